"""The fingertip grasp with flat, scaled spaces (``piezotip/GraspFlat-v0``), for learning libraries.

:class:`GraspFlatEnv` holds a :class:`~piezotip.gym_env.GraspEnv` (the physics, the reward and
the episode's end are all its) and changes only what a learning library sees: one ``Box``
action in [-1, 1]^n scaled to what the robot can do, one ``float32`` ``Box`` observation with
finite bounds scaled by the fingertip's range and the robot's limits, and an episode that ends
once the object is placed and released (``terminate_on_success``).  Every scale is read from the
robot and the fingertip the loop builds for the scenario (:class:`~piezotip.cosim.control.RobotLimits`
as the house controller has it, the model's joint ranges, the fingertip's
``dynamic_range()``), none is typed here.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from piezotip.analysis.referee import Criteria
from piezotip.cosim.assembly import gripper_ranges
from piezotip.cosim.rows import READOUT_STATUSES as STATUS_CODES  # the readout's own (what an agent sees)
from piezotip.gym_env import GraspEnv, MultimodePolicy, ObjectRanges, RewardWeights, real_numbers, shown


def drive_top_speed_m_s(force_limit_n: float, damping_n_s_m: float) -> float:
    """The fastest a drive moves in the controller's model of it, m/s: moving at speed v takes
    the damping it works against times v (RobotLimits), and it has at most its force limit."""
    if not (force_limit_n > 0 and damping_n_s_m > 0 and math.isfinite(force_limit_n / damping_n_s_m)):
        raise ValueError(f"a drive's top speed needs a positive force limit and damping, got {force_limit_n!r} N, {damping_n_s_m!r} N s/m")
    return force_limit_n / damping_n_s_m


@dataclass(frozen=True)
class ActionScale:
    """How the flat action (each entry in [-1, 1]) becomes GraspEnv's action.

    Attributes
    ----------
    grip_max_n : the grip at +1, N per finger: the fingers' force limit (-1 is 0 N, linear between).
    opening_speed_max_m_s : the opening set-point's rate at +-1, m/s (negative closes): the
        fingers' top speed, :func:`drive_top_speed_m_s` of their force limit and the damping
        their drive works against (RobotLimits.finger_damping_n_s_m: the joints' and the servo's).
    lift_speed_max_m_s : the lift set-point's rate at +-1, m/s (positive up): the lift's top
        speed, its force limit over its servo's damping kv (the lift joint has none of its own).
    n_modes : how many modes each pad's entry is binned to: [-1, 1] in n_modes equal bins,
        the lowest mode first.
    """

    grip_max_n: float
    opening_speed_max_m_s: float
    lift_speed_max_m_s: float
    n_modes: int

    def to_grasp(self, action, n_pads: int) -> dict[str, np.ndarray]:
        """GraspEnv's action for the flat ``action`` (clipped to [-1, 1]; anything but real
        numbers of shape (3 + n_pads,), or a non-finite entry, raises ValueError)."""
        a = real_numbers(action)  # strings, complex numbers, bools and dicts are not actions
        if a is None or a.shape != (3 + n_pads,):
            what = f"{3 + n_pads} numbers in [-1, 1] (grip, opening rate, lift rate, a mode per pad), real ints or floats"
            raise ValueError(f"action must be {what}, got {shown(action)}")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"action must be finite, got {shown(action)}")
        a = np.clip(a, -1.0, 1.0)
        modes = np.minimum(np.floor((a[3:] + 1.0) * 0.5 * self.n_modes), self.n_modes - 1).astype(np.int64)
        return {
            "grip_force_n": np.array([(a[0] + 1.0) * 0.5 * self.grip_max_n]),
            "opening_velocity_m_s": np.array([a[1] * self.opening_speed_max_m_s]),
            "lift_velocity_m_s": np.array([a[2] * self.lift_speed_max_m_s]),
            "mode": modes,
        }

    def from_grasp(self, action: Mapping[str, np.ndarray]) -> np.ndarray:
        """The flat action (float32) for GraspEnv's ``action``: rates beyond the top speeds clip to
        +-1, each mode index becomes its bin's centre."""
        grip = float(np.asarray(action["grip_force_n"]).reshape(-1)[0])
        opening = float(np.asarray(action["opening_velocity_m_s"]).reshape(-1)[0])
        lift = float(np.asarray(action["lift_velocity_m_s"]).reshape(-1)[0])
        modes = np.asarray(action["mode"], dtype=float).reshape(-1)
        flat = [2.0 * grip / self.grip_max_n - 1.0, opening / self.opening_speed_max_m_s, lift / self.lift_speed_max_m_s]
        flat += (-1.0 + (2.0 * modes + 1.0) / self.n_modes).tolist()
        return np.clip(np.asarray(flat), -1.0, 1.0).astype(np.float32)


@dataclass(frozen=True)
class ObservationEntry:
    """One entry of the flat observation.

    Attributes
    ----------
    name : ``left_pad.pressure``, ``lift``, ... (``env.unwrapped.observation_names``).
    unit : the unit of the quantity before scaling.
    scale : in words, what it is divided by (and offset by).
    low, high : the entry's bounds in the observation space.
    clipped : True where the quantity can pass the bounds (noise, a joint past its soft limit,
        an impact) and is clipped to them; False where it cannot by construction.
    """

    name: str
    unit: str
    scale: str
    low: float
    high: float
    clipped: bool


class GraspFlatEnv(gym.Env):
    """``piezotip/Grasp-v0`` with one Box action and one scaled float32 Box observation.

    ## Description

    The task, physics, rewards and episode ends of :class:`~piezotip.gym_env.GraspEnv` (its
    docstring); only the spaces differ, and an episode that has succeeded ends
    (``terminate_on_success``).  ``env.unwrapped.grasp_env`` is the GraspEnv inside;
    ``env.unwrapped.grasp_observation`` its last (dict) observation, from which
    :class:`~piezotip.gym_env.MultimodePolicy` drives this environment too:
    ``env.step(env.unwrapped.action_from_grasp(policy(env.unwrapped.grasp_observation)))``.

    ## Action Space

    ``Box(-1, 1, (3 + n_pads,), float32)``; out-of-range values are clipped; anything but real
    numbers (strings, complex numbers, bools, a dict), a non-finite value or a wrong shape raises
    ``ValueError``.  The scales are the robot's (:class:`ActionScale`,
    ``env.unwrapped.action_scale``), read from the RobotLimits the house controller uses:

    | Index | Action | -1 | +1 | Unit |
    |---|---|---|---|---|
    | 0 | grip: the fingers' force limit, per finger | 0 | the fingers' force limit (100) | N |
    | 1 | rate of the opening set-point | -F_fingers / c_fingers | +F_fingers / c_fingers (100 / 30 = 3.3) | m/s |
    | 2 | rate of the lift set-point | -F_lift / kv_lift | +F_lift / kv_lift (300 / 600 = 0.5) | m/s |
    | 3 + i | pad i's mode: [-1, 1] in n_modes equal bins | lowest mode | highest mode | - |

    The grip is linear in the action (the house controller's grips, 0.01 to a few N for light
    objects, sit near -1).  A rate's bound is the drive's top speed (:func:`drive_top_speed_m_s`);
    the set-points still stay in the servos' control range as GraspEnv keeps them.

    ## Observation Space

    ``Box(low, high, (n,), float32)``, every bound finite; ``env.unwrapped.observation_names``
    names the entries in order and ``env.unwrapped.observation_entries`` gives each one's unit,
    scale and bounds.  Per pad (``{pad}``: ``left_pad``, ``right_pad``; ``{m}`` each mode; the
    fingertip's ranges from its ``dynamic_range()``: P_min, P_max the sensor's smallest and
    largest measurable pressure, P_max(m) mode m's largest), then the robot:

    | Name | Quantity | Unit | Scaled as | Bounds | Clipped |
    |---|---|---|---|---|---|
    | ``{pad}.mode_{m}`` | 1 if the reading was taken in mode m (one-hot) | - | - | 0, 1 | no |
    | ``{pad}.status_{s}`` | 1 if the readout's status is s (one-hot; s: ``STATUS_CODES``) | - | - | 0, 1 | no |
    | ``{pad}.amplitude`` | the measured output abs(V_s) / V_0 | - | as is (unloaded 1) | 0, 1 | noise |
    | ``{pad}.i``, ``{pad}.q`` | the lock-in's in-phase and quadrature outputs | - | as is (like V_s / V_0) | -1, 1 | noise |
    | ``{pad}.pressure`` | the readout's pressure estimate (0 with none) | Pa | / P_max | 0, 1 | no |
    | ``{pad}.pressure_log`` | the same on the sensor's log range | Pa | ln(P / P_min) / ln(P_max / P_min), 0 below P_min | 0, 1 | no |
    | ``{pad}.pressure_of_mode`` | the same over the driven mode's range | Pa | / P_max(mode) | 0, 1 | no |
    | ``{pad}.uncertainty`` | its standard deviation; 1 with no estimate | Pa | / P_max | 0, 1 | inf (unresolved) |
    | ``time`` | time since the episode's start | s | / the last observation's, (steps + 1) dt | 0, 1 | no |
    | ``opening`` | opening between the unloaded pad surfaces | m | the finger joints' range to [-1, 1] | -1, 1 | soft joint limit |
    | ``lift`` | lift joint position | m | the lift joint's range to [-1, 1] | -1, 1 | soft joint limit |
    | ``lift_velocity`` | lift joint velocity | m/s | / the lift's top speed (action 2) | -1, 1 | impacts |
    | ``grip_force`` | the fingers' actuator force on each finger | N | / the fingers' force limit | -1, 1 | no |
    | ``lift_force`` | the lift actuator's force | N | / the lift's force limit | -1, 1 | no |
    | ``opening_setpoint`` | the opening set-point | m | the fingers actuator's control range to [-1, 1] | -1, 1 | no |
    | ``lift_setpoint`` | the lift set-point | m | the lift actuator's control range to [-1, 1] | -1, 1 | no |

    STATUS_CODES: ok, below_detection, saturated, settling.  "Clipped" says what can carry a
    quantity past its bounds (there it is clipped): noise and a unit unlike the model past the
    normalized output's physical range, a joint past its soft limit, an impact; "no": it
    cannot (the readout calls a pressure past a mode's P_max saturated, the actuators' forces
    and control ranges are limited, the clock stops at the last step).  An uncertainty is 1
    when the readout has no estimate (settling, saturated): as large as the whole range, it
    says nothing.

    "to a range -> [-1, 1]" is (x - centre) / half-width.  The pressures are linear in Pa over
    five decades, so light touches are near 0 in ``pressure``; ``pressure_log`` spreads the
    sensor's whole range evenly.  ``env.unwrapped.scaled_observation(grasp_observation)`` gives
    the entries before clipping.

    ## Episode End

    GraspEnv's (crushed, dropped, lost, diverged; truncated at the scenario's duration), and,
    with ``terminate_on_success`` (the default), terminated at the first step at which the
    referee (``analysis/referee.py``) judges the episode so far a success: lifted, held, put
    back at rest within its tolerance of the starting height, released.  ``info`` then carries
    ``outcome`` ("success"), ``reason``, ``verdict`` and ``ended`` ("success"), and the reward
    GraspEnv's ``reward_success``.  An ended episode takes no more steps: ``step()`` raises
    ``RuntimeError`` until ``reset()`` (the success bonus is paid once).

    ## Arguments

    GraspEnv's (``scenario``, ``overrides``, ``preset``, ``render_mode``, ``randomize_object``,
    ``reward``, ``width``, ``height``) and ``terminate_on_success`` (default True).

    ## Version History

    - v0: the first version.
    """

    metadata: ClassVar[dict] = dict(GraspEnv.metadata)

    def __init__(
        self,
        scenario: str = "grasp",
        overrides=None,
        preset: str | None = None,
        render_mode: str | None = None,
        randomize_object: bool | ObjectRanges = False,
        reward: RewardWeights | None = None,
        width: int = 640,
        height: int = 480,
        terminate_on_success: bool = True,
    ) -> None:
        if not isinstance(terminate_on_success, bool):
            raise ValueError(f"terminate_on_success must be True or False, got {terminate_on_success!r}")
        self.grasp_env = GraspEnv(scenario, overrides, preset, render_mode, randomize_object, reward, width, height)
        self.terminate_on_success = terminate_on_success
        self.render_mode = render_mode
        grasp = self.grasp_env
        self.pads, self.modes = grasp.pads, grasp.modes
        # The robot and the fingertip as the loop builds them for the house controller.
        house = MultimodePolicy.for_env(grasp)
        robot, fingertip = house.robot, house.fingertip
        self.action_scale = ActionScale(
            grip_max_n=robot.finger_force_limit_n,
            opening_speed_max_m_s=drive_top_speed_m_s(robot.finger_force_limit_n, robot.finger_damping_n_s_m),
            lift_speed_max_m_s=drive_top_speed_m_s(robot.lift_force_limit_n, robot.lift_kv_n_s_m),
            n_modes=len(self.modes),
        )
        self.action_space = spaces.Box(-1.0, 1.0, (3 + len(self.pads),), np.float32)

        span = fingertip.dynamic_range()
        self.p_min_pa, self.p_max_pa = float(span["p_min_pa"]), float(span["p_max_pa"])
        self.mode_p_max_pa = np.array([fingertip.upper_limit(m) for m in self.modes])
        if not (0 < self.p_min_pa < self.p_max_pa < math.inf) or not np.all(self.mode_p_max_pa > 0):
            raise ValueError(
                f"the fingertip's range must be finite and positive to scale pressures: P_min {self.p_min_pa!r} Pa, "
                f"P_max {self.p_max_pa!r} Pa, per mode {self.mode_p_max_pa.tolist()!r} Pa"
            )
        self.opening_joint_range_m = gripper_ranges(grasp.base_config).opening_joint_range_m  # the openings the fingers reach
        self.lift_joint_range_m = tuple(float(x) for x in robot.lift_range_m)
        self.lift_force_limit_n, self.finger_force_limit_n = robot.lift_force_limit_n, robot.finger_force_limit_n
        self.last_time_s = (grasp.total_steps + 1) * grasp.dt

        self.observation_entries = self._entries()
        self.observation_names = tuple(e.name for e in self.observation_entries)
        low = np.array([e.low for e in self.observation_entries], np.float32)
        high = np.array([e.high for e in self.observation_entries], np.float32)
        self.observation_space = spaces.Box(low, high, dtype=np.float32)
        self.grasp_observation: dict[str, np.ndarray] | None = None
        self._ended: str | None = None  # what ended the episode ("terminated: success", ...), None while it runs
        self._status_ok = [STATUS_CODES.index(s) for s in ("ok", "below_detection")]
        self._gate = PlacedReleasedGate()

    # -- Gymnasium API -------------------------------------------------------------------

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        obs, info = self.grasp_env.reset(seed=seed, options=options)
        self.grasp_observation = obs
        self._gate.start()
        self._ended = None
        return self._flat(obs), info

    def step(self, action):
        if self.grasp_observation is None:
            raise RuntimeError("call reset() before step()")
        if self._ended is not None:
            # A success ends the episode here while GraspEnv's goes on: stepped on, the gate
            # opened again and paid the bonus again.
            raise RuntimeError(f"the episode has ended ({self._ended}); call reset() before step()")
        obs, reward, terminated, truncated, info = self.grasp_env.step(self.action_to_grasp(action))
        self.grasp_observation = obs
        if self.terminate_on_success and not terminated:
            starts = self._gate.opens(self.grasp_env.last_row())  # every step: it follows the object's rise
            if truncated:  # the scenario's end: GraspEnv has judged (and paid) the episode
                succeeded = info.get("outcome") == "success"
            elif starts:
                verdict = self.grasp_env.verdict()
                succeeded = verdict.success
                if succeeded:
                    success = self.grasp_env.weights.success
                    reward += success
                    info.update(reward_success=success, outcome=verdict.outcome, reason=verdict.reason, verdict=verdict.as_dict())
            else:
                succeeded = False
            if succeeded:
                terminated, truncated = True, False
                info["ended"] = "success"
        if terminated or truncated:
            self._ended = f"{'terminated' if terminated else 'truncated'}: {info.get('ended', 'duration')}"
        return self._flat(obs), float(reward), terminated, truncated, info

    def render(self):
        return self.grasp_env.render()

    def close(self) -> None:
        self.grasp_env.close()
        super().close()

    # -- the mappings --------------------------------------------------------------------

    @property
    def base_config(self):
        """The scenario's configuration (GraspEnv's; ``MultimodePolicy.for_env`` reads it)."""
        return self.grasp_env.base_config

    @property
    def config(self):
        """This episode's configuration, its object included (GraspEnv's; None before a reset)."""
        return self.grasp_env.config

    def action_to_grasp(self, action) -> dict[str, np.ndarray]:
        """GraspEnv's action for a flat one (:meth:`ActionScale.to_grasp`)."""
        return self.action_scale.to_grasp(action, len(self.pads))

    def action_from_grasp(self, action: Mapping[str, np.ndarray]) -> np.ndarray:
        """The flat action for a GraspEnv action (a house controller's, say)."""
        return self.action_scale.from_grasp(action)

    def scaled_observation(self, obs: Mapping[str, np.ndarray]) -> np.ndarray:
        """The flat observation of GraspEnv's ``obs``, scaled, before clipping (float64)."""
        n, m = len(self.pads), len(self.modes)
        mode = np.asarray(obs["mode"], dtype=np.int64)
        status = np.asarray(obs["status"], dtype=np.int64)
        has_estimate = np.isin(status, self._status_ok)
        pressure = np.asarray(obs["pressure_pa"], dtype=float)
        log_span = math.log(self.p_max_pa / self.p_min_pa)
        pressure_log = np.log(np.maximum(pressure, self.p_min_pa) / self.p_min_pa) / log_span
        # An uncertainty as large as the sensor's whole range says nothing more: 1 is "unknown".
        uncertainty = np.where(has_estimate, np.minimum(np.asarray(obs["uncertainty_pa"], dtype=float) / self.p_max_pa, 1.0), 1.0)
        per_pad = np.column_stack(
            [
                np.eye(m)[mode],
                np.eye(len(STATUS_CODES))[status],
                np.asarray(obs["amplitude"], dtype=float),
                np.asarray(obs["iq"], dtype=float).reshape(n, 2),
                pressure / self.p_max_pa,
                pressure_log,
                pressure / self.mode_p_max_pa[mode],
                uncertainty,
            ]
        )

        def centred(x, lo_hi):
            lo, hi = lo_hi
            return (float(x[0]) - 0.5 * (lo + hi)) / (0.5 * (hi - lo))

        grasp = self.grasp_env
        robot = [
            float(obs["time_s"][0]) / self.last_time_s,
            centred(obs["opening_m"], self.opening_joint_range_m),
            centred(obs["lift_m"], self.lift_joint_range_m),
            float(obs["lift_velocity_m_s"][0]) / self.action_scale.lift_speed_max_m_s,
            float(obs["grip_force_n"][0]) / self.finger_force_limit_n,
            float(obs["lift_force_n"][0]) / self.lift_force_limit_n,
            centred(obs["opening_setpoint_m"], grasp.opening_range_m),
            centred(obs["lift_setpoint_m"], grasp.lift_range_m),
        ]
        return np.concatenate([per_pad.reshape(-1), robot])

    # -- internals ------------------------------------------------------------------------

    def _flat(self, obs: Mapping[str, np.ndarray]) -> np.ndarray:
        space = self.observation_space
        return np.clip(self.scaled_observation(obs), space.low, space.high).astype(np.float32)

    def _entries(self) -> tuple[ObservationEntry, ...]:
        """The entries in :meth:`scaled_observation`'s order (the class docstring's table)."""
        entries = []
        for pad in self.pads:
            entries += [ObservationEntry(f"{pad}.mode_{m}", "-", "one-hot", 0.0, 1.0, False) for m in self.modes]
            entries += [ObservationEntry(f"{pad}.status_{s}", "-", "one-hot", 0.0, 1.0, False) for s in STATUS_CODES]
            log_scale = f"ln(P / {self.p_min_pa:.6g} Pa) / ln({self.p_max_pa:.6g} / {self.p_min_pa:.6g})"
            mode_scale = "/ P_max(mode): " + ", ".join(f"{p:.6g}" for p in self.mode_p_max_pa)
            entries += [
                ObservationEntry(f"{pad}.amplitude", "-", "as is", 0.0, 1.0, True),
                ObservationEntry(f"{pad}.i", "-", "as is", -1.0, 1.0, True),
                ObservationEntry(f"{pad}.q", "-", "as is", -1.0, 1.0, True),
                ObservationEntry(f"{pad}.pressure", "Pa", f"/ P_max = {self.p_max_pa:.6g} Pa", 0.0, 1.0, False),
                ObservationEntry(f"{pad}.pressure_log", "Pa", log_scale, 0.0, 1.0, False),
                ObservationEntry(f"{pad}.pressure_of_mode", "Pa", mode_scale, 0.0, 1.0, False),
                ObservationEntry(f"{pad}.uncertainty", "Pa", f"/ P_max = {self.p_max_pa:.6g} Pa, at most 1", 0.0, 1.0, True),
            ]
        grasp, speed = self.grasp_env, self.action_scale.lift_speed_max_m_s

        def ranged(lo_hi):
            return f"(x - {0.5 * (lo_hi[0] + lo_hi[1]):.6g}) / {0.5 * (lo_hi[1] - lo_hi[0]):.6g}"

        entries += [
            ObservationEntry("time", "s", f"/ {self.last_time_s:.6g}", 0.0, 1.0, False),
            ObservationEntry("opening", "m", ranged(self.opening_joint_range_m), -1.0, 1.0, True),
            ObservationEntry("lift", "m", ranged(self.lift_joint_range_m), -1.0, 1.0, True),
            ObservationEntry("lift_velocity", "m/s", f"/ {speed:.6g}", -1.0, 1.0, True),
            ObservationEntry("grip_force", "N", f"/ {self.finger_force_limit_n:.6g}", -1.0, 1.0, False),
            ObservationEntry("lift_force", "N", f"/ {self.lift_force_limit_n:.6g}", -1.0, 1.0, False),
            ObservationEntry("opening_setpoint", "m", ranged(grasp.opening_range_m), -1.0, 1.0, False),
            ObservationEntry("lift_setpoint", "m", ranged(grasp.lift_range_m), -1.0, 1.0, False),
        ]
        return tuple(entries)


class PlacedReleasedGate:
    """Opens at the control period where the referee's "placed and released" state begins.

    The referee's own tests on the record's last row (analysis.referee.judge): no finger
    touches the object, which rests on the table within ``placed_tolerance_m`` of its starting
    height, after it has been off the table.  Only where that state begins is the whole episode
    worth judging (GraspEnv.verdict, which reads the whole record): while it lasts, nothing the
    verdict depends on (the rise, the hold, the slip, the landing) can change.  One per
    environment; :meth:`start` at each reset, :meth:`opens` on every recorded row.
    """

    def __init__(self, criteria: Criteria | None = None) -> None:
        self.criteria = Criteria() if criteria is None else criteria
        self.start()

    def start(self) -> None:
        """Forget the episode (a reset)."""
        self._z0: float | None = None
        self._max_rise_m = -math.inf
        self._was_resting_released = False

    def opens(self, row: Mapping[str, float]) -> bool:
        """Whether ``row`` (GraspEnv.last_row(): column name -> value) opens the state."""
        c = self.criteria
        z = row["object_height_m"]
        if self._z0 is None:
            self._z0 = z
        rise = z - self._z0
        self._max_rise_m = max(self._max_rise_m, rise)
        touching = row["left_finger_force_n"] > c.contact_force_n or row["right_finger_force_n"] > c.contact_force_n
        at_rest = row["object_speed_m_s"] < c.rest_speed_m_s
        resting = abs(rise) <= c.placed_tolerance_m and at_rest and row["table_force_n"] > c.contact_force_n
        now = resting and not touching and self._max_rise_m > c.placed_tolerance_m
        starts = now and not self._was_resting_released
        self._was_resting_released = now
        return starts
