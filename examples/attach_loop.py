"""piezotip's fingertip on your own MuJoCo model, in your own loop (docs/attach.md).

    python examples/attach_loop.py
    python examples/attach_loop.py --grip-n 5 --seconds 2

A small two-finger gripper made here from scratch (no file of the repository's): each finger on
a slide joint driven by a force motor, a box site on its inner face marking the sensing patch,
a 30 mm box on a table between them.  ``piezotip.attach`` puts a gel pad and its sensor on each
site; the loop sets the motors' force, steps one period at a time and prints what each
fingertip reads against the truth the readout never sees (the grip over the pad's area).  At
half time the left fingertip switches to mode 2 (it rings up, "settling", then reads again).
Headless: no window, nothing written.
"""

from __future__ import annotations

import argparse
import sys

import mujoco

import piezotip

#: The fingers' 20 x 20 mm pads (the sites' x/y half-sizes, m) and the grip's area, m^2.
PAD_HALF_M = 0.01
PAD_AREA_M2 = (2 * PAD_HALF_M) ** 2

# No <option>: MuJoCo's defaults (Euler, 2 ms).  Site frames: +z out of the finger (towards the
# box), +x up the finger (towards the palm, where the element is clamped).  xyaxes gives a frame's
# x and y; its z is their cross product.  examples/gymnasium_mujoco_env.py and
# examples/dm_control_physics.py carry the same gripper (each runs alone; a test keeps them one).
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


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--grip-n", type=float, default=2.0, help="each finger's squeeze, N (default 2)")
    parser.add_argument("--seconds", type=float, default=3.0, help="simulated time, s (default 3)")
    args = parser.parse_args(argv)
    if not 0 < args.grip_n <= 20:
        parser.error(f"--grip-n must be in (0, 20] N (the motors' range), got {args.grip_n!r}")
    if not 0 < args.seconds <= 60:
        parser.error(f"--seconds must be in (0, 60], got {args.seconds!r}")

    spec = mujoco.MjSpec.from_string(GRIPPER_XML)
    tips = piezotip.attach(spec, sites=["left_pad", "right_pad"])
    model = spec.compile()
    data = mujoco.MjData(model)
    sim = tips.bind(model, data)

    grip = [model.actuator(name).id for name in ("left_grip", "right_grip")]
    periods = round(args.seconds / sim.period_s)
    every = round(0.25 / sim.period_s)
    print(f"fingertips {', '.join(sim.names)}; one step = {sim.period_s * 1e3:g} ms ({sim.substeps} physics steps)")
    print(f"the grip's pressure: {args.grip_n:g} N over {PAD_AREA_M2 * 1e6:g} mm^2 = {args.grip_n / PAD_AREA_M2:.1f} Pa once closed")
    print(f"{'t (s)':>6}  {'pad':<9} {'estimate (Pa)':>22}  {'status':<15} mode {'voltage (V)':>11}  {'true (Pa)':>9}")
    for k in range(1, periods + 1):
        t = k * sim.period_s
        for actuator in grip:
            data.ctrl[actuator] = args.grip_n if t >= 0.2 else 0.0  # open for 0.2 s, then squeeze
        if k == periods // 2:
            sim.set_mode("left_pad", 2)
        sim.step()
        if k % every == 0:
            for name, r in sim.readings().items():
                estimate = f"{r.estimate_pa:9.1f} +- {3 * r.sigma_pa:7.1f}" if r.status == "ok" else f"{r.estimate_pa:9.1f}"
                print(f"{t:6.2f}  {name:<9} {estimate:>22}  {r.status:<15} {r.mode:>4} {r.voltage:11.2f}  {r.true_pressure_pa:9.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
