"""The fingertip grasp as a Gymnasium environment (``piezotip/Grasp-v0``), and the multimode
controller wrapped as a policy for it.

``import piezotip`` registers the environment with Gymnasium without importing Gymnasium
(:mod:`piezotip.gym_registration`); this module imports it.  The physics is the command
line's: one environment step is one control period of
:class:`~piezotip.cosim.loop.CoSimulation`, in the loop's own order, with the agent's action as
the controller's :class:`~piezotip.cosim.control.Command` for that step.  ``MultimodePolicy``
driving the environment therefore records the same steps as ``run_sim.py run`` and earns the
same referee outcome (tests/test_gym_env.py).
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import reprlib
from collections.abc import Mapping
from dataclasses import dataclass
from typing import ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from piezotip.analysis.video import check_render_side, choose_headless_backend, import_mujoco

# MuJoCo loads the OpenGL backend MUJOCO_GL names on its first import (which the imports below
# make); one that cannot load is one line naming MUJOCO_GL, not a traceback from PyOpenGL.  With
# no MUJOCO_GL and no display, GLFW (MuJoCo's default) could not render here: a headless backend
# (EGL, else OSMesa) is chosen first, so render_mode="rgb_array" works on a headless machine.
choose_headless_backend()
import_mujoco()

from piezotip import controllers, scenarios  # noqa: E402
from piezotip.analysis.referee import Criteria, judge  # noqa: E402
from piezotip.cosim.control import Command, Observation, PadSignal, Phase, RobotLimits, make_command  # noqa: E402
from piezotip.cosim.gripper_mount import HOME_CLEARANCE_M  # noqa: E402
from piezotip.cosim.loop import CoSimulation, SimulationDiverged, make_controller  # noqa: E402
from piezotip.cosim.rows import READOUT_STATUSES as STATUS_CODES  # noqa: E402
from piezotip.scenarios.config import RATED_MASS_KG, ObjectConfig, ScenarioConfig  # noqa: E402
from piezotip.sensor.estimator import Estimate  # noqa: E402
from piezotip.sensor.resonator import Reading  # noqa: E402

#: The object is lost when its centre is farther than this from the fingers' axis, m: half the
#: open fingers' 90 mm span (cosim.scene.HOME_OPENING_M), beyond their reach.
LOST_RADIUS_M = 0.045
#: Action keys, in the order the manual lists them.
ACTION_KEYS = ("grip_force_n", "opening_velocity_m_s", "lift_velocity_m_s", "mode")


@dataclass(frozen=True)
class ObjectRanges:
    """Where ``randomize_object=True`` draws each episode's object from (its shape is the scenario's).

    Attributes
    ----------
    mass_kg : (low, high), kg, drawn log-uniformly: the gripper's rated 1 g to 10 kg
        (scenarios.config.RATED_MASS_KG).
    size_m : (low, high), m, uniform: 20 to 80 mm, the span of the object catalogue
        (scenarios/objects.py); the scene takes 12 to 85 mm.
    friction : (low, high), uniform: 0.3 (glass on the pads' silicone) to 1.2 (rubber), the
        catalogue's span.
    crush_force_n : (low, high), N per finger, log-uniform: 0.1 N (the catalogue's paper ball)
        to 100 N (the fingers' force limit: a higher crush limit cannot be reached).
    """

    mass_kg: tuple[float, float] = RATED_MASS_KG
    size_m: tuple[float, float] = (0.02, 0.08)
    friction: tuple[float, float] = (0.3, 1.2)
    crush_force_n: tuple[float, float] = (0.1, 100.0)

    def sample(self, rng: np.random.Generator, base: ObjectConfig) -> ObjectConfig:
        """An object of ``base``'s shape with mass, size, friction and crush limit drawn from the ranges."""

        def log_uniform(lo_hi):
            lo, hi = lo_hi
            return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))

        obj = dataclasses.replace(
            base,
            mass_kg=log_uniform(self.mass_kg),
            size_m=float(rng.uniform(*self.size_m)),
            friction=float(rng.uniform(*self.friction)),
            crush_force_n=log_uniform(self.crush_force_n),
        )
        obj.validate()
        return obj

    def validate(self) -> ObjectRanges:
        """Check that every range is (low, high) with low <= high, and that both ends make a valid object."""
        for name in ("mass_kg", "size_m", "friction", "crush_force_n"):
            pair = getattr(self, name)
            if len(pair) != 2 or not (0 < pair[0] <= pair[1]):
                raise ValueError(f"ObjectRanges.{name} must be (low, high) with 0 < low <= high, got {pair!r}")
        for end in (0, 1):
            ObjectConfig(
                mass_kg=self.mass_kg[end], size_m=self.size_m[end], friction=self.friction[end], crush_force_n=self.crush_force_n[end]
            ).validate()
        return self

    def fitted(self, widest_m: float, given: bool) -> ObjectRanges:
        """These ranges for a gripper that takes objects up to ``widest_m`` (m) wide
        (:attr:`cosim.assembly.GripperRanges.widest_object_m`): the defaults (``given`` False) with
        their sizes cut there; ranges the user gave (``given``) that reach past it are a
        ValueError naming the size, not an episode's reset that fails on the object drawn."""
        low, high = self.size_m
        if high <= widest_m:
            return self
        if given or low > widest_m:
            raise ValueError(
                f"randomize_object: ObjectRanges.size_m {self.size_m!r} reaches past the widest object this gripper takes, "
                f"{widest_m:.4g} m (its open pads less {1e3 * HOME_CLEARANCE_M:g} mm a side)"
            )
        return dataclasses.replace(self, size_m=(low, widest_m))


@dataclass(frozen=True)
class RewardWeights:
    """The default reward's weights (the class docstring of :class:`GraspEnv`, "Rewards").

    Attributes
    ----------
    lift_per_s : per second carried without slip, times the share of the lift height risen, 1/s.
    hold_per_s : per second carried at the lift height without slip, up to the scenario's hold
        time, 1/s.
    grip_per_s : per second, the grip beyond need over the grip scale (the object's crush limit,
        else the fingers' force limit), 1/s.
    grip_margin : the grip "need" is this times the friction limit m g / (2 mu): 1.25, the
        10-40 % margin people keep (Johansson and Westling 1984, Exp. Brain Res. 56).
    crush : paid once when a finger presses harder than the crush limit (ends the episode).
    drop : paid once when the object is dropped or lost (ends the episode).
    success : paid at the episode's end when the referee's outcome is ``success``.
    """

    lift_per_s: float = 1.0
    hold_per_s: float = 1.0
    grip_per_s: float = 1.0
    grip_margin: float = 1.25
    crush: float = 10.0
    drop: float = 10.0
    success: float = 10.0


class _AgentController:
    """The loop's controller in the environment: it returns the command the agent's action made."""

    phase = Phase.APPROACH  # the agent has no phases; the record's phase column stays 0
    finished = False

    def __init__(self) -> None:
        self.events: list = []
        self.command: Command | None = None

    def step(self, obs: Observation, dt_s: float) -> Command:
        return self.command


class GraspEnv(gym.Env):
    """A parallel gripper with multimode piezoelectric fingertips grasps, lifts and holds an object.

    ## Description

    The co-simulation of ``run_sim.py run`` as a Gymnasium task: MuJoCo's gripper (a lift and
    two fingers on one force-limited position servo, gel pads on the fingertips), the
    fingertips' vibration sensors (gel -> bimorph -> readout), and the scenario's object
    (``scenarios/objects.py``).  The agent is the grasp controller: each step (one 5 ms control
    period) it sees what the robot's own sensors give and sets the grip, the fingers' and the
    lift's set-point rates and the mode each fingertip drives.  The object's pose, mass and the
    simulator's contact forces are never observed; they set the reward and the episode's end,
    as the referee (``analysis/referee.py``) judges them.

    ## Action Space

    ``Dict``; the continuous parts are float64 arrays of shape (1,).

    | Key | Action | Min | Max | Type (Unit) |
    |---|---|---|---|---|
    | ``grip_force_n`` | the fingers' force limit: the squeeze on the object, per finger | 0 | the fingers' limit (100) | Box (N) |
    | ``opening_velocity_m_s`` | rate of the opening set-point (negative closes) | -range / dt | range / dt | Box (m/s) |
    | ``lift_velocity_m_s`` | rate of the lift set-point (positive up) | -range / dt | range / dt | Box (m/s) |
    | ``mode`` | per instrumented pad, the index of the mode to drive in ``env.unwrapped.modes`` | 0 | n_modes - 1 | MultiDiscrete (-) |

    Both fingers share one drive, so the grip is one number, the force on each finger.  The
    drive is a force-limited position servo: the grip is its force limit, what the fingers press
    with once they meet the object; the opening's rate says how they move until then (the
    multimode controller closes at 20 mm/s so that the fingertips feel the touch before the pads
    press on), so the action has both.  The set-points integrate their rates over the step
    (``setpoint += rate dt``, kept in the servo's control range: opening 0 to 0.1 m, lift -0.3
    to 0.1 m) and the servos follow them with their own gains and force limits
    (``models/gripper.xml``); a rate's bound moves its
    set-point across its whole range in one step, so any set-point a controller may want is
    reachable (the servo, not the bound, limits the motion).  Out-of-bounds values of the
    continuous parts are clipped to the bounds; a value that is not a real number (a string, a
    complex number, a bool, a dict), a non-finite value, a mode index outside ``0..n_modes-1``,
    a missing or extra key raise ``ValueError``.

    ## Observation Space

    ``Dict`` of arrays (float64 unless stated; per-pad arrays in ``env.unwrapped.pads``
    order).  Only what the robot's own sensors and design give:

    | Key | Observation | Min | Max | Type (Unit) |
    |---|---|---|---|---|
    | ``time_s`` | time since the episode's start | 0 | inf | Box(1) (s) |
    | ``mode`` | per pad, index of the mode the reading was taken in | 0 | n_modes - 1 | MultiDiscrete (-) |
    | ``amplitude`` | per pad, the measured output amplitude abs(V_s) / V_0 (noisy) | 0 | inf | Box(n_pads) (-) |
    | ``iq`` | per pad, the lock-in's in-phase and quadrature outputs, normalized like it | -inf | inf | Box(n_pads, 2) (-) |
    | ``pressure_pa`` | per pad, the readout's pressure estimate (0 with no estimate) | 0 | inf | Box(n_pads) (Pa) |
    | ``uncertainty_pa`` | per pad, its standard deviation (0 with no estimate; inf where unresolved) | 0 | inf | Box(n_pads) (Pa) |
    | ``status`` | per pad, the readout's status: 0 ok, 1 below_detection, 2 saturated, 3 settling | 0 | 3 | MultiDiscrete (-) |
    | ``settled`` | per pad, 1 when the readout trusts its estimate (status is not settling) | 0 | 1 | MultiBinary (-) |
    | ``opening_m`` | opening between the unloaded pad surfaces (finger joints) | -inf | inf | Box(1) (m) |
    | ``lift_m`` | lift joint position | -inf | inf | Box(1) (m) |
    | ``lift_velocity_m_s`` | lift joint velocity (its encoder) | -inf | inf | Box(1) (m/s) |
    | ``grip_force_n`` | the fingers' actuator force on each finger (positive squeezes) | -inf | inf | Box(1) (N) |
    | ``lift_force_n`` | the lift actuator's force (positive up) | -inf | inf | Box(1) (N) |
    | ``opening_setpoint_m`` | the opening set-point the actions have made | 0 | 0.1 | Box(1) (m) |
    | ``lift_setpoint_m`` | the lift set-point the actions have made | -0.3 | 0.1 | Box(1) (m) |

    The estimate has no value while the readout settles (after a mode switch or a load step)
    or saturates; ``pressure_pa`` and ``uncertainty_pa`` are then 0 and ``status`` says why.
    The amplitude and I/Q are the driven mode's, as a lock-in gives them under every sensor
    dynamics (``steady``, ``envelope``, ``carrier``).

    ## Rewards

    From the referee's ground truth, per step of ``dt`` = 5 ms (weights: :class:`RewardWeights`):

    - ``reward_lift`` = ``lift_per_s`` dt min(rise / lift_height, 1) while the object is carried
      (both fingers touch it, it is above the table) and has not slipped more than the
      referee's 5 mm in the fingers;
    - ``reward_hold`` = ``hold_per_s`` dt while carried within 5 mm of the lift height without
      slip, until the scenario's hold time has been earned;
    - ``reward_grip`` = -``grip_per_s`` dt max(grip - need, 0) / scale, grip the larger finger
      force on the object, need = ``grip_margin`` m g / (2 mu), scale the crush limit (else the
      fingers' force limit);
    - ``reward_crush`` = -``crush`` once, when a finger presses harder than the crush limit;
    - ``reward_drop`` = -``drop`` once, when the object falls free, lands faster than 0.1 m/s,
      or is lost;
    - ``reward_success`` = ``success`` at the episode's end if the referee's outcome of the
      whole episode is ``success`` (lifted, held, put back, released, never crushed).

    ``reward`` is their sum; each part is in ``info`` under its name, as in Gymnasium's MuJoCo
    environments.

    ## Starting State

    The scenario's home: the gripper open (90 mm) around the object's centre height, the object
    at rest on the table, the drive in the lowest mode, one control period simulated (the first
    readings).  ``reset(seed=S)`` seeds the readout noise with S (the scenario's
    ``sensor.seed``: ``reset(seed=0)`` is ``run_sim.py run``'s episode) and the object draw; a
    reset without a seed continues the seeded sequence.  ``reset(options={"object": obj})``
    grasps the :class:`~piezotip.scenarios.config.ObjectConfig` ``obj`` in this episode instead
    (``piezotip/GraspLearn-v0`` draws its objects so).

    ## Episode End

    Terminated when the object is crushed, dropped (free above the table for two steps, or
    landing faster than 0.1 m/s) or lost (its centre more than 45 mm from the fingers' axis, or
    below the table top), or when the simulation diverges (``info["error"]``).  Truncated at
    the scenario's duration (``duration_s`` / dt steps).  At the end ``info`` carries the
    referee's ``outcome``, ``reason`` and ``verdict`` (a dict) for the whole episode, which
    counts as finished (an object still held is ``timeout``: not released); ``info["ended"]``
    says which condition ended it.  ``env.unwrapped.recording()`` is the episode's record, the
    columns of ``run.npz``.  An ended episode takes no more steps: ``step()`` raises
    ``RuntimeError`` until ``reset()`` (its end and its bonus are paid once).

    ## Arguments

    | Argument | Default | Meaning |
    |---|---|---|
    | ``scenario`` | ``"grasp"`` | a registered scenario (``run_sim.py list``) |
    | ``overrides`` | None | ``{"object.mass_kg": 0.4}`` or ``["object.mass_kg=0.4"]``, as ``--set`` |
    | ``preset`` | None | ``fast``, ``balanced``, ``accurate``, ``reference`` |
    | ``render_mode`` | None | None or ``"rgb_array"`` (the scene's ``grasp_camera``) |
    | ``randomize_object`` | False | True (:class:`ObjectRanges`' defaults, sizes cut to the gripper's) or an ``ObjectRanges`` |
    | ``reward`` | None | a :class:`RewardWeights` (None: the defaults) |
    | ``width``, ``height`` | 640, 480 | ``render()``'s image size, pixels (whole, 1 to 4096) |

    An unknown scenario or override, and a render size that is not a whole number of pixels in
    1..4096, raise the command line's ``ValueError``.  With ``render_mode="rgb_array"``, no
    display and no ``MUJOCO_GL``, the environment renders through EGL (else OSMesa), chosen before
    MuJoCo's first import; a renderer that cannot be made raises ``RendererUnavailable`` naming
    ``MUJOCO_GL``, on every ``render()``.

    ## Version History

    - v0: the first version.
    """

    metadata: ClassVar[dict] = {"render_modes": ["rgb_array"], "render_fps": 30}

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
    ) -> None:
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        # Checked here, before anything reaches MuJoCo's renderer (a negative size aborts the interpreter).
        self.width, self.height = check_render_side("width", width), check_render_side("height", height)
        self.render_mode = render_mode
        self.base_config: ScenarioConfig = scenarios.get(scenario, overrides, preset)
        if isinstance(randomize_object, ObjectRanges):
            self.object_ranges: ObjectRanges | None = randomize_object.validate()
        elif randomize_object is True:
            self.object_ranges = ObjectRanges().validate()
        elif randomize_object is False:
            self.object_ranges = None
        else:
            raise ValueError(f"randomize_object must be True, False or an ObjectRanges, got {randomize_object!r}")
        self.weights = reward if reward is not None else RewardWeights()
        if not isinstance(self.weights, RewardWeights):
            raise ValueError(f"reward must be a RewardWeights, got {reward!r}")
        cfg = self.base_config
        self.pads = tuple(f"{p}_pad" for p in cfg.sensor.pads)
        self.modes = tuple(cfg.sensor.modes)
        self.dt = cfg.physics.control_period_s
        self.total_steps = math.ceil(cfg.duration_s / self.dt - 1e-9)
        from piezotip.cosim.assembly import gripper_ranges

        ranges = gripper_ranges(cfg)  # the house gripper's servos, or a mounted gripper's drive (gripper.mjcf)
        if self.object_ranges is not None:  # objects a mounted gripper's narrower pads take (robosuite's Panda: 64 mm)
            self.object_ranges = self.object_ranges.fitted(ranges.widest_object_m, isinstance(randomize_object, ObjectRanges))
        self.lift_range_m, self.opening_range_m = ranges.lift_range_m, ranges.opening_range_m
        self.finger_force_limit_n, self.gravity_m_s2 = ranges.finger_force_limit_n, ranges.gravity_m_s2
        n, m = len(self.pads), len(self.modes)
        f64, inf = np.float64, np.inf
        lift_rate = (self.lift_range_m[1] - self.lift_range_m[0]) / self.dt
        opening_rate = (self.opening_range_m[1] - self.opening_range_m[0]) / self.dt
        self.action_space = spaces.Dict(
            {
                "grip_force_n": spaces.Box(0.0, self.finger_force_limit_n, (1,), f64),
                "opening_velocity_m_s": spaces.Box(-opening_rate, opening_rate, (1,), f64),
                "lift_velocity_m_s": spaces.Box(-lift_rate, lift_rate, (1,), f64),
                "mode": spaces.MultiDiscrete([m] * n),
            }
        )

        def scalar(lo=-inf, hi=inf):
            return spaces.Box(lo, hi, (1,), f64)

        self.observation_space = spaces.Dict(
            {
                "time_s": scalar(0.0),
                "mode": spaces.MultiDiscrete([m] * n),
                "amplitude": spaces.Box(0.0, inf, (n,), f64),
                "iq": spaces.Box(-inf, inf, (n, 2), f64),
                "pressure_pa": spaces.Box(0.0, inf, (n,), f64),
                "uncertainty_pa": spaces.Box(0.0, inf, (n,), f64),
                "status": spaces.MultiDiscrete([len(STATUS_CODES)] * n),
                "settled": spaces.MultiBinary(n),
                "opening_m": scalar(),
                "lift_m": scalar(),
                "lift_velocity_m_s": scalar(),
                "grip_force_n": scalar(),
                "lift_force_n": scalar(),
                "opening_setpoint_m": scalar(*self.opening_range_m),
                "lift_setpoint_m": scalar(*self.lift_range_m),
            }
        )
        self._status_index = {s: i for i, s in enumerate(STATUS_CODES)}
        self._mode_index = {mode: i for i, mode in enumerate(self.modes)}
        self.sim: CoSimulation | None = None
        self.config: ScenarioConfig | None = None
        self._ended: str | None = None  # what ended the episode ("terminated: crushed", ...), None while it runs
        self._renderer = None
        self._rendered_model = None

    # -- Gymnasium API -------------------------------------------------------------------

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        cfg = self.base_config
        obj = self._episode_object(options)
        noise_seed = int(seed) if seed is not None else int(self.np_random.integers(2**31))
        self.config = dataclasses.replace(cfg, object=obj, sensor=dataclasses.replace(cfg.sensor, seed=noise_seed)).validate()
        # The loop's own controller is replaced by the agent's: build a cheap one (a sensing one
        # would run the element's self-test for nothing).
        sim = self.sim = CoSimulation(_with_blind_controller(self.config))
        sim.controller = _AgentController()
        self._lift_sp, self._opening_sp = sim.robot.home_lift_m, sim.robot.home_opening_m
        self._rows: list[list[float]] = []
        self._episode_start()
        self._error: str | None = None
        self._ended = None
        self._sense_next()
        return self._observation(), {"time_s": sim.time_s}

    def _episode_object(self, options: dict | None) -> ObjectConfig:
        """The episode's object: ``options["object"]`` (an ObjectConfig, checked) if given, else a
        draw from the ranges (``randomize_object``), else the scenario's."""
        if options is not None and "object" in options:
            obj = options["object"]
            if not isinstance(obj, ObjectConfig):
                raise ValueError(f"options['object'] must be an ObjectConfig, got {shown(obj)}")
            obj.validate()
            return obj
        if self.object_ranges is not None:
            return self.object_ranges.sample(self.np_random, self.base_config.object)
        return self.base_config.object

    def step(self, action):
        if self.sim is None:
            raise RuntimeError("call reset() before step()")
        if self._ended is not None:
            # Stepped on, the episode would be judged and paid again (Gymnasium leaves the
            # behaviour past an end undefined; an error cannot be mistaken for a result).
            raise RuntimeError(f"the episode has ended ({self._ended}); call reset() before step()")
        sim = self.sim
        command = self._command(action)
        # CoSimulation.advance in its two halves (sense, act), the agent's command in place of
        # the controller's: actuators and the record now, the next period's physics and
        # observation below.
        sim.controller.command = command
        command = sim.controller.step(self._obs, self.dt)
        row = sim.act(command)
        self._rows.append(row)
        parts, ended = self._judge_step(row)
        terminated = ended != ""
        truncated = not terminated and len(self._rows) >= self.total_steps
        try:
            self._sense_next()
        except SimulationDiverged as err:
            self._error, ended, terminated, truncated = str(err), ended or "diverged", True, False
        info = {"time_s": sim.time_s, **parts}
        if terminated or truncated:
            verdict = self.verdict()
            parts["reward_success"] = self.weights.success if verdict.success else 0.0
            info.update(
                reward_success=parts["reward_success"],
                outcome=verdict.outcome,
                reason=verdict.reason,
                verdict=verdict.as_dict(),
                ended=ended or "duration",
            )
            if self._error is not None:
                info["error"] = self._error
            self._ended = f"{'terminated' if terminated else 'truncated'}: {info['ended']}"
        reward = float(sum(parts.values()))
        return self._observation(), reward, terminated, truncated, info

    def render(self):
        if self.render_mode is None:
            gym.logger.warn("render() was called without a render_mode; make the environment with render_mode='rgb_array'")
            return None
        if self.sim is None:
            raise RuntimeError("call reset() before render()")
        if self._rendered_model is not self.sim.model:  # a new episode's model
            import mujoco

            from piezotip.analysis.video import open_renderer

            self._close_renderer()
            self._renderer = open_renderer(self.sim.model, self.width, self.height)
            self._renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = False
            self._renderer.scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = False
            self._option = mujoco.MjvOption()
            self._option.geomgroup[:] = 1  # pads and objects are collision geoms
            self._rendered_model = self.sim.model
        from piezotip.analysis.video import CAMERA

        self._renderer.update_scene(self.sim.data, camera=CAMERA, scene_option=self._option)
        return self._renderer.render().copy()

    def close(self) -> None:
        self._close_renderer()
        super().close()

    # -- the episode's record and judgement ------------------------------------------------

    def last_row(self) -> dict[str, float]:
        """The episode's last recorded step (column name -> value), without copying the record."""
        if self.sim is None or not self._rows:
            return {}
        return dict(zip(self.sim.columns, self._rows[-1], strict=True))

    def recording(self) -> dict[str, np.ndarray]:
        """The episode so far as the command line records it (column name -> array, a row per step)."""
        if self.sim is None or not self._rows:
            return {}
        table = np.asarray(self._rows, dtype=float)
        return {c: table[:, i] for i, c in enumerate(self.sim.columns)}

    def verdict(self):
        """The referee's :class:`~piezotip.analysis.referee.Verdict` of the episode so far (as finished)."""
        from piezotip.analysis.run_report import object_friction, object_needed_grip_n

        c = self.config.controller
        # the simulated object's friction, as run's summary has it: the need on the contacts' tilts
        needed, friction = (None, None) if self.sim is None else (object_needed_grip_n(self.sim.model), object_friction(self.sim.model))
        record = self.recording()
        crush = self.config.object.crush_force_n
        return judge(record, c.lift_height_m, c.hold_s, crush, finished=True, error=self._error, needed_grip=needed, friction=friction)

    # -- internals ------------------------------------------------------------------------

    def _sense_next(self) -> None:
        """CoSimulation.advance up to the controller: physics, pressures, sensor, readout, observation."""
        self._obs = self.sim.sense()

    def _observation(self) -> dict[str, np.ndarray]:
        obs, n = self._obs, len(self.pads)
        mode, status = np.empty(n, np.int64), np.empty(n, np.int64)
        amplitude, pressure, uncertainty = np.empty(n), np.empty(n), np.empty(n)
        iq = np.empty((n, 2))
        for i, pad in enumerate(self.pads):
            sig = obs.pads[pad]
            r, e = sig.reading, sig.estimate
            mode[i] = self._mode_index[r.mode]
            amplitude[i] = r.v1
            iq[i, 0], iq[i, 1] = r.iq.real, r.iq.imag
            status[i] = self._status_index[e.status]
            has_value = e.status in ("ok", "below_detection")  # NaN otherwise: no estimate
            pressure[i] = e.pressure_pa if has_value else 0.0
            uncertainty[i] = e.uncertainty_pa if has_value else 0.0
        return {
            "time_s": np.array([obs.time_s]),
            "mode": mode,
            "amplitude": amplitude,
            "iq": iq,
            "pressure_pa": pressure,
            "uncertainty_pa": uncertainty,
            "status": status,
            "settled": (status != self._status_index["settling"]).astype(np.int8),
            "opening_m": np.array([obs.opening_m]),
            "lift_m": np.array([obs.lift_pos_m]),
            "lift_velocity_m_s": np.array([obs.lift_vel_m_s]),
            "grip_force_n": np.array([obs.grip_force_n]),
            "lift_force_n": np.array([obs.lift_force_n]),
            "opening_setpoint_m": np.array([self._opening_sp]),
            "lift_setpoint_m": np.array([self._lift_sp]),
        }

    def _command(self, action) -> Command:
        """The loop's Command from ``action``: continuous parts clipped, anything malformed refused."""
        if not isinstance(action, Mapping) or set(action) != set(ACTION_KEYS):
            got = shown(sorted(map(str, action))) if isinstance(action, Mapping) else type(action).__name__
            raise ValueError(f"action must be a dict with keys {', '.join(ACTION_KEYS)}; got {got}")
        space = self.action_space
        values = {}
        for key in ACTION_KEYS[:3]:
            a = real_numbers(action[key])
            if a is None or a.size != 1 or not math.isfinite(a.reshape(-1)[0]):
                raise ValueError(f"action[{key!r}] must be one finite real number, got {shown(action[key])}")
            box = space[key]
            values[key] = min(max(float(a.reshape(-1)[0]), float(box.low[0])), float(box.high[0]))
        modes = real_numbers(action["mode"])
        n_modes = len(self.modes)
        whole = modes is not None and all(k.is_integer() and 0 <= k < n_modes for k in modes.reshape(-1).tolist())
        if not whole or modes.size != len(self.pads):
            raise ValueError(
                f"action['mode'] must be {len(self.pads)} mode indices in 0..{n_modes - 1} (modes {list(self.modes)}), "
                f"got {shown(action['mode'])}"
            )
        modes = modes.reshape(-1)
        lo, hi = self.lift_range_m
        self._lift_sp = min(max(self._lift_sp + values["lift_velocity_m_s"] * self.dt, lo), hi)
        lo, hi = self.opening_range_m
        self._opening_sp = min(max(self._opening_sp + values["opening_velocity_m_s"] * self.dt, lo), hi)
        drive = {pad: self.modes[int(k)] for pad, k in zip(self.pads, modes.tolist(), strict=True)}
        return make_command(self._lift_sp, self._opening_sp, values["grip_force_n"], drive, Phase.APPROACH, "agent")

    def _episode_start(self) -> None:
        """Column indices and the per-step referee's state for a new episode."""
        index = {c: i for i, c in enumerate(self.sim.columns)}
        self._col = {
            name: index[name]
            for name in (
                "lift_m",
                "object_height_m",
                "object_x_m",
                "object_y_m",
                "object_vz_m_s",
                "table_force_n",
                "left_finger_force_n",
                "right_finger_force_n",
            )
        }
        # The crush is judged on the fingers' peak over the period's physics steps where the
        # loop records it (an object with a crush limit), as the referee does.
        peaks = [index[c] for c in ("left_finger_peak_force_n", "right_finger_peak_force_n") if c in index]
        self._peak_cols = peaks or [self._col["left_finger_force_n"], self._col["right_finger_force_n"]]
        obj = self.config.object
        w = self.weights
        self._need_n = w.grip_margin * obj.mass_kg * self.gravity_m_s2 / (2.0 * obj.friction)
        self._grip_scale_n = obj.crush_force_n if obj.crush_force_n is not None else self.finger_force_limit_n
        self._z0 = None
        self._carry_ref = None
        self._slipped = False
        self._held_s = 0.0
        self._free_steps = 0
        self._first_off = None
        self._on_table_before = True
        self._vz = [0.0, 0.0, 0.0]

    def _judge_step(self, row: list[float]) -> tuple[dict[str, float], str]:
        """This step's reward parts and what ended the episode ("" if nothing), from the row's
        ground truth, by the referee's criteria (analysis.referee.judge, one step at a time)."""
        c, col, w, dt = Criteria(), self._col, self.weights, self.dt
        cfg = self.config
        i = len(self._rows) - 1
        z = row[col["object_height_m"]]
        if self._z0 is None:
            self._z0 = z
        rise = z - self._z0
        left, right = row[col["left_finger_force_n"]], row[col["right_finger_force_n"]]
        gripped = left > c.contact_force_n and right > c.contact_force_n
        on_table = row[col["table_force_n"]] > c.contact_force_n
        off_table = rise > c.placed_tolerance_m
        carried = gripped and off_table
        x, y = row[col["object_x_m"]], row[col["object_y_m"]]
        if carried:
            rel = (x, y, z - row[col["lift_m"]])
            if self._carry_ref is None:
                self._carry_ref = rel
            if math.dist(rel, self._carry_ref) > c.slip_tolerance_m:
                self._slipped = True
        lift_h = cfg.controller.lift_height_m
        parts = dict.fromkeys(("reward_lift", "reward_hold", "reward_grip", "reward_crush", "reward_drop", "reward_success"), 0.0)
        if carried and not self._slipped:
            parts["reward_lift"] = w.lift_per_s * dt * min(max(rise, 0.0) / lift_h, 1.0)
            if rise >= lift_h - c.slip_tolerance_m and self._held_s < cfg.controller.hold_s:
                parts["reward_hold"] = w.hold_per_s * dt
                self._held_s += dt
        grip = max(left, right)
        parts["reward_grip"] = -w.grip_per_s * dt * max(grip - self._need_n, 0.0) / self._grip_scale_n
        # Drops, as the referee sees them: free above the table for two samples, or a landing
        # (the table's touch after the object first left it) faster than the landing limit.
        free = off_table and not gripped and not on_table
        self._free_steps = self._free_steps + 1 if free else 0
        self._vz = [*self._vz[1:], row[col["object_vz_m_s"]]]
        window = self._vz[-min(i + 1, 3) :]
        touched_down = self._first_off is not None and i > self._first_off and on_table and not self._on_table_before
        landed_hard = touched_down and -min(window) > c.landing_speed_m_s
        if off_table and self._first_off is None:
            self._first_off = i
        self._on_table_before = on_table
        crush = cfg.object.crush_force_n
        ended = ""
        if crush is not None and max(row[k] for k in self._peak_cols) > crush:
            ended, parts["reward_crush"] = "crushed", -w.crush
        elif self._free_steps >= 2 or landed_hard:
            ended, parts["reward_drop"] = "dropped", -w.drop
        elif math.hypot(x, y) > LOST_RADIUS_M or z < 0.0:
            ended, parts["reward_drop"] = "lost", -w.drop
        return parts, ended

    def _close_renderer(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer, self._rendered_model = None, None


class MultimodePolicy:
    """The multimode controller (:mod:`piezotip.cosim.control.multimode`) as a policy for GraspEnv.

    ``policy(obs) -> action``.  It reads only the observation (the fingertips' readouts and the
    robot's proprioception, as the controller does in the loop) and the robot's own design (its
    servo gains, force limits and pads, from the scenario's model); the home set-points come
    from the first observation of each episode, which it recognises by the clock starting again.

    Parameters
    ----------
    scenario, overrides, preset : the environment's (``MultimodePolicy.for_env(env)`` takes them
        from an environment).
    """

    def __init__(self, scenario: str = "grasp", overrides=None, preset: str | None = None) -> None:
        self.config = scenarios.get(scenario, overrides, preset)
        self._init_from_config()

    @classmethod
    def for_env(cls, env) -> MultimodePolicy:
        """The policy for ``env`` (a GraspEnv, or a wrapper of one)."""
        policy = cls.__new__(cls)
        policy._env = env.unwrapped
        policy.config = policy._env.base_config
        policy._init_from_config()
        return policy

    def _init_from_config(self) -> None:
        cfg = self.config
        sim = CoSimulation(_with_blind_controller(cfg))  # for the robot's design and the fingertip model, nothing run
        self.robot: RobotLimits = sim.robot
        self.fingertip = sim.fingertip
        self.pads = tuple(f"{p}_pad" for p in cfg.sensor.pads)
        self.modes = tuple(cfg.sensor.modes)
        self.dt = cfg.physics.control_period_s
        self.controller = None
        self._last_t = math.inf

    def reset(self) -> None:
        """Forget the episode: the next observation starts a new controller."""
        self.controller, self._last_t = None, math.inf

    def __call__(self, obs: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        t = float(obs["time_s"][0])
        if self.controller is None or t <= self._last_t - 0.5 * self.dt:
            # An environment's episode has its own object (randomized, or given at reset): the
            # camera the controller's touch plans from (perception.*) sees that one, not the
            # scenario's (a 40 mm camera reading closed on a 25 mm object at the touch's 1.4 mm/s
            # until the episode ran out).
            episode = getattr(getattr(self, "_env", None), "config", None)
            if episode is not None:
                self.config = episode
            home = {"home_lift_m": float(obs["lift_setpoint_m"][0]), "home_opening_m": float(obs["opening_setpoint_m"][0])}
            robot = dataclasses.replace(self.robot, **home)
            self.controller = make_controller(self.config, robot, self.fingertip)
        self._last_t = t
        command = self.controller.step(self._observation(obs), self.dt)
        return {
            "grip_force_n": np.array([command.grip_force_limit_n]),
            "opening_velocity_m_s": np.array([_rate(command.opening_m, float(obs["opening_setpoint_m"][0]), self.dt)]),
            "lift_velocity_m_s": np.array([_rate(command.lift_m, float(obs["lift_setpoint_m"][0]), self.dt)]),
            "mode": np.array([self.modes.index(command.modes[pad]) for pad in self.pads], dtype=np.int64),
        }

    def _observation(self, obs: Mapping[str, np.ndarray]) -> Observation:
        """The controller's Observation from the environment's (exactly: float64 throughout)."""
        pads = {}
        nan = math.nan
        for i, pad in enumerate(self.pads):
            status = STATUS_CODES[int(obs["status"][i])]
            if status in ("ok", "below_detection"):
                estimate = Estimate(float(obs["pressure_pa"][i]), float(obs["uncertainty_pa"][i]), status)
            else:
                estimate = Estimate(nan, nan, status)
            iq = complex(float(obs["iq"][i, 0]), float(obs["iq"][i, 1]))
            mode = self.modes[int(obs["mode"][i])]
            # Only what a lock-in gives; the simulator's own fields (noise-free output, load) are unknown.
            reading = Reading(mode, float(obs["amplitude"][i]), nan, nan, nan, nan, bool(obs["settled"][i]), nan, nan, iq)
            pads[pad] = PadSignal(reading, estimate)
        return Observation(
            time_s=float(obs["time_s"][0]),
            pads=pads,
            lift_pos_m=float(obs["lift_m"][0]),
            opening_m=float(obs["opening_m"][0]),
            lift_force_n=float(obs["lift_force_n"][0]),
            grip_force_n=float(obs["grip_force_n"][0]),
            lift_vel_m_s=float(obs["lift_velocity_m_s"][0]),
        )


def real_numbers(value) -> np.ndarray | None:
    """``value`` as a float64 array if it is real numbers (Python's or NumPy's ints and floats, any
    shape), else None: a string, a bool, a complex number, a dict, None or a ragged nesting is not
    an action, though NumPy would convert some of them (``"0.5"`` to 0.5, ``1+2j`` to 1 with a
    warning, ``True`` to 1)."""
    if isinstance(value, (str, bytes, Mapping)):
        return None
    try:
        a = np.asarray(value)
    except (ValueError, TypeError):  # ragged, or refused by NumPy
        return None
    if a.dtype.kind == "O":  # Python objects (a Fraction, None, a list in a list): real numbers only
        items = a.reshape(-1).tolist()
        if not all(isinstance(x, numbers.Real) and not isinstance(x, (bool, np.bool_)) for x in items):
            return None
        a = np.array([float(x) for x in items]).reshape(a.shape)
    if a.dtype.kind not in "iuf":  # b (bool), c (complex), U and S (text), V, M, m
        return None
    return a.astype(float, copy=False)


_repr = reprlib.Repr()
_repr.maxstring, _repr.maxother, _repr.maxlist, _repr.maxdict = 80, 120, 8, 6


def shown(value) -> str:
    """``value``'s repr for an error message, cut to a few hundred characters."""
    if isinstance(value, np.ndarray):
        return _repr.repr(value.tolist()) if value.size <= 64 else f"an array of shape {value.shape} and dtype {value.dtype}"
    return _repr.repr(value)


def _with_blind_controller(config: ScenarioConfig) -> ScenarioConfig:
    """``config`` with the first registered controller that reads no fingertip (the built-in
    scripted one), the cheapest to build, where only the simulation is wanted (its controller is
    replaced or unused); its other settings as they were."""
    kind = next(name for name in controllers.names() if not controllers.get(name).senses)
    return dataclasses.replace(config, controller=controllers.configure(kind, like=config.controller))


def _rate(target: float, setpoint: float, dt: float) -> float:
    """The set-point rate that takes ``setpoint`` to ``target`` in one step as the environment
    integrates it (``setpoint + rate * dt``), to the last bit where a float64 rate can."""
    rate = (target - setpoint) / dt
    best, best_err = rate, abs(setpoint + rate * dt - target)
    for direction in (math.inf, -math.inf):
        r = rate
        for _ in range(4):
            if best_err == 0.0:
                return best
            r = math.nextafter(r, direction)
            err = abs(setpoint + r * dt - target)
            if err < best_err:
                best, best_err = r, err
    return best
