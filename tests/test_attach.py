"""piezotip.attach: the fingertip as a component on a model built here from scratch (cosim/attach.py).

The models: fingers fixed in the world, a box site (or a body's face) carrying each pad, and a
plate on a vertical slide joint resting on one pad with its weight.  The joint's dashpot damps
the plate critically at the pad's stiffness under that load (it carries no static force), so
the pad settles to exactly the plate's weight: the true pressure is m g / A over the pad.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

import piezotip
from piezotip.cosim.attach import PREFIX, attach
from piezotip.cosim.pad_model import apply_pad_contact, build_model
from piezotip.scenarios import SensorConfig
from piezotip.sensor.gel import GelParams, stretch_from_pressure, winkler_stiffness_n_m3

GEL = GelParams()
H0 = GEL.thickness_m
PLATE_KG = 0.1
G = 9.81
PAD_HALF_M = 0.01  # the sites' x/y half-sizes: a 20 x 20 mm pad, the house's
PAD_AREA_M2 = (2 * PAD_HALF_M) ** 2
PRESSURE_PA = PLATE_KG * G / PAD_AREA_M2  # 2452.5 Pa
FINGER_TOP_M = 0.11  # the fingers' top faces (the pads' bases), m


def _dashpot_n_s_m() -> float:
    """Critical damping of the plate on the pad at its load: 2 sqrt(k m), k = A k_w(P)."""
    k = PAD_AREA_M2 * float(winkler_stiffness_n_m3(stretch_from_pressure(PRESSURE_PA, GEL), GEL))
    return 2.0 * math.sqrt(k * PLATE_KG)


def scene_xml(
    option: str = '<option integrator="discrete" timestep="0.001"/>', pad_type: str = "box", pad_half_x_m: float = PAD_HALF_M, key: str = ""
) -> str:
    """Two fixed fingers side by side, each with a box site on its top face; the plate rests on
    the first, its bottom on the unloaded gel's free surface."""
    plate_z = FINGER_TOP_M + H0 + 0.005
    return f"""<mujoco model="two pads">
  {option}
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <body name="pressed_finger" pos="0 0 0.1">
      <geom name="pressed_finger_geom" type="box" size="0.015 0.015 0.01"/>
      <site name="pressed" type="{pad_type}" size="{pad_half_x_m} {PAD_HALF_M} 0.001" pos="0 0 0.01"/>
    </body>
    <body name="free_finger" pos="0.1 0 0.1">
      <geom name="free_finger_geom" type="box" size="0.015 0.015 0.01"/>
      <site name="free" type="box" size="{PAD_HALF_M} {PAD_HALF_M} 0.001" pos="0 0 0.01"/>
    </body>
    <body name="plate" pos="0 0 {plate_z}">
      <joint name="press" type="slide" axis="0 0 1" damping="{_dashpot_n_s_m():.6g}"/>
      <geom name="plate_geom" type="box" size="0.02 0.02 0.005" mass="{PLATE_KG}"/>
    </body>
  </worldbody>
  {key}
</mujoco>"""


def run(sim, periods: int) -> list[dict]:
    out = []
    for _ in range(periods):
        sim.step()
        out.append(sim.readings())
    return out


@pytest.fixture(scope="module")
def settled():
    """The two-pad scene with default fingertips: 1 s to settle, then 1 s of readings."""
    spec = mujoco.MjSpec.from_string(scene_xml())
    tips = attach(spec, sites=["pressed", "free"])
    model = spec.compile()
    data = mujoco.MjData(model)
    sim = tips.bind(model, data)
    periods = round(1.0 / sim.period_s)
    run(sim, periods)
    return sim, run(sim, periods)


def test_pressed_pad_reads_the_plates_weight_within_three_sigma(settled):
    sim, window = settled
    state = sim.pad_state("pressed")
    assert state.normal_force_n == pytest.approx(PLATE_KG * G, rel=1e-6)  # statics are exact
    assert not state.bottomed
    pressed = [readings["pressed"] for readings in window]
    assert all(r.true_pressure_pa == pytest.approx(PRESSURE_PA, rel=1e-6) for r in pressed)
    ok = [r for r in pressed if r.status == "ok"]
    assert len(ok) >= 0.95 * len(pressed)  # the rest "settling": the readout's change detection on noise
    assert {r.status for r in pressed} <= {"ok", "settling"}
    for r in ok:
        assert abs(r.estimate_pa - PRESSURE_PA) <= 3 * r.sigma_pa
        assert r.sigma_pa < 0.1 * PRESSURE_PA  # a reading, not a shrug
        assert r.mode == 1 and 0 < r.v1 < 1 and r.voltage > 0


def test_unpressed_pad_reads_below_detection(settled):
    _, window = settled
    statuses = [readings["free"].status for readings in window]
    assert "ok" not in statuses and "saturated" not in statuses
    assert statuses.count("below_detection") >= 0.95 * len(statuses)  # now and then "settling" on noise
    assert all(abs(readings["free"].true_pressure_pa) < 1e-9 for readings in window)


def test_set_mode_changes_the_driven_mode():
    spec = mujoco.MjSpec.from_string(scene_xml())
    tips = attach(spec, sites=["pressed", "free"], config={"sensor.quality_factor": 70})
    model = spec.compile()
    sim = tips.bind(model, mujoco.MjData(model))
    sim.step()
    assert {r.mode for r in sim.readings().values()} == {1}
    sim.set_mode("pressed", 2)
    sim.step()
    assert sim.readings()["pressed"].mode == 2
    assert sim.readings()["free"].mode == 1
    assert sim.readings()["pressed"].status == "settling"  # the new mode rings up
    with pytest.raises(ValueError, match="mode 7"):
        sim.set_mode("pressed", 7)
    with pytest.raises(ValueError, match="'elsewhere'"):
        sim.set_mode("elsewhere", 1)


def test_a_configured_fingertip_reads_the_weight_too():
    """Soft PZT (Q 70, sensor.quality_factor) at 2 ms periods (physics.control_period_s)."""
    spec = mujoco.MjSpec.from_string(scene_xml())
    config = {"sensor.quality_factor": 70, "physics.control_period_s": 0.002}
    tips = attach(spec, sites=["pressed"], config=config)
    model = spec.compile()
    sim = tips.bind(model, mujoco.MjData(model))
    assert (sim.period_s, sim.substeps) == (0.002, 2)
    run(sim, 250)
    r = sim.readings()["pressed"]
    assert r.status == "ok" and abs(r.estimate_pa - PRESSURE_PA) <= 3 * r.sigma_pa


def test_a_sensor_config_dataclass_configures_the_fingertips():
    sensor = SensorConfig(quality_factor=70.0, modes=(1, 2), coverage_mm=(6.0, 7.5))
    tips = attach(mujoco.MjSpec.from_string(scene_xml()), sites=["pressed"], config=sensor)
    assert tips.config.sensor == sensor  # its pads aside: the sites are the fingertips
    assert tips.fingertip.modes == (1, 2) and tips.fingertip.coverage == pytest.approx((6.0e-3, 7.5e-3))


# -- errors ------------------------------------------------------------------------------


def flag(setting: str) -> str:
    return f'<option integrator="discrete" timestep="0.001"><flag {setting}/></option>'


@pytest.mark.parametrize(
    ("kwargs", "xml", "match"),
    [
        ({"sites": ["missing_pad"]}, scene_xml(), "site 'missing_pad' is not in the model"),
        ({"bodies": ["missing_finger", "free_finger"]}, scene_xml(), "body 'missing_finger' is not in the model"),
        ({"sites": ["pressed"]}, scene_xml(pad_type="sphere"), "site 'pressed' is a sphere; a pad's site must be a box"),
        ({"sites": ["pressed"]}, scene_xml(option=flag('contact="disable"')), "disables 'contact'"),
        ({"sites": ["pressed"]}, scene_xml(option=flag('spring="disable"')), "disables 'spring'"),
        ({"sites": ["pressed"]}, scene_xml(option=flag('limit="disable"')), "disables 'limit'"),
        ({"sites": ["pressed"]}, scene_xml(option=flag('override="enable"')), "enables 'override'"),
        ({"sites": ["pressed"], "config": {"sensor.quality_factor": 1}}, scene_xml(), "sensor.quality_factor must be at least 50"),
        ({"sites": ["pressed"], "config": {"sensor.colour": 1}}, scene_xml(), "unknown fingertip key 'sensor.colour'"),
        ({"sites": ["pressed"], "config": {"physics.timestep_s": 0.001}}, scene_xml(), "physics.timestep_s is the model's own option"),
        ({"sites": ["pressed"], "config": {"sensor.pads": ["left"]}}, scene_xml(), "sensor.pads does not apply"),
        ({"sites": ["pressed"], "config": {"physics.pad_segments": 0}}, scene_xml(), "physics.pad_segments must be an integer in 1..64"),
        ({"sites": ["pressed", "pressed"]}, scene_xml(), r"\['pressed'\] repeated"),
        ({"bodies": ["pressed_finger"]}, scene_xml(), "give two or more bodies"),
        ({}, scene_xml(), "give the fingertips' sites"),
        ({"sites": ["pressed"], "pad": "foam"}, scene_xml(), "unknown pad 'foam'; valid: gel, touch"),
        ({"sites": ["pressed"], "pad": "touch"}, scene_xml(option=flag('contact="disable"')), "disables 'contact'"),
    ],
)
def test_bad_input_is_a_value_error_naming_it(kwargs, xml, match):
    spec = mujoco.MjSpec.from_string(xml)
    before = spec.to_xml()
    with pytest.raises(ValueError, match=match):
        attach(spec, **kwargs)
    assert spec.to_xml() == before  # a refused attach leaves the spec as it was


def test_a_pad_smaller_than_the_element_is_refused():
    xml = scene_xml(pad_half_x_m=0.003)  # 6 mm along the element's 7.5 mm
    with pytest.raises(ValueError, match=r"site 'pressed': its pad \(6 x 20 mm, x by y\) is smaller than the sensor element"):
        attach(mujoco.MjSpec.from_string(xml), sites=["pressed"])


def test_attach_once_per_spec():
    spec = mujoco.MjSpec.from_string(scene_xml())
    attach(spec, sites=["pressed"])
    with pytest.raises(ValueError, match="already has piezotip fingertips"):
        attach(spec, sites=["free"])


def test_bind_refuses_a_model_options_change_after_attach():
    spec = mujoco.MjSpec.from_string(scene_xml())
    tips = attach(spec, sites=["pressed"])
    model = spec.compile()
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    with pytest.raises(ValueError, match="bind: the model disables 'contact'"):
        tips.bind(model, mujoco.MjData(model))


# -- the user's model otherwise untouched --------------------------------------------------


def _named(model: mujoco.MjModel, kind: str, count: int) -> list[str]:
    return [getattr(model, kind)(i).name for i in range(count)]


def test_the_users_model_is_unchanged_but_for_prefixed_additions():
    key = '<keyframe><key name="pressed_in" qpos="-0.0004"/></keyframe>'
    spec = mujoco.MjSpec.from_string(scene_xml(key=key))
    before = spec.compile()
    tips = attach(spec, sites=["pressed", "free"])
    after = spec.compile()
    for kind, n in (("body", "nbody"), ("geom", "ngeom"), ("joint", "njnt"), ("site", "nsite"), ("key", "nkey")):
        names = _named(after, kind, getattr(after, n))
        assert [x for x in names if not x.startswith(PREFIX)] == _named(before, kind, getattr(before, n))
    strips = [s for pad in tips.pads for s in pad.strips]
    assert len(strips) == 6  # two pads of a guard, one segment, a guard
    assert after.njnt - before.njnt == len(strips) and after.nq - before.nq == len(strips)
    for name in _named(before, "geom", before.ngeom):
        for field in ("size", "pos", "quat", "friction", "solref", "solimp", "contype", "conaffinity", "priority", "condim"):
            assert np.array_equal(getattr(after.geom(name), field), getattr(before.geom(name), field)), (name, field)
    for name in _named(before, "body", before.nbody)[1:]:
        for field in ("pos", "quat"):
            assert np.array_equal(getattr(after.body(name), field), getattr(before.body(name), field)), (name, field)
    for field in (
        "timestep",
        "integrator",
        "gravity",
        "disableflags",
        "enableflags",
        "cone",
        "impratio",
        "solver",
        "iterations",
        "tolerance",
    ):
        assert np.array_equal(getattr(after.opt, field), getattr(before.opt, field)), field
    # The keyframe's joint keeps its value; the strips start unloaded.
    press = after.joint("press").qposadr[0]
    assert after.key_qpos[0][press] == -0.0004
    assert np.count_nonzero(after.key_qpos[0]) == 1
    assert not [
        b
        for b in _named(after, "body", after.nbody)
        if b.startswith(PREFIX) and not b.startswith(f"{PREFIX}pressed/") and not b.startswith(f"{PREFIX}free/")
    ]


def test_the_pads_are_the_house_grippers():
    """The strips' contact (the hard one), housing stop, stiffness and damping per area are gripper.xml's."""
    spec = mujoco.MjSpec.from_string(scene_xml())
    attach(spec, sites=["pressed"], config={"physics.pad_segments": 5})
    ours = spec.compile()
    house = build_model("grasp")  # N = 5 as the file holds it, at its 1 ms step
    # attach's contacts are the house's hard ones: its compliant ones need impratio 100, and the
    # user's model keeps its own options (cosim.pad_model.resolve_pad_contact).
    apply_pad_contact(house, "hard")
    for strip in ("guard_lower", "seg0", "seg4", "guard_upper"):
        mine, theirs = f"{PREFIX}pressed/{strip}", f"left_pad_{strip}"
        for field in ("size", "solref", "solimp", "friction", "priority", "condim", "contype", "conaffinity"):
            assert np.allclose(getattr(ours.geom(f"{mine}_geom"), field), getattr(house.geom(f"{theirs}_geom"), field)), (strip, field)
        for field in ("range", "solref", "solimp", "stiffness", "damping"):
            assert np.allclose(getattr(ours.joint(f"{mine}_joint"), field), getattr(house.joint(f"{theirs}_joint"), field)), (strip, field)
        assert ours.body(mine).mass == pytest.approx(house.body(theirs).mass, rel=1e-12)


def test_a_turned_site_carries_its_pad_along_its_axes():
    """A site whose +z is world +x and whose x is world +z: the gel stands out along world x,
    the strips run up world z, distal (the lower guard) first."""
    xml = """<mujoco><option integrator="discrete" timestep="0.001"/><worldbody>
      <body name="finger" pos="0 0 0.2"><geom type="box" size="0.01 0.015 0.02"/>
        <site name="side" type="box" size="0.01 0.01 0.001" pos="0.01 0 0" xyaxes="0 0 1 0 -1 0"/></body>
    </worldbody></mujoco>"""
    spec = mujoco.MjSpec.from_string(xml)
    attach(spec, sites=["side"], config={"physics.pad_segments": 3})
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    centres = np.array(
        [data.geom_xpos[model.geom(f"{PREFIX}side/{s}_geom").id] for s in ("guard_lower", "seg0", "seg1", "seg2", "guard_upper")]
    )
    assert np.allclose(centres[:, 0], 0.01 + 0.5 * H0)  # the gel column, from the face out by h0
    assert np.allclose(centres[:, 1], 0.0)
    assert np.all(np.diff(centres[:, 2]) > 0) and centres[2, 2] == pytest.approx(0.2)


# -- bodies ------------------------------------------------------------------------------


def two_bodies_xml(option: str, plate_z_m: float) -> str:
    """Two fingers one above the other, 30 mm square boxes (their faces towards each other
    carry the pads), and the plate on its dashpot at ``plate_z_m`` (its centre, m)."""
    return f"""<mujoco>{option}<worldbody>
      <body name="lower" pos="0 0 0.1"><geom type="box" size="0.015 0.015 0.01"/></body>
      <body name="upper" pos="0 0 0.3"><geom type="box" size="0.015 0.015 0.01"/></body>
      <body name="plate" pos="0 0 {plate_z_m}">
        <joint name="press" type="slide" axis="0 0 1" damping="{_dashpot_n_s_m():.6g}"/>
        <geom type="box" size="0.02 0.02 0.005" mass="{PLATE_KG}"/>
      </body>
    </worldbody></mujoco>"""


def test_pads_on_bodies_face_each_other_and_read_the_weight():
    """Two fingers one above the other: the lower's pad on its top face (towards the upper),
    the upper's on its bottom face; the plate rests on the lower pad.  Their faces are 30 mm
    square, so each pad is the house's 20 x 20 mm."""
    spec = mujoco.MjSpec.from_string(two_bodies_xml('<option integrator="discrete" timestep="0.001"/>', FINGER_TOP_M + H0 + 0.005))
    tips = attach(spec, bodies=["lower", "upper"])
    assert [(p.geometry.pad_length_m, p.geometry.pad_width_m) for p in tips.pads] == [(0.02, 0.02)] * 2
    model = spec.compile()
    data = mujoco.MjData(model)
    sim = tips.bind(model, data)
    mujoco.mj_forward(model, data)
    lower = data.geom_xpos[model.geom(f"{PREFIX}lower/seg0_geom").id]
    upper = data.geom_xpos[model.geom(f"{PREFIX}upper/seg0_geom").id]
    assert lower[2] == pytest.approx(FINGER_TOP_M + 0.5 * H0, abs=1e-9)  # lower pad on the top face
    assert upper[2] == pytest.approx(0.29 - 0.5 * H0, abs=1e-9)  # upper pad on the bottom face
    run(sim, round(1.0 / sim.period_s))
    r = sim.readings()
    assert r["lower"].true_pressure_pa == pytest.approx(PRESSURE_PA, rel=1e-6)
    assert r["lower"].status == "ok" and abs(r["lower"].estimate_pa - PRESSURE_PA) <= 3 * r["lower"].sigma_pa
    assert r["upper"].status == "below_detection"


def test_touch_pads_on_bodies_read_the_whole_face_and_leave_the_model_as_it_was():
    """``pad="touch"`` on bodies: each zone is the body's whole face towards the other (a 30 mm
    box's corners carry a resting plate), the plate's weight over that face presses the element;
    no body, geom or joint is added, and a spring-less model (a touch pad needs no spring) is taken."""
    xml = two_bodies_xml('<option><flag spring="disable"/></option>', FINGER_TOP_M + 0.005)
    spec = mujoco.MjSpec.from_string(xml)
    tips = attach(spec, bodies=["lower", "upper"], pad="touch")
    assert [(p.kind, p.strips, p.area_m2) for p in tips.pads] == [("touch", (), pytest.approx(0.03 * 0.03))] * 2
    model = spec.compile()
    bare = mujoco.MjModel.from_xml_string(xml)
    assert (model.nbody, model.ngeom, model.njnt, model.nsite) == (bare.nbody, bare.ngeom, bare.njnt, bare.nsite + 2)
    data = mujoco.MjData(model)
    sim = tips.bind(model, data)
    mujoco.mj_forward(model, data)
    zone = data.site_xpos[model.site(f"{PREFIX}lower/zone").id]
    assert zone[2] == pytest.approx(FINGER_TOP_M, abs=1e-12)  # on the lower body's top face
    run(sim, round(1.0 / sim.period_s))
    r = sim.readings()
    face_pressure_pa = PLATE_KG * G / 0.03**2
    assert sim.pad_state("lower").normal_force_n == pytest.approx(PLATE_KG * G, rel=1e-6)
    assert r["lower"].true_pressure_pa == pytest.approx(face_pressure_pa, rel=1e-6)
    assert r["lower"].status == "ok" and abs(r["lower"].estimate_pa - face_pressure_pa) <= 3 * r["lower"].sigma_pa
    assert r["upper"].status == "below_detection" and sim.pad_state("upper").normal_force_n == 0.0


def test_attach_is_exported():
    assert piezotip.attach is attach


def test_a_diverged_step_is_an_error_not_a_silent_reset():
    """MuJoCo resets the data to the model's initial state on a bad velocity or acceleration,
    warns and steps on (mj_checkVel, mj_checkAcc): the state is finite again, and the fingertips
    read a reset scene as if nothing happened.  The step names the warning instead."""
    from piezotip.cosim.loop import SimulationDiverged

    spec = mujoco.MjSpec.from_string(scene_xml())
    tips = attach(spec, sites=["pressed", "free"])
    model = spec.compile()
    data = mujoco.MjData(model)
    sim = tips.bind(model, data)
    run(sim, 3)
    data.qvel[:] = np.nan
    with pytest.raises(SimulationDiverged, match="mjWARN_BADQVEL"):
        sim.step()
    assert np.all(np.isfinite(data.qvel))  # what MuJoCo left: a reset state, finite


@pytest.mark.parametrize(
    "given",
    [
        None,
        {"sensor.quality_factor": 70, "physics.control_period_s": 0.002},
        {"sensor.modes": [1, 2], "sensor.coverage_mm": [6, 7.5], "physics.pad_segments": 3},
        {"sensor.seed": np.int64(5), "sensor.noise": "false", "physics.gel_update": "substep", "physics.control_period_s": 0.0031},
        SensorConfig(quality_factor=80.0, modes=(1, 2, 3), dynamics="steady"),
    ],
)
def test_the_fingertip_config_is_the_default_grasp_s_with_the_keys_given(given):
    """attach makes its config itself, below the scenarios (cosim/attach.py): the default grasp's
    with the given keys, at the model's options, under the scripted controller over the sensor's
    modes, as the scenario library makes it from the same keys."""
    from piezotip import scenarios
    from piezotip.cosim.attach import fingertip_config

    spec = mujoco.MjSpec()
    spec.option.timestep = 0.0005
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    config = fingertip_config(given, spec.option)
    keys = {f"sensor.{k}": getattr(given, k) for k in ("quality_factor", "modes", "dynamics")} if isinstance(given, SensorConfig) else given
    asked = (keys or {}).get("physics.control_period_s", 0.005)
    options = {
        "physics.timestep_s": 0.0005,
        "physics.integrator": "implicitfast",
        "physics.control_period_s": round(asked / 0.0005) * 0.0005,
    }
    modes = {"controller.modes": config.sensor.modes}
    expected = scenarios.get("grasp", {"controller.kind": "scripted", **modes, **(keys or {}), **options})
    assert config == expected
