"""The MuJoCo models and the pad mechanics (models/, cosim/pad_geometry.py, pad_model.py, pad_bridge.py).

Objects are defined once, in the scenario library (scenarios/library.py); the one scene file,
models/scene_grasp.xml, holds a placeholder that cosim.assembly.build_scene replaces.

* scene_grasp.xml is the only scene file, and its placeholder object is the ``grasp`` scenario's;
* every registered scenario's scene steps a simulated second from home without warnings;
* squeeze test: the pad's force against indentation follows the gel's law A P(d), for the
  ``grasp`` scenario's box at masses from 1 g to 10 kg (the gripper's rated range: the contact
  itself adds no compliance, whatever the object's mass);
* static cross-checks: gel pressure = contact force / area per strip, gel force = contact force;
* bottoming: past the gel's range the housing takes the load and ``bottomed`` is set;
* the static gripper.xml equals the pads regenerated for its N; keyframes survive regeneration;
* the gripper holds and lifts the ``grasp-10kg`` block; a broken MJCF names its file.
"""

from __future__ import annotations

import re

import mujoco
import numpy as np
import pytest

from piezotip import scenarios
from piezotip.cosim.assembly import build_scene
from piezotip.cosim.pad_bridge import PadBridge, _GelTable
from piezotip.cosim.pad_geometry import DEFAULT_PAD_SEGMENTS, PAD_NAMES, PadGeometry
from piezotip.cosim.pad_model import build_model, scene_names, scene_path
from piezotip.cosim.scene import SCENE_FILE, object_shape, reset_home
from piezotip.scenarios.config import RATED_MASS_KG
from piezotip.sensor.gel import GelModel

GEL = GelModel()
GEOMETRY = PadGeometry()
#: The pads as gripper.xml holds them (N = 5), which the scenarios' default (N = 1) replaces.
FILE_PADS = f"physics.pad_segments={DEFAULT_PAD_SEGMENTS}"

# The squeeze: the `grasp` scenario's box (a 40 mm cube: its faces cover the 20 x 20 mm pads)
# held between the pads away from the table, gravity off.
SQUEEZE_SCENARIO = "grasp"
BOX_HALF_X = object_shape(scenarios.get(SQUEEZE_SCENARIO).object).size[0]  # m: half the width between the pads
LIFT_SQUEEZE = -0.2  # lift_joint: pad centres at z = 0.28 - 0.2 = 0.08 m, the object's centre
SQUEEZE_HEIGHT_M = 0.08


def squeeze_start(model):
    """Gravity off, the object at the pads' height away from the table, the fingers just touching it."""
    model.opt.gravity[:] = 0.0  # the pad law alone: no weight to hold, mass only in the dynamics
    data = mujoco.MjData(model)
    data.qpos[model.joint("lift_joint").qposadr[0]] = data.ctrl[model.actuator("lift_actuator").id] = LIFT_SQUEEZE
    adr = model.joint("object_joint").qposadr[0]
    data.qpos[adr : adr + 7] = [0.0, 0.0, SQUEEZE_HEIGHT_M, 1.0, 0.0, 0.0, 0.0]
    for side in ("left", "right"):
        data.qpos[model.joint(f"{side}_finger_joint").qposadr[0]] = BOX_HALF_X + 2e-4
    data.ctrl[model.actuator("fingers_actuator").id] = 0.0  # close: the servo saturates at its force limit
    mujoco.mj_forward(model, data)
    return model, data, PadBridge(model)


def squeeze_model(mass, pad_segments=DEFAULT_PAD_SEGMENTS):
    """The ``grasp`` scenario's scene with its box at ``mass`` kg, squeezed (:func:`squeeze_start`)."""
    config = scenarios.get(SQUEEZE_SCENARIO, [f"object.mass_kg={mass!r}", f"physics.pad_segments={pad_segments}"])
    return squeeze_start(build_scene(config))


def bar_model(mass, half_z):
    """scene_grasp.xml with its object made a bar 2 ``half_z`` tall (a concentrated load, not a
    project object: a probe), squeezed (:func:`squeeze_start`)."""

    def edit(spec):
        geom = spec.geom("object_geom")
        geom.type = mujoco.mjtGeom.mjGEOM_BOX
        geom.size = [BOX_HALF_X, 0.015, half_z]
        geom.mass = mass

    return squeeze_start(build_model(SCENE_FILE, edit=edit))


def settle(model, data, bridge, grip_force_n, max_time_s=2.0, tol=1e-7, quiet_steps=50):
    """Squeeze with ``grip_force_n`` per finger until every velocity stays below ``tol`` for ``quiet_steps``."""
    model.actuator_forcerange[model.actuator("fingers_actuator").id] = [-grip_force_n, grip_force_n]
    start, quiet = data.time, 0
    while quiet < quiet_steps:
        bridge.apply_gel_forces(data)
        mujoco.mj_step(model, data)
        quiet = quiet + 1 if np.abs(data.qvel).max() < tol else 0
        if data.time - start > max_time_s:
            raise AssertionError(f"no static equilibrium at {grip_force_n} N after {max_time_s} s")


def pad_contact_force(model, data, side):
    """Sum of mj_contactForce normal components over the contacts of one pad's strip geoms."""
    strips = {model.geom(f"{name}_geom").id for name in GEOMETRY.strip_names(side)}
    total, f6 = 0.0, np.zeros(6)
    for i in range(data.ncon):
        if data.contact.geom[i, 0] in strips or data.contact.geom[i, 1] in strips:
            mujoco.mj_contactForce(model, data, i, f6)
            total += f6[0]
    return total


def geometric_indentation(model, data, side):
    """How far the object's face lies inside the pad's unloaded surface, m (contact penetration included)."""
    finger = data.body(f"{side}_finger")
    surface_x = finger.xpos[0]  # the finger frame's origin is the unloaded pad surface's centre
    normal_x = finger.xmat[0]  # the finger's local x (towards the object) in world x
    obj_x = data.body("object").xpos[0]
    face_x = obj_x - BOX_HALF_X * normal_x
    return (surface_x - face_x) * normal_x


def assert_no_warnings(data):
    counts = {mujoco.mjtWarning(i).name: w.number for i, w in enumerate(data.warning) if w.number}
    assert not counts, f"MuJoCo warnings: {counts}"


def step_one_second_at_rest(model, data, bridge):
    """One simulated second from ``data``'s state: no warning, no NaN, the object still at rest."""
    object_start = data.qpos[model.joint("object_joint").qposadr[0] :][:3].copy()
    for _ in range(round(1.0 / model.opt.timestep)):
        if bridge:
            bridge.apply_gel_forces(data)
        mujoco.mj_step(model, data)
    assert_no_warnings(data)
    assert np.all(np.isfinite(data.qpos)) and np.all(np.isfinite(data.qvel))
    # The object rests on the table (contact sinks it by well under a millimetre).
    object_end = data.qpos[model.joint("object_joint").qposadr[0] :][:3]
    np.testing.assert_allclose(object_end, object_start, atol=1e-3)


# ---------------------------------------------------------------------------------------
# The scene and the objects.
# ---------------------------------------------------------------------------------------


def test_scene_grasp_is_the_only_scene_file():
    """Objects live in the scenario library only: no scene file defines another one."""
    assert scene_names() == ("grasp",)
    assert scene_path("grasp") == SCENE_FILE
    with pytest.raises(ValueError, match=r"valid scenes: grasp$"):
        scene_path("no_such_scene")


def test_placeholder_object_is_the_grasp_scenarios():
    """scene_grasp.xml's placeholder (and its `home` key) is the `grasp` scenario's object, read
    from both sides: the file and the library cannot disagree."""
    raw = mujoco.MjModel.from_xml_path(str(SCENE_FILE))
    config = scenarios.get("grasp")
    shape = object_shape(config.object)
    geom, body = raw.geom("object_geom"), raw.body("object")
    assert geom.type[0] == shape.geom_type
    np.testing.assert_allclose(geom.size, shape.size, rtol=0, atol=1e-12)
    assert body.mass[0] == pytest.approx(config.object.mass_kg, rel=1e-12)
    np.testing.assert_allclose(body.pos, [0.0, 0.0, shape.rest_height_m], rtol=0, atol=1e-12)
    # The pad-object friction: pads have priority, so the pads carry the object's friction.
    for side in ("left", "right"):
        for name in GEOMETRY.strip_names(side):
            assert raw.geom(f"{name}_geom").friction[0] == pytest.approx(config.object.friction, rel=1e-12)
    # The file's `home` key is the home state build_scene's scenarios start from.
    keyed, computed = mujoco.MjData(raw), mujoco.MjData(raw)
    mujoco.mj_resetDataKeyframe(raw, keyed, raw.key("home").id)
    reset_home(raw, computed, config)
    np.testing.assert_allclose(keyed.qpos, computed.qpos, rtol=0, atol=1e-12)
    np.testing.assert_allclose(keyed.ctrl, computed.ctrl, rtol=0, atol=1e-12)
    # And building the scenario at the file's pad resolution changes nothing in the model.
    built = build_scene(scenarios.get("grasp", [FILE_PADS]))
    for field in (
        "geom_type",
        "geom_size",
        "geom_pos",
        "geom_friction",
        "body_pos",
        "body_mass",
        "body_inertia",
        "opt.timestep",
        "opt.integrator",
    ):
        obj_a, obj_b, attr = (raw.opt, built.opt, field[4:]) if field.startswith("opt.") else (raw, built, field)
        np.testing.assert_allclose(getattr(obj_b, attr), getattr(obj_a, attr), rtol=1e-6, atol=1e-12, err_msg=field)


@pytest.mark.parametrize("pads", ["scenario", "file"])
@pytest.mark.parametrize("scenario", scenarios.names())
def test_scenario_scene_steps_one_second_clean(scenario, pads):
    """Every registered scenario's scene (its own pad resolution, and gripper.xml's N = 5): one
    second from home, bare and with the gel law: no warning, no NaN, the object at rest."""
    config = scenarios.get(scenario, [] if pads == "scenario" else [FILE_PADS])
    for with_bridge in (False, True):
        model = build_scene(config)  # one model each: a bridge takes over the model's pad joints
        bridge = PadBridge(model) if with_bridge else None
        data = mujoco.MjData(model)
        reset_home(model, data, config)
        step_one_second_at_rest(model, data, bridge)


def test_scene_file_steps_one_second_clean_from_home():
    """MuJoCo's own loader on scene_grasp.xml, then one second from its `home` key, bare and
    with the gel law: no warning, no NaN, the object at rest."""
    for model, bridge in ((mujoco.MjModel.from_xml_path(str(SCENE_FILE)), False), (build_model("grasp"), True)):
        data = mujoco.MjData(model)
        mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
        step_one_second_at_rest(model, data, PadBridge(model) if bridge else None)


def test_scenes_share_the_gripper_conventions():
    config = scenarios.get("grasp-fragile")
    model = build_scene(config)
    for name in ("lift_joint", "left_finger_joint", "right_finger_joint"):
        assert model.joint(name).type[0] == mujoco.mjtJoint.mjJNT_SLIDE
    for name in ("lift_actuator", "fingers_actuator"):
        assert model.actuator(name).forcelimited[0]
    # The grip: 10 kg at mu = 1 needs 49 N per finger; lifting 10 kg needs 98 N plus acceleration.
    assert model.actuator("fingers_actuator").forcerange[1] >= 60
    assert model.actuator("lift_actuator").forcerange[1] >= 2 * 10 * 9.81
    # The crush limit is the library's data, nowhere in the model: a grip can exceed it.
    assert 0 < config.object.crush_force_n < model.actuator("fingers_actuator").forcerange[1]
    with pytest.raises(KeyError):
        model.numeric("object_crush_force")
    for name in ("lift_pos", "fingers_opening", "fingers_force", "left_finger_contact"):
        model.sensor(name)
    assert model.opt.integrator == mujoco.mjtIntegrator.mjINT_DISCRETE


# ---------------------------------------------------------------------------------------
# The pad law.
# ---------------------------------------------------------------------------------------


def test_gel_table_follows_the_gel_model():
    table = _GelTable.build(GEL, GEOMETRY)
    d = np.random.default_rng(0).uniform(0.0, GEOMETRY.stop_m, 1000)
    exact = GEL.pressure_from_indentation(d)
    np.testing.assert_allclose(np.interp(d, table.grid_m, table.pressure_pa), exact, rtol=1e-5, atol=1e-3)
    assert np.all(table.pressure_pa[table.grid_m < 0] < 0)  # the bonded gel pulls back in tension
    assert np.all(np.diff(table.pressure_pa) > 0)


SQUEEZE_MASSES_KG = (RATED_MASS_KG[0], 0.06, 0.5, 2.0, RATED_MASS_KG[1])  # 1 g to 10 kg
SQUEEZE_FORCES_N = (0.5, 5.0, 30.0, 80.0)  # indentations 0.2, 1.4, 3.1, 3.7 mm: strains 4-75 %
SQUEEZE_TOLERANCE = 0.10  # the brief's 10 %; measured errors are below 0.7 %


@pytest.mark.parametrize("mass", SQUEEZE_MASSES_KG)
def test_squeeze_follows_the_gel_law_for_any_mass(mass):
    """Contact normal force (mj_contactForce) against the object's indentation into the pad = A P(d)."""
    model, data, bridge = squeeze_model(mass)
    assert model.body("object").mass[0] == pytest.approx(mass)
    for force in SQUEEZE_FORCES_N:
        settle(model, data, bridge, force)
        assert_no_warnings(data)
        for i, side in enumerate(("left", "right")):
            measured = pad_contact_force(model, data, side)
            d = geometric_indentation(model, data, side)
            law = GEOMETRY.pad_area_m2 * float(GEL.pressure_from_indentation(d))
            assert measured == pytest.approx(law, rel=SQUEEZE_TOLERANCE), f"{side}: {measured} N vs A P({d}) = {law} N"
            assert measured == pytest.approx(force, rel=1e-3)  # the servo's force limit is the grip
            # Static cross-checks: the gel's pressure is the contact pressure, strip by strip.
            reading = bridge.read(data)[PAD_NAMES[i]]
            assert not reading.bottomed
            assert reading.gel_force_n == pytest.approx(measured, rel=1e-4)
            assert reading.normal_force_n == pytest.approx(measured, rel=1e-4)
            contact_pressure = bridge.strip_contact_forces(data)[i] / GEOMETRY.strip_areas_m2
            np.testing.assert_allclose(bridge.strip_pressures(data)[i], contact_pressure, rtol=1e-3)
            assert reading.mean_pressure_pa == pytest.approx(force / GEOMETRY.pad_area_m2, rel=1e-2)
            assert reading.contact_area_m2 == pytest.approx(GEOMETRY.pad_area_m2)
            # The contact rests at most its impedance's width deep (models/gripper.xml, class pad):
            # the gel's indentation is the object's less that depth.
            width_m = float(model.geom_solimp[model.geom(f"{side}_pad_seg0_geom").id, 2])
            assert np.all(reading.indentation_m <= d + 1e-9) and np.all(reading.indentation_m >= d - width_m)


@pytest.mark.parametrize("segments", [1, 2, 8])
def test_other_pad_resolutions_squeeze_statically(segments):
    model, data, bridge = squeeze_model(0.06, pad_segments=segments)
    assert bridge.geometry.segments == segments
    settle(model, data, bridge, 20.0)
    readings = bridge.read(data)
    for i, name in enumerate(PAD_NAMES):
        assert readings[name].segment_pressure_pa.shape == (segments,)
        assert readings[name].gel_force_n == pytest.approx(20.0, rel=1e-3)
        np.testing.assert_allclose(bridge.element_pressures(data)[i], readings[name].segment_pressure_pa)


@pytest.mark.parametrize(("segments", "grip"), [(5, 3.0), (5, 10.0), (5, 30.0), (1, 30.0), (9, 45.0)])
def test_egg_settles_and_loads_the_element_centre_most(segments, grip):
    """A curved object on the table (the `grasp-fragile` egg): the grasp settles (it touches the
    guards at their edges, where friction once drove a limit cycle); the strips under its equator
    carry the most pressure."""
    config = scenarios.get("grasp-fragile", [f"physics.pad_segments={segments}"])
    assert config.object.shape == "egg"
    model = build_scene(config)
    data = mujoco.MjData(model)
    bridge = PadBridge(model)
    assert bridge.geometry.segments == segments
    reset_home(model, data, config)
    data.ctrl[model.actuator("fingers_actuator").id] = 0.0
    settle(model, data, bridge, grip, tol=1e-5)  # the egg creeps on the table at < 1 um/s
    for _ in range(500):  # and stays settled: a limit cycle grows over a few tenths of a second
        bridge.apply_gel_forces(data)
        mujoco.mj_step(model, data)
        assert np.abs(data.qvel).max() < 1e-4
    assert_no_warnings(data)
    pressures = bridge.strip_pressures(data)
    for i in range(2):
        assert pressures[i, 0] < pressures[i, 1:-1].min() and pressures[i, -1] < pressures[i, 1:-1].min()
        assert bridge.read(data)[PAD_NAMES[i]].gel_force_n == pytest.approx(grip, rel=1e-3)


def test_bottoming_engages_the_housing():
    """A 4 mm bar pressed with 60 N: its strips reach the 4 mm stop, the housing takes the rest."""
    model, data, bridge = bar_model(0.06, half_z=0.002)
    settle(model, data, bridge, 10.0)  # 10 N on 3 strips (90 mm^2): 111 kPa, inside the gel's range
    assert not any(r.bottomed for r in bridge.read(data).values())
    settle(model, data, bridge, 60.0)  # 667 kPa > 383 kPa at the stop
    stop_pressure = float(GEL.pressure_from_indentation(GEOMETRY.stop_m))
    for i, (name, reading) in enumerate(bridge.read(data).items()):
        assert reading.bottomed, name
        assert reading.indentation_m.max() == pytest.approx(GEOMETRY.stop_m, abs=5e-6)
        assert reading.segment_pressure_pa.max() == pytest.approx(stop_pressure, rel=1e-3)
        assert reading.gel_force_n < 50.0  # the gel alone cannot carry the load any more ...
        assert reading.normal_force_n == pytest.approx(60.0, rel=1e-3)  # ... the housing carries the rest
        assert pad_contact_force(model, data, ("left", "right")[i]) == pytest.approx(60.0, rel=1e-3)


# ---------------------------------------------------------------------------------------
# Generated pads, keyframes, the lift, errors.
# ---------------------------------------------------------------------------------------


def test_static_gripper_equals_generated_pads():
    static = build_model("grasp")
    generated = build_model("grasp", pad_segments=DEFAULT_PAD_SEGMENTS)
    for field in (
        "body_pos",
        "body_mass",
        "body_gravcomp",
        "geom_size",
        "geom_pos",
        "geom_solref",
        "geom_solimp",
        "geom_friction",
        "geom_priority",
        "geom_contype",
        "geom_conaffinity",
        "jnt_range",
        "jnt_solref",
        "jnt_solimp",
        "jnt_stiffness",
        "dof_damping",
        "key_qpos",
        "key_ctrl",
    ):
        np.testing.assert_allclose(getattr(static, field), getattr(generated, field), rtol=1e-6, atol=1e-12, err_msg=field)
    assert [static.body(i).name for i in range(static.nbody)] == [generated.body(i).name for i in range(generated.nbody)]


def test_regenerated_pads_keep_the_keyframe():
    static = build_model("grasp")
    coarse = build_model("grasp", pad_segments=2)
    assert static.nkey == coarse.nkey == 1
    assert coarse.nq == static.nq - 2 * (DEFAULT_PAD_SEGMENTS - 2)
    for name in ("lift_joint", "left_finger_joint", "right_finger_joint", "object_joint"):
        a, b = static.joint(name).qposadr[0], coarse.joint(name).qposadr[0]
        n = 7 if name == "object_joint" else 1
        np.testing.assert_array_equal(coarse.key_qpos[0, b : b + n], static.key_qpos[0, a : a + n])
    np.testing.assert_array_equal(coarse.key_ctrl, static.key_ctrl)


def test_gripper_lifts_10_kg_without_slip():
    """The `grasp-10kg` block: close with the full 100 N, lift 5 cm at 10 cm/s, hold: the block follows the palm."""
    config = scenarios.get("grasp-10kg", [FILE_PADS])
    assert config.object.mass_kg == RATED_MASS_KG[1]
    model = build_scene(config)
    data = mujoco.MjData(model)
    bridge = PadBridge(model)
    reset_home(model, data, config)
    lift, fingers = model.actuator("lift_actuator").id, model.actuator("fingers_actuator").id
    lift0, rest_z = data.ctrl[lift], data.body("object").xpos[2]
    data.ctrl[fingers] = 0.0
    offsets = []
    while data.time < 1.6:
        if data.time > 0.5:
            data.ctrl[lift] = lift0 + min(0.05, 0.1 * (data.time - 0.5))
        bridge.apply_gel_forces(data)
        mujoco.mj_step(model, data)
        if data.time > 0.45:
            offsets.append(data.body("palm").xpos[2] - data.body("object").xpos[2])
    assert_no_warnings(data)
    assert data.body("object").xpos[2] > rest_z + 0.04  # lifted (servo sag ~5 mm under 10 kg)
    assert np.ptp(offsets) < 1e-3  # no slip along the pads
    assert not any(r.bottomed for r in bridge.read(data).values())


def test_explicit_integrators_are_refused_at_this_timestep():
    model = build_scene(scenarios.get("grasp-light", [FILE_PADS, "physics.integrator=implicitfast"]))
    assert model.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    with pytest.raises(ValueError, match="discrete"):
        PadBridge(model)


@pytest.mark.parametrize(("timestep", "constant"), [(5e-4, 2e-3), (1e-3, 2e-3), (2.5e-3, 5e-3)])
def test_timestep_keeps_the_pad_time_constant_above_two_steps(timestep, constant):
    """The pads' contact time constant is the physical 2 ms, floored at 2 timesteps: for the scene
    file (build_model) and for a scenario's scene (build_scene, its physics.timestep_s)."""
    for model in (
        build_model("grasp", timestep=timestep),
        build_scene(scenarios.get("grasp-light", [FILE_PADS, f"physics.timestep_s={timestep!r}"])),
    ):
        assert model.opt.timestep == timestep
        assert model.geom("left_pad_seg0_geom").solref[0] == pytest.approx(constant)
        assert model.joint("right_pad_guard_upper_joint").solref[0] == pytest.approx(constant)


def test_broken_mjcf_names_its_file(tmp_path):
    broken = tmp_path / "broken_scene.xml"
    broken.write_text('<mujoco><worldbody><geom type="box" sizee="1"/></worldbody></mujoco>')
    with pytest.raises(ValueError, match=re.escape("broken_scene.xml")):
        build_model(broken)
    missing_include = tmp_path / "scene_missing.xml"
    missing_include.write_text('<mujoco><include file="no_gripper.xml"/></mujoco>')
    with pytest.raises(ValueError, match=re.escape("scene_missing.xml")):
        build_model(missing_include)
    with pytest.raises(ValueError, match=re.escape("nowhere.xml")):
        build_model(tmp_path / "nowhere.xml")


def test_pad_geometry_validates():
    assert GEOMETRY.strip_areas_m2.sum() == pytest.approx(GEOMETRY.pad_area_m2)
    np.testing.assert_allclose(GEOMETRY.segment_centers_m, [-3e-3, -1.5e-3, 0.0, 1.5e-3, 3e-3], atol=1e-15)
    assert PadGeometry(segments=3, pad_length_m=7.5e-3).strip_names("left") == ("left_pad_seg0", "left_pad_seg1", "left_pad_seg2")
    for bad in ({"segments": 0}, {"element_length_m": 0.03}, {"stop_strain": 1.0}, {"retain_m": -1e-3}):
        with pytest.raises(ValueError):
            PadGeometry(**bad)


def _pads_on_a_sphere(condim: int, torsion_m: float, friction: float, squeeze_n: float, torque_n_m: float) -> float:
    """Two boxes on slides squeezing a free 10 mm sphere with ``squeeze_n`` each (gravity off),
    their contacts of ``condim`` and torsional coefficient ``torsion_m`` (m); a torque
    ``torque_n_m`` (N m) about the squeeze axis on the sphere for 0.3 s: its spin about that
    axis then, rad/s."""
    xml = f"""<mujoco><option gravity="0 0 0" timestep="0.001" cone="elliptic" impratio="1000"/>
      <default><geom condim="{condim}" friction="{friction} {torsion_m} 0.0001" priority="1" solref="0.002 1"/></default>
      <worldbody>
        <body name="left" pos="-0.015 0 0"><joint name="l" type="slide" axis="1 0 0" damping="5"/>
          <geom type="box" size="0.005 0.01 0.01" mass="0.02"/></body>
        <body name="right" pos="0.015 0 0"><joint name="r" type="slide" axis="-1 0 0" damping="5"/>
          <geom type="box" size="0.005 0.01 0.01" mass="0.02"/></body>
        <body name="ball"><freejoint name="ball"/>
          <geom type="sphere" size="0.01" mass="0.01" priority="0" condim="3" friction="0.5 0.005 0.0001"/></body>
      </worldbody>
      <actuator><motor joint="l"/><motor joint="r"/></actuator></mujoco>"""
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    data.ctrl[:] = squeeze_n
    ball = model.body("ball").id
    for step in range(round(0.5 / model.opt.timestep)):
        if step * model.opt.timestep >= 0.2:
            data.xfrc_applied[ball, 3] = torque_n_m
        mujoco.mj_step(model, data)
    return float(abs(data.qvel[model.jnt_dofadr[model.joint("ball").id] + 3]))


def test_the_pads_hold_an_object_as_soft_fingers_do_against_a_spin_about_the_grip():
    """The pads' contacts are soft fingers (condim 4: the gel's patch resists a spin about its
    normal, up to mu_t N a contact): held at two point contacts (a sphere, a cylinder's edge, a
    linkage's tilted pads), an object spun about the grip axis stays below 2 mu_t N and turns past
    it; with sliding friction only it turns at any torque.  Dm_robotics' 2F-85 let a 7 g, 21 mm
    cylinder swing about its pads' two contacts as the place slowed its descent, and struck the
    table (tests/test_third_party_grippers.py::test_robotiqs_pads_hold_a_light_cylinder_without_letting_it_swing).
    The pad class's own coefficient (models/gripper.xml), on the scenes it builds."""
    model = build_scene(scenarios.get("grasp"))
    pads = [g for g in range(model.ngeom) if model.geom(g).name.startswith(PAD_NAMES)]
    assert pads and {int(model.geom_condim[g]) for g in pads} == {4}
    torsion = float(model.geom_friction[pads[0], 1])
    squeeze = 1.0
    limit = 2.0 * torsion * squeeze  # two contacts' torsional friction, N m
    assert _pads_on_a_sphere(4, torsion, 1.0, squeeze, 0.5 * limit) < 0.05
    assert _pads_on_a_sphere(4, torsion, 1.0, squeeze, 2.0 * limit) > 1.0
    assert _pads_on_a_sphere(3, torsion, 1.0, squeeze, 0.5 * limit) > 1.0  # sliding friction only: it turns
