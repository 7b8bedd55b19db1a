"""Grippers in their natural pose (issue 43, item 3): a gripper file is mounted as its author
wrote it (cosim/gripper_mount.py, docs/grippers.md).

- Fingers closed at ``qpos0`` (Menagerie's Franka hand; here jaws on hinges whose tips cross at
  0) and a ``qpos0`` outside the joints' ranges (the ALOHA gripper's fingers at 0 on rails of
  21-57 mm): the free closing starts from the open pose the actuators command
  (:func:`cosim.attach.open_pose_qpos`), not from ``qpos0``, where the pads start pressed
  through each other or the joints through their limits (before: "zero-size array to reduction
  operation", the fingers touching at the first sample).
- A ``general`` actuator the drive cannot use is refused before anything runs, naming it and
  the reason (:func:`cosim.gripper_parts._drive_kind`); the command line exits 2.
- Menagerie's way of driving a hand (one 0-255 ``general`` servo on a fixed tendon of both
  fingers, a joint equality mirroring them, closed at ``qpos0``), and a filtered servo.

Each gripper is written here, as a third party would write it, and used through the scenario
keys only.  Menagerie's own files: tests/test_third_party_grippers.py.
"""

from __future__ import annotations

import re
from pathlib import Path

import mujoco
import numpy as np
import pytest

import piezotip
from piezotip import cli, scenarios
from piezotip.cosim.gripper_mount import PREFIX, mount_gripper, reference_qpos

#: Jaws on hinges, closed at qpos0: each jaw leans 0.4 rad in, so that at 0 their tips cross at
#: the middle (the tip boxes through each other); opening turns them out over 0.6 rad.  The tips
#: stand upright at 0.45 rad, where they close on a 40 mm box.
HINGE_JAWS = """<mujoco model="hinge jaws closed at qpos0">
  <compiler angle="radian"/>
  <default>
    <geom type="box" density="2700"/>
    <joint type="hinge" axis="0 1 0" damping="0.05" range="0 0.6"/>
  </default>
  <worldbody>
    <body name="palm">
      <geom name="palm" size="0.05 0.015 0.01"/>
      <body name="left_jaw" pos="-0.03 0 0.012" euler="0 0.4 0">
        <joint name="left_hinge" axis="0 -1 0"/>
        <geom size="0.003 0.01 0.035" pos="0 0 0.035"/>
        <geom name="left_tip" size="0.004 0.012 0.012" pos="0.004 0 0.07" euler="0 0.05 0"/>
      </body>
      <body name="right_jaw" pos="0.03 0 0.012" euler="0 -0.4 0">
        <joint name="right_hinge"/>
        <geom size="0.003 0.01 0.035" pos="0 0 0.035"/>
        <geom name="right_tip" size="0.004 0.012 0.012" pos="-0.004 0 0.07" euler="0 -0.05 0"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <position name="left_servo" joint="left_hinge" kp="2" kv="0.05" ctrlrange="0 0.6" forcelimited="true" forcerange="-2 2"/>
    <position name="right_servo" joint="right_hinge" kp="2" kv="0.05" ctrlrange="0 0.6" forcelimited="true" forcerange="-2 2"/>
  </actuator>
</mujoco>"""

#: Slides whose qpos0 (0) lies outside their range, as the ALOHA gripper's rails: at 0 the two
#: fingers stand through each other at the middle; their range puts their inner faces 15-51 mm
#: from it.
RAILS = """<mujoco model="fingers on rails, qpos0 outside their range">
  <default>
    <geom type="box" density="2700"/>
    <joint type="slide" damping="20"/>
  </default>
  <worldbody>
    <body name="hand">
      <geom name="palm" size="0.07 0.015 0.01"/>
      <body name="left" pos="0.002 0 0.04">
        <joint name="left_slide" axis="-1 0 0" range="0.021 0.057"/>
        <geom name="left_tip" size="0.004 0.012 0.015"/>
      </body>
      <body name="right" pos="-0.002 0 0.04">
        <joint name="right_slide" axis="1 0 0" range="0.021 0.057"/>
        <geom name="right_tip" size="0.004 0.012 0.015"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    {actuators}
  </actuator>
</mujoco>"""

RAIL_LIMITS = 'ctrlrange="0.021 0.057" forcelimited="true" forcerange="-30 30"'
RAIL_SERVOS = f"""<position name="left_servo" joint="left_slide" kp="2000" kv="20" {RAIL_LIMITS}/>
    <position name="right_servo" joint="right_slide" kp="2000" kv="20" {RAIL_LIMITS}/>"""

#: Menagerie's Franka hand's drive on slides closed at qpos0: one `general` servo on a fixed
#: tendon of both fingers (its length their mean) with a 0-255 command (kp 100, kv 10, 100 N), a
#: joint equality mirroring the fingers; at 0 the fingers' inner faces touch.
TENDON_HAND = """<mujoco model="Menagerie-style hand, closed at qpos0">
  <default>
    <geom type="box" density="2700"/>
    <joint type="slide" damping="1" armature="0.1" range="0 0.04"/>
  </default>
  <worldbody>
    <body name="hand">
      <geom name="palm" size="0.06 0.015 0.01"/>
      <body name="left_finger" pos="-0.005 0 0.04">
        <joint name="finger_joint1" axis="-1 0 0"/>
        <geom name="left_tip" size="0.005 0.01 0.02"/>
      </body>
      <body name="right_finger" pos="0.005 0 0.04">
        <joint name="finger_joint2" axis="1 0 0"/>
        <geom name="right_tip" size="0.005 0.01 0.02"/>
      </body>
    </body>
  </worldbody>
  <tendon><fixed name="split"><joint joint="finger_joint1" coef="0.5"/><joint joint="finger_joint2" coef="0.5"/></fixed></tendon>
  <equality><joint joint1="finger_joint1" joint2="finger_joint2" solimp="0.95 0.99 0.001" solref="0.005 1"/></equality>
  <actuator>
    <general name="actuator8" tendon="split" {dynamics} forcelimited="true" forcerange="-100 100" ctrlrange="0 255"
      gainprm="0.01568627451 0 0" biastype="affine" biasprm="0 -100 -10"/>
  </actuator>
</mujoco>"""


def write(tmp_path: Path, text: str, name: str) -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def keys(path: Path, actuators=("left_servo", "right_servo"), tips=("left_tip", "right_tip")) -> dict:
    return {"gripper.mjcf": str(path), "gripper.fingertips": list(tips), "gripper.actuators": list(actuators)}


def config(overrides: dict):
    return scenarios.get("grasp", overrides, "fast")


def assert_success(overrides: dict) -> None:
    result = piezotip.run("grasp", overrides=overrides, preset="fast")
    assert result.outcome == "success", result.reason


# -- the pose a file is written in -------------------------------------------------------------


def test_jaws_closed_at_qpos0_mount_open_and_grasp_the_box(tmp_path):
    """At qpos0 the jaws' tips cross (their pads through each other): the free closing starts
    from the open pose, the servos at 0.6 rad, and closes until the pads touch.  The home
    opening is the jaws' at 0.6 rad (their limit): between their pads' unloaded surfaces there,
    read on the file's model; the 100 g box is carried."""
    path = write(tmp_path, HINGE_JAWS, "jaws.xml")
    cfg = config(keys(path))
    mounted = mount_gripper(cfg)
    model = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(model)
    data.qpos[:] = 0.6
    mujoco.mj_kinematics(model, data)
    surfaces = []
    for _, body, placement, _ in mounted.parts.pads:
        b = model.body(body).id
        surfaces.append(data.xpos[b] + data.xmat[b].reshape(3, 3) @ np.asarray(placement.pos_m))
    assert mounted.drive.home_opening_m == pytest.approx(surfaces[1][0] - surfaces[0][0], abs=1e-5)
    assert mounted.drive.path.opening_m[0] < 0.0  # the pads close on each other: the path's narrow end
    assert_success(keys(path))


def test_fingers_whose_qpos0_is_outside_their_range_mount_in_it_and_grasp_the_box(tmp_path):
    """qpos0 = 0 lies under the rails' 21-57 mm: the frames are read with the fingers clamped to
    21 mm (reference_qpos), the drive starts from the servos' open end (57 mm): the pads' surfaces
    2 (57 - 2 - 4 - 5) = 92 mm apart, closing to 2 (21 - 2 - 4 - 5) = 20 mm."""
    path = write(tmp_path, RAILS.format(actuators=RAIL_SERVOS), "rails.xml")
    model = mujoco.MjModel.from_xml_path(str(path))
    assert reference_qpos(model) == pytest.approx([0.021, 0.021])
    assert model.qpos0 == pytest.approx([0.0, 0.0])  # the file is used as it is
    mounted = mount_gripper(config(keys(path)))
    assert mounted.drive.home_opening_m == pytest.approx(0.092, abs=1e-6)
    assert mounted.drive.path.opening_m[0] == pytest.approx(0.020, abs=2e-4)
    assert_success(keys(path))


def test_a_menagerie_style_tendon_servo_on_a_hand_closed_at_qpos0_mounts_open(tmp_path):
    """One 0-255 `general` servo on the fingers' mean (a fixed tendon, coefficients 0.5), a joint
    equality mirroring them, the fingers closed at qpos0 (their inner faces touching): open at 255
    (the tendon's 40 mm), the pads 2 (40 - 5) = 70 mm apart; the grip rating is the servo's 100 N
    on the tendon, whose length moves half the opening's: 50 N per finger (each finger's joint
    takes half the tendon's force), though its servo's reach is far less
    (test_a_servos_reach_caps_the_grip_at_each_width_and_the_controller_says_so).  The 100 g box
    is carried by both controllers (0.1 kg of armature a slide, as Menagerie's hand)."""
    path = write(tmp_path, TENDON_HAND.format(dynamics=""), "tendon_hand.xml")
    overrides = keys(path, ["actuator8"])
    mounted = mount_gripper(config(overrides))
    assert list(mounted.open_ctrl) == [255.0]
    assert mounted.drive.home_opening_m == pytest.approx(0.070, abs=1e-4)
    assert mounted.drive.rating_n() == pytest.approx(50.0, rel=1e-3)
    assert_success({**overrides, "controller.kind": "multimode"})
    assert_success({**overrides, "controller.kind": "gentle"})


def test_a_servos_reach_caps_the_grip_at_each_width_and_the_controller_says_so(tmp_path):
    """Menagerie's Franka hand drives its tendon (the fingers' mean length l) with a servo of
    kp 100 N/m whose closed command (0) holds l* = 0, the fingers touching: at rest it presses
    with 100 l, 4 N at most, whatever its 100 N force range (its 50 N a finger of rating).  The
    grip a finger gets is kp |l - l*| |dl/do| (the tendon moves half the opening): about 1.7 N
    on a 60 mm jar, where the jar needs 4.9 N (friction 0.3).  The mount reads that reach along
    the path (:meth:`GripperDrive.reach_n`), checked here against MuJoCo: the hand closed on a
    wide box at its closed command settles with the drive's own grip reading at the reach of
    its opening.  The controller caps the grip there at the touch and says so (a ``drive_reach``
    event), and gives up on the jar at that cap, not at a 50 N it never gave (before: "the grip
    at the gripper's limit, 50 N", its pads at 1.47 N)."""
    path = write(tmp_path, TENDON_HAND.format(dynamics=""), "tendon_hand.xml")
    overrides = {**keys(path, ["actuator8"]), "object.size_m": 0.06, "object.mass_kg": 0.3, "object.friction": 0.3}
    drive, limits, opening, grip_n = _closed_on_the_jar(overrides)
    lengths, slopes = drive.path.lengths[0], np.gradient(drive.path.lengths[0], drive.path.opening_m)
    assert drive.reach_n() == pytest.approx(100.0 * np.abs(lengths) * np.abs(slopes), rel=1e-6, abs=1e-9)
    assert limits.finger_force_limit_n == pytest.approx(50.0, rel=1e-3)
    assert 0.05 < opening < 0.062
    assert grip_n == pytest.approx(limits.finger_force_limit_at_n(opening), rel=0.03)
    assert limits.finger_force_limit_at_n(opening) < 2.0
    result = piezotip.run("grasp", overrides={**overrides, "controller.kind": "gentle"}, preset="fast")
    assert result.outcome == "never_lifted"
    reach = next(e["message"] for e in result.events if e["kind"] == "drive_reach")
    cap_n = float(reach.split("at most ")[1].split(" N")[0])
    assert cap_n == pytest.approx(limits.finger_force_limit_at_n(0.06), rel=0.05)
    # given up at the reach where its fingers came to (pads pressed in: a little closer, a little less)
    said = re.search(r"what the drive reaches at this ([0-9.]+) mm opening, ([0-9.]+) N", result.reason)
    assert said and "50 N" not in result.reason, result.reason
    assert float(said[2]) == pytest.approx(limits.finger_force_limit_at_n(float(said[1]) * 1e-3), rel=0.01)
    assert float(said[2]) == pytest.approx(cap_n, rel=0.05)


def _closed_on_the_jar(overrides: dict):
    """The gripper of ``overrides`` mounted on its object and closed on it at its closed command
    for 1.5 s: (drive, robot limits, opening m, the drive's own grip reading N)."""
    cfg = config(overrides)
    mounted = mount_gripper(cfg)
    data = mujoco.MjData(mounted.model)
    limits = mounted.robot_limits(mounted.reset_home(data, cfg))
    data.ctrl[mounted.drive.actuators] = 0.0  # closed: the fingers press the object at the servo's reach
    for _ in range(round(1.5 / mounted.model.opt.timestep)):
        mujoco.mj_step(mounted.model, data)
    return mounted.drive, limits, mounted.drive.opening_m(data), mounted.drive.grip_force_n(data)


def test_a_servos_reach_counts_the_springs_the_free_fingers_hold(tmp_path):
    """Springs on the fingers (stiffness 20 N/m a slide, at rest open) take part of the servo's
    force to hold the free fingers where they are (:attr:`DrivePath.static_force`), and the grip
    the drive reads leaves it out: the reach adds what they give there, and the hand closed on
    the jar settles at it (7 % under the springless reach)."""
    hand = TENDON_HAND.format(dynamics="").replace('armature="0.1"', 'armature="0.1" stiffness="20" springref="0.04"')
    path = write(tmp_path, hand, "sprung_hand.xml")
    drive, limits, opening, grip_n = _closed_on_the_jar({**keys(path, ["actuator8"]), "object.size_m": 0.06})
    assert np.any(drive.path.static_force != 0.0)
    assert grip_n == pytest.approx(limits.finger_force_limit_at_n(opening), rel=0.01)


def test_a_servo_that_reaches_its_rating_at_every_width_has_no_reach_table(tmp_path):
    """The house gripper's servo, and the hand's with a command range twice its stroke (its
    closed command holds the tendon 40 mm past the fingers touching) and a 3 N force range: the
    force range binds at every width, and the limits keep no reach table (the grip's cap is the
    rating)."""
    from piezotip.cosim.loop import CoSimulation

    house = CoSimulation(scenarios.get("grasp", [], "fast")).robot
    assert house.finger_reach_n == ((), ()) and house.finger_force_limit_at_n(0.03) == house.finger_force_limit_n
    hand = TENDON_HAND.format(dynamics="").replace('forcerange="-100 100" ctrlrange="0 255"', 'forcerange="-3 3" ctrlrange="-255 255"')
    cfg = config({**keys(write(tmp_path, hand, "long_stroke_hand.xml"), ["actuator8"]), "object.size_m": 0.04})
    mounted = mount_gripper(cfg)
    limits = mounted.robot_limits(mounted.reset_home(mujoco.MjData(mounted.model), cfg))
    assert limits.finger_reach_n == ((), ()) and limits.finger_force_limit_n == pytest.approx(1.5, rel=1e-6)


def test_a_filtered_servo_starts_held_at_its_open_command(tmp_path):
    """A servo whose activation filters its command (dyntype filter, 20 ms) holds a length at
    rest as a plain one does: the drive takes it, and home starts its activation at the open
    command (a reset's 0 would first close the hand).  The path is the plain servo's."""
    filtered = write(tmp_path, TENDON_HAND.format(dynamics='dyntype="filter" dynprm="0.02"'), "filtered.xml")
    mounted = mount_gripper(config(keys(filtered, ["actuator8"])))
    data = mujoco.MjData(mounted.model)
    mounted.reset_home(data, config(keys(filtered, ["actuator8"])))
    actuator = mounted.model.actuator(PREFIX + "actuator8").id
    assert data.act[mounted.model.actuator_actadr[actuator]] == 255.0
    plain = mount_gripper(config(keys(write(tmp_path, TENDON_HAND.format(dynamics=""), "plain.xml"), ["actuator8"])))
    assert mounted.drive.home_opening_m == pytest.approx(plain.drive.home_opening_m, abs=1e-5)
    assert mounted.drive.rating_n() == pytest.approx(plain.drive.rating_n(), rel=1e-9)


def test_a_file_whose_qpos0_is_a_pose_it_takes_is_read_there_unchanged(tmp_path):
    """The reference pose is qpos0 itself where it lies in the joints' ranges (the frames of
    every gripper mounted before are read where they were)."""
    model = mujoco.MjModel.from_xml_string(TENDON_HAND.format(dynamics=""))
    assert np.array_equal(reference_qpos(model), model.qpos0)


# -- actuators the drive cannot use ------------------------------------------------------------

#: Each a finger actuator of RAILS the drive cannot use, and the reason its refusal gives.
UNUSABLE = {
    "integrator": (
        '<general name="left_servo" joint="left_slide" dyntype="integrator" gainprm="2000" biastype="affine" biasprm="0 -2000 -20" '
        'ctrlrange="-1 1" forcelimited="true" forcerange="-30 30"/>',
        r"its command is its activation's rate \(dyntype integrator\)",
    ),
    "muscle dynamics": (
        '<general name="left_servo" joint="left_slide" dyntype="muscle" gainprm="2000" biastype="affine" biasprm="0 -2000 -20" '
        'ctrlrange="0 1" forcelimited="true" forcerange="-30 30"/>',
        r"its activation follows dynamics of its own \(dyntype muscle\)",
    ),
    "user gain": (
        '<general name="left_servo" joint="left_slide" gaintype="user" biastype="affine" biasprm="0 -2000 -20" '
        'ctrlrange="0.021 0.057" forcelimited="true" forcerange="-30 30"/>',
        r"its force comes from a user gain \(gaintype user\)",
    ),
    "affine gain": (
        '<general name="left_servo" joint="left_slide" gaintype="affine" gainprm="2000 -10 0" biastype="affine" biasprm="0 -2000 -20" '
        'ctrlrange="0.021 0.057" forcelimited="true" forcerange="-30 30"/>',
        r"its gain changes with its length or speed \(gaintype affine",
    ),
    "velocity servo": (
        '<velocity name="left_servo" joint="left_slide" kv="20" ctrlrange="-1 1" forcelimited="true" forcerange="-30 30"/>',
        r"it is a velocity servo .* it holds a speed, not a length",
    ),
    "positive feedback": (
        '<general name="left_servo" joint="left_slide" gainprm="2000" biastype="affine" biasprm="0 2000 0" ctrlrange="0.021 0.057" '
        'forcelimited="true" forcerange="-30 30"/>',
        r"its bias pushes away from its target \(biasprm\[1\] = 2000 > 0\)",
    ),
    "negative gain": (
        '<general name="left_servo" joint="left_slide" gainprm="-2000" biastype="affine" biasprm="0 -2000 -20" '
        'ctrlrange="0.021 0.057" forcelimited="true" forcerange="-30 30"/>',
        r"its gain gainprm\[0\] = -2000 is not positive",
    ),
    "unbounded motor": (
        '<motor name="left_servo" joint="left_slide"/>',
        r"a motor with neither a force range nor a command range",
    ),
}


@pytest.mark.parametrize("case", sorted(UNUSABLE))
def test_an_actuator_the_drive_cannot_use_is_refused_naming_it_and_why(tmp_path, case):
    """One ValueError naming the key, the actuator and the reason, when the scenario is made
    (before anything runs)."""
    actuator, reason = UNUSABLE[case]
    right = RAIL_SERVOS.splitlines()[1]
    path = write(tmp_path, RAILS.format(actuators=f"{actuator}\n{right}"), "unusable.xml")
    with pytest.raises(ValueError, match=rf"gripper.actuators: 'left_servo' cannot close the fingers: {reason}"):
        scenarios.get("grasp", keys(path))


def test_an_unusable_actuator_is_a_bad_input_on_the_command_line(tmp_path, capsys):
    """The command line's exit status 2 and one line naming it."""
    actuator, _ = UNUSABLE["integrator"]
    right = RAIL_SERVOS.splitlines()[1]
    path = write(tmp_path, RAILS.format(actuators=f"{actuator}\n{right}"), "unusable.xml")
    argv = ["run", "grasp", "--preset", "fast", "--no-plot", "--out", str(tmp_path / "out"), "--set", f"gripper.mjcf={path}"]
    argv += ["--set", "gripper.fingertips=['left_tip', 'right_tip']", "--set", "gripper.actuators=['left_servo', 'right_servo']"]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: gripper.actuators: 'left_servo' cannot close the fingers: its command is"), err
