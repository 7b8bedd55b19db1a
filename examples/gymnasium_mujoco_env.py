"""piezotip's fingertips in a Gymnasium ``MujocoEnv``: the environment a user had, plus attach and bind.

    python examples/gymnasium_mujoco_env.py
    python examples/gymnasium_mujoco_env.py --grip-n 0.5 --steps 500

A two-finger gripper (each finger on a slide joint driven by a force motor, a box site on its
inner face marking the sensing patch, a 30 mm box on a table between them) as an ordinary
``gymnasium.envs.mujoco.MujocoEnv`` subclass: MuJoCo's default options (Euler at 2 ms), two
physics steps per ``env.step``, the motors' force as the action.  What piezotip adds to it is
the override of ``MujocoEnv._initialize_simulation``, where Gymnasium builds ``self.model`` and
``self.data`` from the XML file: load the file as an ``MjSpec``, ``piezotip.attach`` the pads,
compile, make the data, ``bind``.  Nothing else of the environment knows about piezotip: from
then on Gymnasium's own ``mujoco.mj_step`` runs the fingertips (MuJoCo's callbacks) and the
observation reads their MuJoCo sensors by name, as it would any sensor (docs/attach.md,
"Readings in data.sensordata").

The reward is 0: this is the plumbing of an environment, not a task.  ``main`` squeezes with a
constant force and prints what each fingertip reads against the truth the readout never sees.
Headless: no window, nothing written.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path
from typing import ClassVar

import mujoco
import numpy as np
from gymnasium import spaces
from gymnasium.envs.mujoco import MujocoEnv

import piezotip

#: The fingertips: the box sites the pads go on, and what the observation reads of each.
TIPS = ("left_pad", "right_pad")
SENSOR_FIELDS = ("pressure_pa", "sigma_pa", "status", "mode")
#: The finger slide joints (their qpos and qvel are in the observation) and the motors (the action).
FINGER_JOINTS = ("left_slide", "right_slide")
#: The fingers' 20 x 20 mm pads (the sites' x/y half-sizes, m) and the pad's area, m^2.
PAD_HALF_M = 0.01
PAD_AREA_M2 = (2 * PAD_HALF_M) ** 2

# No <option>: MuJoCo's defaults (Euler, 2 ms), as the user wrote them.  Site frames: +z out of
# the finger (towards the box), +x up the finger (towards the palm, where the element is
# clamped).  The gripper is examples/attach_loop.py's but for its <option>.
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


def observation_names() -> list[str]:
    """The observation's entries, in order: the fingers' qpos (m) and qvel (m/s), then each
    fingertip's sensors (``TIP/pressure_pa``, ``TIP/sigma_pa``, ``TIP/status``, ``TIP/mode``)."""
    return (
        [f"{j}/qpos_m" for j in FINGER_JOINTS]
        + [f"{j}/qvel_m_s" for j in FINGER_JOINTS]
        + [f"{tip}/{field}" for tip in TIPS for field in SENSOR_FIELDS]
    )


class GripperEnv(MujocoEnv):
    """The two-finger gripper squeezing a box, with piezotip fingertips on its finger pads.

    Observation (``float64``, :func:`observation_names`): the two finger slides' positions (m)
    and velocities (m/s), then per fingertip its MuJoCo ``user`` sensors ``piezotip/TIP/...``:
    the readout's pressure estimate and its one-sigma uncertainty (Pa), its status (0 ok, 1
    below detection, 2 saturated, 3 settling) and the vibration mode driven.  The estimate and
    sigma are NaN while the readout has no estimate (settling or saturated); the observation
    gives 0 there (``np.nan_to_num``), so that it stays in its Box: the status says which
    readings hold.  The readout samples once a period (4 ms, this environment's step), inside
    the ``mj_step`` that starts it, from the state it starts from (MuJoCo computes sensors
    there): a step's observation holds the readings of the state one step before.

    Action: the two finger motors' force, N (``[0, 20]``, the motors' ``ctrlrange``).
    Reward: 0 (an example of the plumbing, no task); never terminated or truncated (wrap it in
    ``gymnasium.wrappers.TimeLimit`` for episodes).

    Parameters
    ----------
    xml_file : the gripper's MJCF file; None writes :data:`GRIPPER_XML` to a temporary folder for
        the construction (MujocoEnv loads its model from a file).
    frame_skip : physics steps per ``step`` (2: 4 ms, one readout period at MuJoCo's 2 ms).
    reset_noise_scale_m : each finger's start is moved by up to this much at reset (uniform, m).
    **kwargs : MujocoEnv's (``render_mode``, ``width``, ...).
    """

    metadata: ClassVar[dict] = {"render_modes": ["human", "rgb_array", "depth_array", "rgbd_tuple"]}  # render_fps: from dt, below

    def __init__(self, xml_file: str | None = None, frame_skip: int = 2, reset_noise_scale_m: float = 5e-4, **kwargs) -> None:
        self._reset_noise_scale_m = reset_noise_scale_m
        observation_space = spaces.Box(-np.inf, np.inf, shape=(len(observation_names()),), dtype=np.float64)
        if xml_file is None:
            with tempfile.TemporaryDirectory(prefix="piezotip-gripper-") as folder:
                path = Path(folder) / "gripper.xml"
                path.write_text(GRIPPER_XML)
                MujocoEnv.__init__(self, str(path), frame_skip, observation_space, **kwargs)
        else:
            MujocoEnv.__init__(self, xml_file, frame_skip, observation_space, **kwargs)
        self.metadata = {**self.metadata, "render_fps": int(np.round(1.0 / self.dt))}
        self._finger_qpos = [int(self.model.joint(j).qposadr[0]) for j in FINGER_JOINTS]
        self._finger_qvel = [int(self.model.joint(j).dofadr[0]) for j in FINGER_JOINTS]

    def _initialize_simulation(self) -> tuple[mujoco.MjModel, mujoco.MjData]:
        """Gymnasium's, with the fingertips: the model loaded as a spec, ``piezotip.attach``
        before compiling, ``bind`` once the data exists.  These lines are all piezotip adds."""
        spec = mujoco.MjSpec.from_file(self.fullpath)  # Gymnasium: mujoco.MjModel.from_xml_path(self.fullpath)
        self.fingertips = piezotip.attach(spec, sites=list(TIPS))
        model = spec.compile()
        model.vis.global_.offwidth = max(model.vis.global_.offwidth, self.width)  # as Gymnasium's
        model.vis.global_.offheight = max(model.vis.global_.offheight, self.height)
        data = mujoco.MjData(model)
        self.fingertips.bind(model, data)  # from here on every mj_step runs the fingertips
        return model, data

    def _get_obs(self) -> np.ndarray:
        sensors = [self.data.sensor(f"piezotip/{tip}/{field}").data[0] for tip in TIPS for field in SENSOR_FIELDS]
        return np.concatenate(
            [self.data.qpos[self._finger_qpos], self.data.qvel[self._finger_qvel], np.nan_to_num(np.array(sensors), nan=0.0)]
        )

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict]:
        self.do_simulation(action, self.frame_skip)
        return self._get_obs(), 0.0, False, False, {}

    def reset_model(self) -> np.ndarray:
        # Only the fingers' start is drawn: the pad strips start unloaded, the box where the model puts it.
        qpos = self.init_qpos.copy()
        noise = self._reset_noise_scale_m
        qpos[self._finger_qpos] += self.np_random.uniform(-noise, noise, size=len(FINGER_JOINTS))
        self.set_state(qpos, self.init_qvel.copy())
        return self._get_obs()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--grip-n", type=float, default=1.0, help="each finger's squeeze, N (default 1: 2.5 kPa, in mode 1's range)")
    parser.add_argument("--steps", type=int, default=300, help="environment steps (default 300: 1.2 s at 4 ms)")
    parser.add_argument("--seed", type=int, default=0, help="the reset's seed (default 0)")
    args = parser.parse_args(argv)
    if not 0 < args.grip_n <= 20:
        parser.error(f"--grip-n must be in (0, 20] N (the motors' range), got {args.grip_n!r}")
    if not 0 < args.steps <= 100_000:
        parser.error(f"--steps must be in (0, 100000], got {args.steps!r}")

    env = GripperEnv()
    obs, _ = env.reset(seed=args.seed)
    squeeze = np.full(env.action_space.shape, args.grip_n, dtype=env.action_space.dtype)
    for _ in range(args.steps):
        obs, _, _, _, _ = env.step(squeeze)
    reading = dict(zip(observation_names(), obs, strict=True))
    print(f"after {args.steps} steps ({env.unwrapped.data.time:.3f} s) of {args.grip_n:g} N per finger")
    print(f"the grip's pressure: {args.grip_n:g} N over {PAD_AREA_M2 * 1e6:g} mm^2 = {args.grip_n / PAD_AREA_M2:.1f} Pa")
    print(f"{'pad':<9} {'estimate (Pa)':>22}  {'status':>6} {'mode':>4}  {'true (Pa)':>9}")
    for tip in TIPS:
        estimate, sigma = reading[f"{tip}/pressure_pa"], reading[f"{tip}/sigma_pa"]
        # The truth, for evaluation only: a sensor of its own, not in the observation.
        truth = env.unwrapped.data.sensor(f"piezotip/{tip}/true_pressure_pa").data[0]
        print(f"{tip:<9} {estimate:9.1f} +- {3 * sigma:7.1f}  {reading[f'{tip}/status']:6.0f} {reading[f'{tip}/mode']:4.0f}  {truth:9.1f}")
    env.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
