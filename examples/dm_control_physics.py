"""piezotip's fingertips in a dm_control ``Physics``: the loop a user had, plus attach and bind.

    pip install "dm-control>=1.0.48"
    python examples/dm_control_physics.py
    python examples/dm_control_physics.py --grip-n 0.5 --seconds 2

dm_control's bindings are made for one MuJoCo's structs, and its ``Physics`` fails at once under
another (``AttributeError`` on an MjModel field).  Checked: dm_control 1.0.48 and 1.0.49 under
MuJoCo 3.16 and 3.17, 1.0.50 under 3.17.  No dm_control yet runs under MuJoCo 4.0 (1.0.50, the
newest, reads fields 4.0 removed); tests/test_framework_examples.py skips there.

The two-finger gripper of examples/gymnasium_mujoco_env.py (MuJoCo's default options, Euler
at 2 ms) stepped by dm_control.  A dm_control user makes a ``Physics`` from the model
(``Physics.from_xml_string``), sets the controls, calls ``physics.step()`` and reads
``physics.named.data``.  With piezotip the model goes through an ``MjSpec`` first
(``piezotip.attach`` edits a spec), the compiled model is wrapped for dm_control
(``Physics.from_model``), and the fingertips are bound to the MjData dm_control steps
(``physics.data.ptr``, its ``mujoco.MjData``).  Then ``physics.step()`` runs them (MuJoCo's
callbacks) and their readings are sensors like any other:
``physics.named.data.sensordata["piezotip/left_pad/pressure_pa"]`` (docs/attach.md).

Headless: dm_control picks a rendering backend at import (it may warn that there is no
display); nothing here renders.  Nothing written.
"""

from __future__ import annotations

import argparse
import sys

import mujoco

try:
    from dm_control import mujoco as dm_mujoco
except ModuleNotFoundError:
    sys.exit(
        'examples/dm_control_physics.py needs dm_control: pip install "dm-control>=1.0.48" (none yet runs under MuJoCo 4; '
        f"this is MuJoCo {mujoco.__version__})"
    )

import piezotip

#: The fingertips: the box sites the pads go on.
TIPS = ("left_pad", "right_pad")
#: The fingers' 20 x 20 mm pads (the sites' x/y half-sizes, m) and the pad's area, m^2.
PAD_HALF_M = 0.01
PAD_AREA_M2 = (2 * PAD_HALF_M) ** 2

# examples/gymnasium_mujoco_env.py's gripper, as it is there (a test checks they are one), so
# that this example needs dm_control only.  No <option>: MuJoCo's defaults (Euler, 2 ms).
# Site frames: +z out of the finger (towards the box), +x up the finger (towards the palm,
# where the element is clamped).
GRIPPER_XML = f"""
<mujoco model="two-finger gripper">
  <worldbody>
    <geom name="table" type="box" size="0.1 0.1 0.005" pos="0 0 0.08"/>
    <body name="left_finger" pos="-0.03 0 0.11">
      <joint name="left_slide" type="slide" axis="1 0 0" range="-0.01 0.02" damping="20"/>
      <geom name="left_link" type="box" size="0.005 0.015 0.02"/>
      <site name="left_pad" type="box" size="{PAD_HALF_M} {PAD_HALF_M} 0.001" pos="0.005 0 -0.01" xyaxes="0 0 1 0 -1 0"/>
    </body>
    <body name="right_finger" pos="0.03 0 0.11">
      <joint name="right_slide" type="slide" axis="-1 0 0" range="-0.01 0.02" damping="20"/>
      <geom name="right_link" type="box" size="0.005 0.015 0.02"/>
      <site name="right_pad" type="box" size="{PAD_HALF_M} {PAD_HALF_M} 0.001" pos="-0.005 0 -0.01" xyaxes="0 0 1 0 1 0"/>
    </body>
    <body name="box" pos="0 0 0.1">
      <freejoint/>
      <geom name="box_geom" type="box" size="0.015 0.015 0.015" mass="0.05"/>
    </body>
  </worldbody>
  <actuator>
    <motor name="left_grip" joint="left_slide" ctrlrange="0 20"/>
    <motor name="right_grip" joint="right_slide" ctrlrange="0 20"/>
  </actuator>
</mujoco>
"""

#: What the loop reads of each fingertip: its five sensors ``piezotip/TIP/<field>``.
SENSOR_FIELDS = ("pressure_pa", "sigma_pa", "status", "mode", "true_pressure_pa")


def make_physics() -> dm_mujoco.Physics:
    """The gripper as a dm_control ``Physics``, its fingertips running in every ``physics.step()``.

    Without piezotip this is ``dm_mujoco.Physics.from_xml_string(GRIPPER_XML)``; the lines
    between are what attach and bind take.
    """
    spec = mujoco.MjSpec.from_string(GRIPPER_XML)
    tips = piezotip.attach(spec, sites=list(TIPS))
    physics = dm_mujoco.Physics.from_model(dm_mujoco.wrapper.MjModel(spec.compile()))
    # Bind to the MjModel and MjData dm_control itself steps (its wrappers' .ptr): a copy
    # (physics.copy(), a pickled Physics) has MjData of its own, without fingertips.
    tips.bind(physics.model.ptr, physics.data.ptr)
    return physics


def read_tips(physics: dm_mujoco.Physics) -> dict[str, dict[str, float]]:
    """Each fingertip's sensors by name, from ``physics.named.data.sensordata`` (Pa; status and mode codes)."""
    sensordata = physics.named.data.sensordata
    return {tip: {field: float(sensordata[f"piezotip/{tip}/{field}"][0]) for field in SENSOR_FIELDS} for tip in TIPS}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--grip-n", type=float, default=1.0, help="each finger's squeeze, N (default 1: 2.5 kPa, in mode 1's range)")
    parser.add_argument("--seconds", type=float, default=1.2, help="simulated time, s (default 1.2)")
    args = parser.parse_args(argv)
    if not 0 < args.grip_n <= 20:
        parser.error(f"--grip-n must be in (0, 20] N (the motors' range), got {args.grip_n!r}")
    if not 0 < args.seconds <= 60:
        parser.error(f"--seconds must be in (0, 60], got {args.seconds!r}")

    physics = make_physics()
    physics.set_control([args.grip_n, args.grip_n])
    steps = round(args.seconds / physics.timestep())
    every = round(0.2 / physics.timestep())
    print(f"{args.grip_n:g} N per finger over {PAD_AREA_M2 * 1e6:g} mm^2 = {args.grip_n / PAD_AREA_M2:.1f} Pa once closed")
    print(f"{'t (s)':>6}  {'pad':<9} {'estimate (Pa)':>22}  {'status':>6} {'mode':>4}  {'true (Pa)':>9}")
    for k in range(1, steps + 1):
        physics.step()
        if k % every == 0 or k == steps:
            for tip, r in read_tips(physics).items():
                estimate = f"{r['pressure_pa']:9.1f} +- {3 * r['sigma_pa']:7.1f}"
                codes = f"{r['status']:6.0f} {r['mode']:4.0f}"
                print(f"{physics.data.time:6.3f}  {tip:<9} {estimate:>22}  {codes}  {r['true_pressure_pa']:9.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
