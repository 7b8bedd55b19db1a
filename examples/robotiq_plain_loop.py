"""A gripper file used untouched, in your own loop: piezotip fingertips on Robotiq's 2F-85.

    pip install --no-deps dm-robotics-moma     # only its vendored Robotiq model files are read
    python examples/robotiq_plain_loop.py
    python examples/robotiq_plain_loop.py --ctrl 135 --seconds 3

Robotiq's 2F-85 as DeepMind's dm_robotics vendors it (``robotiq_beta_robots/mujoco/
robotiq_2f85.xml``: per finger a closed four-bar, one tendon servo ``fingers_actuator`` with
commands 0-255, no ``<option>``, i.e. MuJoCo's defaults, Euler at 2 ms) is loaded with
``mujoco.MjSpec.from_file`` and nothing of it changes.  Around it, a small scene built here:

- **a mount**: the file's root is welded to the world, with its fingers pointing up.  Upright,
  gravity folds the underactuated fingertips inwards before they touch anything (the follower
  joint runs to its 0.87 rad limit, the pads tilt 33 degrees: the spring link holds the
  parallel pinch with 0.001 N m/rad).  So the scene hangs it from a frame, fingers down, as an
  arm's wrist holds it (``MjSpec.attach`` with the prefix ``2f85/``: every name of the file is
  kept behind it);
- **a 40 mm box welded to the world** between the pads: it cannot fall, whatever the grip.

``piezotip.attach`` puts a fingertip on each pad body (``left_pad``, ``right_pad``: their one
collision geom is the silicone pad's box, the ``gripper.fingertips`` of docs/grippers.md).  The
loop is a plain ``mujoco.mj_step`` loop: it commands the file's own servo, reads each
fingertip's five sensors from ``data.sensordata`` by name, and drives a saturated fingertip in
its next stiffer mode (``sim.set_mode``).  It prints a table of the readings over time and, at
the end, each fingertip's estimate +- 3 sigma against its true pressure, the pad's normal force
against the contact force MuJoCo reports on its strips, and the time an ``mj_step`` takes with
and without the fingertips on the same scene.  Headless.

The grip: the servo's force on its tendon is ``0.3137 ctrl - 100 L - 10 dL/dt`` (N, L the
tendon's length, rad), within +-5 N.  The pads meet the box at L = 0.35 (a command of about
113); each command unit past it adds about 0.8 N per finger.  At the default 125 each pad
presses about 5.1 N (12.8 kPa over its 20 x 20 mm), tipped a few degrees by the linkage, so
its gel presses harder at the distal guard than at the root one; the element's truth reads
about 12.8 kPa.  Mode 1 saturates there, and the loop drives mode 2.  At the full 255 the servo
pushes its 5 N on the tendon: the fingertips tip 15 degrees into Robotiq's encompassing grasp,
the file's own pad boxes touch the box beside the gel (21 N each, the gel 23 N, on its distal
guard and element strip), and the pad's normal force is 7 % under MuJoCo's contact force on its
strips (their normals 15 degrees apart).

The forces are compared as means over the run's last 0.5 s: how still a held pad rests under
an explicit integrator depends on its contact's impedance (``cosim/attach.py``), and a single
step's contact force may scatter about the static balance the means hold.
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import sys
import time
from pathlib import Path

import mujoco
import numpy as np

import piezotip

#: Where dm_robotics keeps the model, under its package folder.
MODEL_PATH = Path("moma", "models", "vendor", "robotiq_beta_robots", "mujoco", "robotiq_2f85.xml")
#: Every name of the file appears behind this prefix in the scene (MuJoCo's attach).
PREFIX = "2f85/"
#: The file's pad bodies: the fingertips' names are these behind the prefix.
PAD_BODIES = ("left_pad", "right_pad")
TIPS = tuple(PREFIX + body for body in PAD_BODIES)
#: The file's servo and its command range (ctrlrange="0 255").
ACTUATOR = PREFIX + "fingers_actuator"
CTRL_RANGE = (0.0, 255.0)
#: The default command: about 5 N per finger on the box (see the module's docstring).
DEFAULT_CTRL = 125.0

#: The wrist frame the gripper hangs from (m), fingers down: half a turn about world x.
MOUNT_POS_M = (0.0, 0.0, 0.3)
MOUNT_QUAT = (0.0, 1.0, 0.0, 0.0)
#: The box between the pads: 40 mm across the closing (world y), wider and taller than the
#: 20 x 20 mm pads, its centre at the pads' centre when they meet it (the pads swing along an
#: arc; they meet a 40 mm box 149 mm above the world origin).
OBJECT_HALF_M = (0.02, 0.02, 0.015)
OBJECT_POS_M = (0.0, 0.0, 0.15)
OBJECT = "object"

#: The fingertip's sensors, and the readout's status codes (docs/attach.md).
FIELDS = ("pressure_pa", "sigma_pa", "status", "mode", "true_pressure_pa")
STATUS = {0: "ok", 1: "below_detection", 2: "saturated", 3: "settling"}
SATURATED = 2


def robotiq_2f85_path() -> Path | None:
    """The 2F-85's XML in the installed dm_robotics, or None where it is not installed.

    Found without importing dm_robotics (its package pins another MuJoCo; only the model files
    are read)."""
    found = importlib.util.find_spec("dm_robotics")
    for folder in (found.submodule_search_locations or []) if found is not None else []:
        path = Path(folder) / MODEL_PATH
        if path.is_file():
            return path
    return None


def build_scene(path: Path, fingertips: bool = True) -> tuple[mujoco.MjSpec, piezotip.Fingertips | None]:
    """The scene: the gripper file as it is, hung from a frame, a box welded between its pads.

    Parameters
    ----------
    path : the 2F-85's XML.
    fingertips : put piezotip's fingertips on the two pad bodies (False: the same scene without,
        to compare against).

    Returns
    -------
    The scene's spec (to compile) and its fingertips (None without).
    """
    gripper = mujoco.MjSpec.from_file(str(path))
    # A fresh spec's <option> is MuJoCo's defaults, as the file's (it has none): the scene's
    # options are the gripper's own.  attach keeps the file's compiler (radians, its mesh
    # folder) for the file's elements and puts every name behind the prefix.
    scene = mujoco.MjSpec()
    scene.modelname = "robotiq_2f85 plain loop"
    wrist = scene.worldbody.add_frame(pos=list(MOUNT_POS_M), quat=list(MOUNT_QUAT))
    scene.attach(gripper, frame=wrist, prefix=PREFIX)
    # No joint: welded to the world, the box cannot fall.  The scene's default geom (contype and
    # conaffinity 1) touches the pads' strips (the pad box's 6/5 bits: strips 6/1).
    box = scene.worldbody.add_body(name=OBJECT, pos=list(OBJECT_POS_M))
    box.add_geom(name=f"{OBJECT}_geom", type=mujoco.mjtGeom.mjGEOM_BOX, size=list(OBJECT_HALF_M))
    tips = piezotip.attach(scene, bodies=list(TIPS)) if fingertips else None
    return scene, tips


def read_tip(model: mujoco.MjModel, data: mujoco.MjData, tip: str) -> dict[str, float]:
    """Fingertip ``tip``'s five sensors from ``data.sensordata``, by name."""
    return {field: float(data.sensordata[model.sensor(f"piezotip/{tip}/{field}").adr[0]]) for field in FIELDS}


def contact_normal_force_n(model: mujoco.MjModel, data: mujoco.MjData, tip: str, other: int) -> float:
    """The normal force MuJoCo reports between fingertip ``tip``'s strips and geom ``other``, N
    (the sum over their contacts, ``mj_contactForce``'s normal component)."""
    strips = f"piezotip/{tip}/"
    force = np.zeros(6)
    total = 0.0
    for i in range(data.ncon):
        pair = (int(data.contact.geom1[i]), int(data.contact.geom2[i]))
        if other not in pair:
            continue
        mine = pair[1] if pair[0] == other else pair[0]
        if model.geom(mine).name.startswith(strips):
            mujoco.mj_contactForce(model, data, i, force)
            total += force[0]
    return total


def step_time_s(model: mujoco.MjModel, data: mujoco.MjData, ctrl: float, steps: int) -> float:
    """Seconds per ``mj_step`` over ``steps`` steps with the servo at ``ctrl`` from where ``data`` is."""
    data.ctrl[model.actuator(ACTUATOR).id] = ctrl
    start = time.perf_counter()
    for _ in range(steps):
        mujoco.mj_step(model, data)
    return (time.perf_counter() - start) / steps


def compare_step_times(path: Path, ctrl: float, seconds: float, rounds: int = 3) -> dict[bool, tuple[float, int]]:
    """Seconds per ``mj_step`` on the scene with and without the fingertips (True, False), and
    the contacts on the box at the end: the same closing, each from its start, in alternating
    rounds (the least of each: the machine's other load only adds)."""
    runs = {}
    for fingertips in (True, False):
        scene, tips = build_scene(path, fingertips)
        runs[fingertips] = (scene.compile(), tips)
    best = {fingertips: (math.inf, 0) for fingertips in runs}
    for _ in range(rounds):
        for fingertips, (model, tips) in runs.items():
            data = mujoco.MjData(model)
            if tips is not None:
                tips.bind(model, data)
            seconds_per_step = step_time_s(model, data, ctrl, round(seconds / model.opt.timestep))
            box = model.geom(f"{OBJECT}_geom").id
            touching = sum(box in (data.contact.geom1[i], data.contact.geom2[i]) for i in range(data.ncon))
            best[fingertips] = min(best[fingertips], (seconds_per_step, int(touching)))
    return best


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--ctrl", type=float, default=DEFAULT_CTRL, help=f"the servo's command, 0-255 (default {DEFAULT_CTRL:g})")
    parser.add_argument("--seconds", type=float, default=2.5, help="simulated time, s (default 2.5)")
    parser.add_argument("--every-s", type=float, default=0.1, help="the table's row interval, s (default 0.1)")
    args = parser.parse_args(argv)
    if not CTRL_RANGE[0] <= args.ctrl <= CTRL_RANGE[1]:
        parser.error(f"--ctrl must be within the servo's ctrlrange {CTRL_RANGE[0]:g}-{CTRL_RANGE[1]:g}, got {args.ctrl!r}")
    if not 0 < args.seconds <= 60:
        parser.error(f"--seconds must be in (0, 60], got {args.seconds!r}")
    if not 0 < args.every_s <= args.seconds:
        parser.error(f"--every-s must be in (0, --seconds], got {args.every_s!r}")
    path = robotiq_2f85_path()
    if path is None:
        print("dm_robotics' Robotiq 2F-85 is not installed: pip install --no-deps dm-robotics-moma", file=sys.stderr)
        return 1

    scene, tips = build_scene(path)
    model = scene.compile()
    data = mujoco.MjData(model)
    sim = tips.bind(model, data)  # from here on every mj_step runs the fingertips
    modes = tips.config.sensor.modes
    box = model.geom(f"{OBJECT}_geom").id
    integrator = mujoco.mjtIntegrator(model.opt.integrator).name.removeprefix("mjINT_")
    print(f"{path.name}: {integrator} at {model.opt.timestep * 1e3:g} ms (the file's: no <option>); fingertips {', '.join(sim.names)}")
    print(f"servo command {args.ctrl:g} of 0-255; the readout samples every {sim.period_s * 1e3:g} ms; modes {list(modes)}")

    head = "".join(f"  {tip + ': status':<27} mode {'estimate +- 3 sigma (Pa)':>24} {'true (Pa)':>10}" for tip in sim.names)
    print(f"\n{'t (s)':>6}{head}")
    steps = round(args.seconds / model.opt.timestep)
    every = max(1, round(args.every_s / model.opt.timestep))
    # The forces over the run's last 0.5 s: a step's contact force may scatter about the statics
    # (module docstring); their means are the statics.
    averaged_from = steps - round(min(0.5, args.seconds / 2) / model.opt.timestep)
    forces_n = {tip: [] for tip in sim.names}
    data.ctrl[model.actuator(ACTUATOR).id] = args.ctrl  # the file's own servo closes the fingers
    for k in range(1, steps + 1):
        mujoco.mj_step(model, data)
        readings = {tip: read_tip(model, data, tip) for tip in sim.names}
        if k > averaged_from:
            for tip in sim.names:
                forces_n[tip].append((sim.pad_state(tip).normal_force_n, contact_normal_force_n(model, data, tip, box)))
        for tip, r in readings.items():
            # Saturated: past the mode's range; a stiffer mode rings up and reads again.
            stiffer = [m for m in modes if m > r["mode"]]
            if r["status"] == SATURATED and stiffer:
                sim.set_mode(tip, stiffer[0])
        if k % every == 0:
            row = ""
            for r in readings.values():
                band = f"{r['pressure_pa']:10.1f} +- {3 * r['sigma_pa']:8.1f}" if r["status"] == 0 else f"{r['pressure_pa']:10.1f}"
                row += f"  {STATUS[int(r['status'])]:<27} {int(r['mode']):>4} {band:>24} {r['true_pressure_pa']:10.1f}"
            print(f"{data.time:6.2f}{row}")

    print(f"\nat t = {data.time:.2f} s:")
    for tip in sim.names:
        r = read_tip(model, data, tip)
        pad_n, contact_n = np.array(forces_n[tip]).T
        if r["status"] == 0:
            inside = abs(r["pressure_pa"] - r["true_pressure_pa"]) <= 3 * r["sigma_pa"]
            said = f"{r['pressure_pa']:.1f} +- {3 * r['sigma_pa']:.1f} Pa (3 sigma), true {r['true_pressure_pa']:.1f} Pa: "
            said += "within" if inside else "OUTSIDE"
        else:
            said = f"{STATUS[int(r['status'])]}, true {r['true_pressure_pa']:.1f} Pa"
        print(f"  {tip}: mode {int(r['mode'])}, {said}")
        print(
            f"  {' ' * len(tip)}  over the last {len(pad_n) * model.opt.timestep:g} s: the pad's normal force {pad_n.mean():.4f} N, "
            f"MuJoCo's contact normal force on its strips {contact_n.mean():.4f} N ({contact_n.mean() / pad_n.mean() - 1:+.2%}; "
            f"step to step +-{contact_n.std() / contact_n.mean():.1%} and +-{pad_n.std() / pad_n.mean():.1%})"
        )
    warned = [mujoco.mjtWarning(w).name for w in range(len(data.warning)) if data.warning[w].number]
    print(f"MuJoCo warnings: {', '.join(warned) or 'none'}")

    # Without the fingertips the file's pad boxes, 5 mm behind the gel's surface, may stop short
    # of the box at a light command: the contacts on the box say which closing was timed.
    times = compare_step_times(path, args.ctrl, args.seconds)
    (with_s, with_contacts), (without_s, without_contacts) = times[True], times[False]
    print(
        f"\none mj_step on this scene, the same closing ({args.seconds:g} s simulated, the least of 3 rounds): "
        f"{with_s * 1e6:.1f} us with the fingertips ({with_contacts} contacts on the box at the end), "
        f"{without_s * 1e6:.1f} us without ({without_contacts}): {with_s / without_s:.2f}x"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
