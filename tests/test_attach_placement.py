"""piezotip.attach: what the pads touch (their collision bits) and which face they go on (the pose
the faces are read in), on models built here (cosim/attach.py, docs/attach.md "Where the pad goes").

The collision scenes are tests/test_attach.py's plate on a pad, with other contype/conaffinity
bits; the placement models are two slide fingers that are closed, crossed or coincident at qpos0.
"""

from __future__ import annotations

import importlib.util
import math
import warnings
from pathlib import Path

import mujoco
import numpy as np
import pytest

from piezotip.cosim.attach import PREFIX, PadCollisionWarning, attach, fingertip_pads, open_pose_qpos, pad_collision_bits
from piezotip.sensor.gel import GelParams, stretch_from_pressure, winkler_stiffness_n_m3

H0 = GelParams().thickness_m
PLATE_KG = 0.1
G = 9.81
PAD_AREA_M2 = 0.02**2  # the sites' 20 x 20 mm pads, the house's
PRESSURE_PA = PLATE_KG * G / PAD_AREA_M2


def _dashpot_n_s_m() -> float:
    """Critical damping of the plate on the pad at its load (tests/test_attach.py's)."""
    k = PAD_AREA_M2 * float(winkler_stiffness_n_m3(stretch_from_pressure(PRESSURE_PA, GelParams()), GelParams()))
    return 2.0 * math.sqrt(k * PLATE_KG)


# -- collision filters -------------------------------------------------------------------


def plate_scene(fingers: str = "", plate: str = "", extra: str = "") -> str:
    """Two fixed fingers with a box site on each top face, the plate resting on the first pad;
    ``fingers`` and ``plate`` are attributes of their geoms (contype, conaffinity), ``extra`` more
    of the world's geoms."""
    plate_z = 0.11 + H0 + 0.005
    return f"""<mujoco model="plate on a pad">
  <option integrator="discrete" timestep="0.001"/>
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    {extra}
    <body name="pressed_finger" pos="0 0 0.1">
      <geom name="pressed_finger_geom" type="box" size="0.015 0.015 0.01" {fingers}/>
      <site name="pressed" type="box" size="0.01 0.01 0.001" pos="0 0 0.01"/>
    </body>
    <body name="free_finger" pos="0.1 0 0.1">
      <geom name="free_finger_geom" type="box" size="0.015 0.015 0.01" {fingers}/>
      <site name="free" type="box" size="0.01 0.01 0.001" pos="0 0 0.01"/>
    </body>
    <body name="plate" pos="0 0 {plate_z}">
      <joint name="press" type="slide" axis="0 0 1" damping="{_dashpot_n_s_m():.6g}"/>
      <geom name="plate_geom" type="box" size="0.02 0.02 0.005" mass="{PLATE_KG}" {plate}/>
    </body>
  </worldbody>
</mujoco>"""


#: A wall the fingers (contype 2, conaffinity 2) touch through their conaffinity bit 2, which the
#: pads (contype 2, conaffinity 0) lack: only the wall's conaffinity 1 is left to meet them.
WALL = '<geom name="far_wall" type="box" size="0.01 0.1 0.1" pos="0.5 0 0.1" contype="2" conaffinity="1"/>'
BIT_2 = 'contype="2" conaffinity="2"'


def strip_geoms(model: mujoco.MjModel) -> list[int]:
    return [g for g in range(model.ngeom) if model.geom(g).name.startswith(PREFIX)]


def test_pads_on_bit_2_fingers_read_a_bit_2_plates_weight():
    """Fingers and plate on contype/conaffinity bit 2 only: the house's contype 1 pads would let
    the plate fall through; the pads take the fingers' bits and read its weight exactly."""
    spec = mujoco.MjSpec.from_string(plate_scene(fingers=BIT_2, plate=BIT_2))
    with warnings.catch_warnings():
        warnings.simplefilter("error", PadCollisionWarning)  # everything the fingers touch, the pads do
        tips = attach(spec, sites=["pressed", "free"])
    model = spec.compile()
    assert {(int(model.geom_contype[g]), int(model.geom_conaffinity[g])) for g in strip_geoms(model)} == {(2, 0)}
    sim = tips.bind(model, mujoco.MjData(model))
    for _ in range(round(1.0 / sim.period_s)):  # 1 s to settle, as tests/test_attach.py's fixture
        sim.step()
    state = sim.pad_state("pressed")
    assert state.normal_force_n == pytest.approx(PLATE_KG * G, rel=1e-6)
    assert state.normal_force_n / PAD_AREA_M2 == pytest.approx(PRESSURE_PA, rel=1e-6)
    assert sim.readings()["pressed"].true_pressure_pa == pytest.approx(PRESSURE_PA, rel=1e-6)
    assert not state.bottomed


def test_a_geom_the_fingers_touch_and_the_pads_cannot_is_named_at_the_callers_line():
    spec = mujoco.MjSpec.from_string(plate_scene(fingers=BIT_2, plate=BIT_2, extra=WALL))
    with pytest.warns(PadCollisionWarning, match=r"'far_wall' \(contype 2, conaffinity 1\)") as record:
        attach(spec, sites=["pressed", "free"])
    (warning,) = record
    message = str(warning.message)
    assert "2/0" in message and "bit value 2" in message  # the pads' bits, and what to change
    assert "floor" not in message and "plate_geom" not in message  # the floor: the fingers do not touch it either
    assert warning.filename == __file__  # it points at the attach call
    spec.compile()  # a warning, not a refusal


def test_a_model_whose_geoms_all_collide_gives_no_warning_and_the_house_bits():
    spec = mujoco.MjSpec.from_string(plate_scene())
    with warnings.catch_warnings():
        warnings.simplefilter("error", PadCollisionWarning)
        attach(spec, sites=["pressed", "free"])
    model = spec.compile()
    assert {(int(model.geom_contype[g]), int(model.geom_conaffinity[g])) for g in strip_geoms(model)} == {(1, 0)}


def test_a_site_on_a_visual_only_body_keeps_the_house_bits_and_names_what_they_miss():
    """No collision geom to take bits from: the house class's contype 1, conaffinity 0; a geom
    those cannot touch (contype 2 only) is named."""
    visual = 'contype="0" conaffinity="0"'
    spec = mujoco.MjSpec.from_string(plate_scene(fingers=visual, plate=BIT_2))
    with pytest.warns(PadCollisionWarning, match="'plate_geom'"):
        attach(spec, sites=["pressed", "free"])
    model = spec.compile()
    assert {(int(model.geom_contype[g]), int(model.geom_conaffinity[g])) for g in strip_geoms(model)} == {(1, 0)}


def test_pads_never_touch_their_own_strips():
    """dm_control's Jaco hand: contype 3, conaffinity 2.  The pads take contype 3 and drop
    conaffinity bit 2 (it is in their contype): with it the neighbouring strips, sibling bodies,
    would touch each other."""
    jaco = 'contype="3" conaffinity="2"'
    spec = mujoco.MjSpec.from_string(plate_scene(fingers=jaco))
    attach(spec, sites=["pressed", "free"], config={"physics.pad_segments": 5})
    model = spec.compile()
    assert pad_collision_bits(model, model.body("pressed_finger").id) == (3, 0)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    strips = set(strip_geoms(model))
    assert len(strips) == 14
    assert not [c for c in data.contact[: data.ncon] if {int(c.geom[0]), int(c.geom[1])} <= strips]


# -- the pose the faces are read in --------------------------------------------------------


#: Two slide fingers under a palm on a lift: at qpos0 their boxes cross (the left one's centre is
#: right of the right one's, and they overlap); their joints open them 30 mm each, the left
#: towards -x, the right towards +x.  The lift moves both together.
HAND = """<mujoco model="closed hand">
  <option integrator="discrete" timestep="0.001"/>
  <worldbody>
    <body name="palm" pos="0 0 0.3">
      <joint name="lift" type="slide" axis="0 0 1" {lift}/>
      <geom name="palm" type="box" size="0.05 0.02 0.01"/>
      <body name="left" pos="0 0 -0.04">
        <joint name="left_slide" type="slide" axis="-1 0 0" {fingers}/>
        <geom name="left_box" type="box" size="0.008 0.015 0.025" pos="{offset} 0 0"/>
      </body>
      <body name="right" pos="0 0 -0.04">
        <joint name="right_slide" type="slide" axis="1 0 0" {fingers}/>
        <geom name="right_box" type="box" size="0.008 0.015 0.025" pos="-{offset} 0 0"/>
      </body>
    </body>
  </worldbody>
  {more}
</mujoco>"""

OPEN_M = 0.03
LIFT_SERVO = '<position name="lift_servo" joint="lift" kp="100" ctrlrange="-0.1 0.1"/>'
#: A position servo per finger (MuJoCo's `position`: gain kp, bias -kp).
SERVOS = f"""<actuator>
    <position name="left_servo" joint="left_slide" kp="100" ctrlrange="0 {OPEN_M}"/>
    <position name="right_servo" joint="right_slide" kp="100" ctrlrange="0 {OPEN_M}"/>
    {LIFT_SERVO}
  </actuator>"""
#: Menagerie's Franka hand's way: one `general` servo on a fixed tendon of both fingers (its
#: length their mean), a 0-255 command, a joint equality mirroring the fingers.
TENDON = f"""<tendon><fixed name="split"><joint joint="left_slide" coef="0.5"/><joint joint="right_slide" coef="0.5"/></fixed></tendon>
  <equality><joint joint1="left_slide" joint2="right_slide"/></equality>
  <actuator>
    <general name="hand" tendon="split" ctrlrange="0 255" gainprm="{OPEN_M * 100 / 255:.12g}" biastype="affine" biasprm="0 -100 -10"/>
    {LIFT_SERVO}
  </actuator>"""


def hand(lift: str = 'range="-0.1 0.1"', fingers: str = f'range="0 {OPEN_M}"', offset: float = 0.005, more: str = "") -> str:
    return HAND.format(lift=lift, fingers=fingers, offset=offset, more=more)


def out_in_body(placement) -> np.ndarray:
    """The pad's +x (out of the pad, towards what it touches) in the frame of its body."""
    rotation = np.zeros(9)
    mujoco.mju_quat2Mat(rotation, np.asarray(placement.quat, float))
    return rotation.reshape(3, 3)[:, 0]


def assert_inner_faces(tips) -> None:
    """The left pad looks along +x at the right finger, the right one along -x (their bodies'
    frames are the palm's), each on its box's inner face."""
    left, right = tips.pads
    assert out_in_body(left.placement) == pytest.approx([1, 0, 0], abs=1e-12)
    assert out_in_body(right.placement) == pytest.approx([-1, 0, 0], abs=1e-12)
    offset = 0.005
    assert left.placement.pos_m[0] == pytest.approx(offset + 0.008 + H0, abs=1e-12)  # the box's +x face, h0 out
    assert right.placement.pos_m[0] == pytest.approx(-offset - 0.008 - H0, abs=1e-12)


@pytest.mark.parametrize("actuators", [SERVOS, TENDON], ids=["servo per finger", "servo on a fixed tendon"])
def test_fingers_closed_at_qpos0_get_their_pads_on_the_inner_faces_of_the_open_hand(actuators):
    spec = mujoco.MjSpec.from_string(hand(more=actuators))
    model = spec.compile()
    joints = [model.joint(n).qposadr[0] for n in ("lift", "left_slide", "right_slide")]
    assert open_pose_qpos(model, ["left", "right"])[joints] == pytest.approx([0.0, OPEN_M, OPEN_M])  # the lift stays
    tips = attach(spec, bodies=["left", "right"])
    assert_inner_faces(tips)
    # In the world, with the hand open: each pad's strips stand between the fingers.
    model = spec.compile()
    data = mujoco.MjData(model)
    data.qpos[[model.joint(n).qposadr[0] for n in ("left_slide", "right_slide")]] = OPEN_M
    mujoco.mj_forward(model, data)
    inner = OPEN_M - 0.005 - 0.008  # the left box's inner face at x = -inner, the right one's at +inner
    left_x, right_x = (data.geom_xpos[model.geom(f"{PREFIX}{side}/seg0_geom").id][0] for side in ("left", "right"))
    assert left_x == pytest.approx(-inner + 0.5 * H0, abs=1e-9) and right_x == pytest.approx(inner - 0.5 * H0, abs=1e-9)
    assert model.nkey == 0 and not np.any(model.qpos0)  # the user's model keeps its reference


def test_qpos0_outside_the_joints_ranges_is_clamped_into_them():
    """No actuators; the fingers' range 20-30 mm open and the lift's 50-100 mm exclude qpos0."""
    spec = mujoco.MjSpec.from_string(hand(lift='range="0.05 0.1"', fingers='range="0.02 0.03"'))
    model = spec.compile()
    assert open_pose_qpos(model, ["left", "right"]) == pytest.approx([0.05, 0.02, 0.02])
    assert_inner_faces(attach(spec, bodies=["left", "right"]))
    with pytest.raises(ValueError, match="body 'thumb' is not in the model"):
        open_pose_qpos(model, ["left", "thumb"])


COINCIDENT = hand(lift="", fingers="", offset=0.0, more='<keyframe><key name="open_key" qpos="0 0.03 0.03"/></keyframe>')


def test_a_keyframe_names_the_pose():
    """Unlimited, unactuated fingers whose boxes coincide at qpos0: no open pose to find.  The
    error names the pose and suggests pose=; the keyframe places the pads and stays as it was."""
    with pytest.raises(ValueError, match=r"body 'left' has its collision box where the other fingertips' are in the open pose .*pose="):
        attach(mujoco.MjSpec.from_string(COINCIDENT), bodies=["left", "right"])
    spec = mujoco.MjSpec.from_string(COINCIDENT)
    tips = attach(spec, bodies=["left", "right"], pose="open_key")
    left, right = tips.pads
    assert out_in_body(left.placement) == pytest.approx([1, 0, 0], abs=1e-12)
    assert out_in_body(right.placement) == pytest.approx([-1, 0, 0], abs=1e-12)
    model = spec.compile()
    joints = [model.joint(n).qposadr[0] for n in ("lift", "left_slide", "right_slide")]
    assert model.nkey == 1 and model.key("open_key").qpos[joints].tolist() == [0.0, 0.03, 0.03]
    assert np.count_nonzero(model.key("open_key").qpos) == 2  # the strips start unloaded
    # fingertip_pads takes the pose too, and a geom's name places as its body does.
    by_geom = fingertip_pads(mujoco.MjModel.from_xml_string(COINCIDENT), ["left_box", "right_box"], 1, H0, pose="open_key")
    assert [p[2] for p in by_geom] == [pad.placement for pad in tips.pads]


@pytest.mark.parametrize("kwargs", [{"bodies": ["left", "right"]}, {"sites": ["left_site"]}], ids=["bodies", "sites"])
def test_a_pose_that_is_no_keyframe_is_a_value_error_naming_it_and_the_keyframes(kwargs):
    xml = COINCIDENT.replace('<geom name="left_box"', '<site name="left_site" type="box" size="0.01 0.01 0.001"/><geom name="left_box"')
    spec = mujoco.MjSpec.from_string(xml)
    before = spec.to_xml()
    with pytest.raises(ValueError, match=r"pose 'shut' is no keyframe of the model \(its keyframes: open_key\)"):
        attach(spec, pose="shut", **kwargs)
    assert spec.to_xml() == before
    with pytest.raises(ValueError, match="pose 'shut' is no keyframe"):
        fingertip_pads(mujoco.MjModel.from_xml_string(xml), ["left_box", "right_box"], 1, H0, pose="shut")


def _robotiq_2f85() -> Path:
    spec = importlib.util.find_spec("dm_robotics")
    if spec is None or not spec.submodule_search_locations:
        pytest.skip("dm_robotics (dm-robotics-moma) is not installed")
    path = Path(next(iter(spec.submodule_search_locations))) / "moma/models/vendor/robotiq_beta_robots/mujoco/robotiq_2f85.xml"
    if not path.is_file():
        pytest.skip(f"dm_robotics' Robotiq 2F-85 model is not at {path}")
    return path


def test_pads_on_robotiqs_2f85_pad_bodies_face_each_other():
    """Robotiq's own 2F-85 model as dm_robotics vendors it, untouched: its pad bodies' pads look
    at each other in the world."""
    spec = mujoco.MjSpec.from_file(str(_robotiq_2f85()))
    with warnings.catch_warnings():
        warnings.simplefilter("error", PadCollisionWarning)
        tips = attach(spec, bodies=["left_pad", "right_pad"])
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    surfaces, outs = [], []
    for pad in tips.pads:
        body = model.body(pad.body).id
        rotation = data.xmat[body].reshape(3, 3)
        surfaces.append(data.xpos[body] + rotation @ np.asarray(pad.placement.pos_m))
        outs.append(rotation @ out_in_body(pad.placement))
    gap = surfaces[1] - surfaces[0]
    assert np.dot(outs[0], gap) > 0.99 * np.linalg.norm(gap) and np.dot(outs[1], -gap) > 0.99 * np.linalg.norm(gap)
