"""The fingertip grasp shaped for learning (``piezotip/GraspLearn-v0``), issue 46.

:class:`GraspLearnEnv` holds a :class:`~piezotip.gym_env.GraspEnv` (the physics, the readout and
the referee's ends are its) and changes what a learner meets: a decision every few control
periods, actions in [-1, 1] on the scales a grasp needs (the grip's rate in decades of force
across the gripper's rating, the fingers open or closed, a lift target reached at a speed that
cannot slam the object down), observations normalized to [-1, 1] (forces on one log scale), a
dense reward whose best return is a gentle placed grasp, and ``randomize=True``, a new object at
each reset (shape, mass, size, friction, crush force) drawn from the seed across the gripper's
rating.  The class docstring has the tables; docs/gym.md the reasons.

:class:`GraspAssistEnv` (``piezotip/GraspAssist-v0``) is the same task with the house controller
running the grasp and the policy correcting its grip (residual policy learning): action 0 is the
house controller, bit for bit.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import asdict, dataclass, fields
from typing import ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from piezotip.analysis.referee import Criteria
from piezotip.analysis.run_report import object_needed_grip_n
from piezotip.cosim.control.phases import Phase
from piezotip.cosim.loop import CoSimulation
from piezotip.cosim.rows import READOUT_STATUSES as STATUS_CODES  # the readout's own (what an agent sees)
from piezotip.gym_env import GraspEnv, MultimodePolicy, _with_blind_controller, real_numbers, shown
from piezotip.gym_flat import PlacedReleasedGate
from piezotip.scenarios.config import OBJECT_SHAPES, RATED_MASS_KG, ObjectConfig
from piezotip.scenarios.shapes import shape_names

#: The potentials of progress, in the order the reward lists them (:class:`LearnReward`).
PROGRESS = ("touch", "carry", "lift", "hold", "place")
#: The reward's parts, each in ``info`` under ``reward_<part>``; ``reward`` is their sum.
REWARD_PARTS = (*(f"reward_{p}" for p in PROGRESS), "reward_grip", "reward_crush", "reward_drop", "reward_slip", "reward_success")


def force_to_unit(force_n: float, low_n: float, high_n: float) -> float:
    """A force on the log scale [-1, 1]: ``low_n`` (and anything less, a pull included) is -1,
    ``high_n`` +1, each decade the same step: 2 ln(F / low) / ln(high / low) - 1, clipped."""
    if not force_n > low_n:
        return -1.0
    return min(2.0 * math.log(force_n / low_n) / math.log(high_n / low_n) - 1.0, 1.0)


def unit_to_force(x: float, low_n: float, high_n: float) -> float:
    """The force, N, at ``x`` in [-1, 1] on :func:`force_to_unit`'s scale: low (high / low)^((x + 1) / 2)."""
    return low_n * (high_n / low_n) ** ((x + 1.0) / 2.0)


@dataclass(frozen=True)
class LearnSettings:
    """The task's pace and the action's scales.

    Attributes
    ----------
    decision_period_s : time between the agent's decisions, s; a whole number of control
        periods: 40 ms (eight 5 ms periods): an episode is 8x fewer decisions to credit than at
        the control rate.  The touch's gentleness is the grip (the fingers' force limit), not
        the decision's latency.
    time_limit_s : the episode's length, s (truncated there): 6 s.  A grasp at these speeds
        takes 3-5 s (close 0.3-1 s, lift 1 s, hold the scenario's 1 s, lower 1 s, release).
    lift_speed_m_s : the lift set-point's fastest rate, m/s: 0.05, half the referee's landing
        limit (0.1 m/s), so that no lowering the agent commands lands the object hard.
    opening_speed_m_s : the opening set-point's fastest rate, m/s: 0.1 (the whole 90 mm stroke
        in 0.9 s; the fingers move no faster than their force limit over their joints' damping).
    grip_decades : the grip's span below the fingers' force limit, decades: 5 (1 mN to 100 N on
        the house gripper), so that the grip a 1 g object needs (4 mN at mu 1.2) is reachable.
        Each episode starts at its log-centre (0.32 N).
    grip_rate_decades_per_s : the grip action's full rate, decades per second: 5 (x1.58 per
        40 ms decision at +-1; from the start to the 40 N a 10 kg object needs in 0.4 s, to the
        4 mN of a 1 g one in 0.4 s); the same factor per step at every grip.
    lift_span : the lift's range above its home as a multiple of the scenario's lift height: 1.2
        (60 mm for 50 mm): a saturated action lifts high enough and no higher (at 2, a policy
        lifted to 100 mm and ran out of time coming back down).
    """

    decision_period_s: float = 0.04
    time_limit_s: float = 6.0
    lift_speed_m_s: float = 0.05
    opening_speed_m_s: float = 0.1
    grip_decades: float = 5.0
    grip_rate_decades_per_s: float = 5.0
    lift_span: float = 1.2

    def validate(self, control_period_s: float) -> LearnSettings:
        """Check every value is positive and finite, and the decision a whole number of control periods."""
        for f in fields(self):
            value = getattr(self, f.name)
            if not (isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value) and value > 0):
                raise ValueError(f"LearnSettings.{f.name} must be a positive finite number, got {value!r}")
        periods = self.decision_period_s / control_period_s
        if abs(periods - round(periods)) > 1e-9 or round(periods) < 1:
            raise ValueError(
                f"LearnSettings.decision_period_s must be a whole number of control periods ({control_period_s:g} s), "
                f"got {self.decision_period_s!r}"
            )
        if self.time_limit_s < self.decision_period_s:
            raise ValueError(f"LearnSettings.time_limit_s must be at least one decision, got {self.time_limit_s!r}")
        return self


@dataclass(frozen=True)
class LearnReward:
    """The reward's weights (the class docstring of :class:`GraspLearnEnv`, "Rewards").

    Progress is paid as the growth of its best so far (five parts, each 0 to 1, times its
    weight); the grip's cost per second carried; the ends once.

    Attributes
    ----------
    touch : weight of the touch progress: both fingers on the object.
    carry : weight of the carry potential: the share of the object's weight the fingers carry
        (its weight less the table's push, over its weight) while both touch it.  It grows with
        the grip as the lift pulls, before the object rises: the signal that a firmer grip lifts.
    lift : weight of the lift potential: the share of the lift height risen while carried
        without slip (kept once held).
    hold : weight of the hold potential: the share of the scenario's hold time carried at the
        lift height.
    place : weight of the place potential: after the hold, the share of the way back down while
        carried; 1 once the object rests at its start in the fingers.
    success : paid when the referee judges the episode a success (lifted, held, placed, released).
    grip_per_s : cost per second of carrying (both fingers on the object, off the table), times
        ln(grip / (grip_margin x need)) where that is positive, at most ``grip_cap``, 1/s.  Not
        charged on the table: there a grip holds nothing, and charging it (a 0.3 N touch of a 1 g
        object costs the cap) taught PPO never to touch.
    grip_margin : the grip that costs nothing, over the least grip that holds (need = m g / (2 mu),
        the referee's): 1.25, the 10-40 % people keep (Johansson and Westling 1984).
    grip_cap : the largest log-excess charged: ln 10 (a grip 12.5x the need).
    crush, drop, slip : paid once (negative) when the episode ends so.  Small next to the
        success they forfeit: large ones teach an agent never to lift (issue 46).  The crush's
        is larger: the fingertip's point is gentleness.
    """

    touch: float = 0.25
    carry: float = 1.0
    lift: float = 2.0
    hold: float = 2.0
    place: float = 1.0
    success: float = 10.0
    grip_per_s: float = 0.5
    grip_margin: float = 1.25
    grip_cap: float = math.log(10.0)
    crush: float = 0.5
    drop: float = 0.1
    slip: float = 0.1

    def validate(self, time_limit_s: float) -> LearnReward:
        """Check the weights are non-negative (the margin at least 1) and that the worst-paid success
        (the grip's cost at its cap through the whole episode) still beats doing nothing (0)."""
        for f in fields(self):
            value = getattr(self, f.name)
            if not (isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value) and value >= 0):
                raise ValueError(f"LearnReward.{f.name} must be a finite number >= 0, got {value!r}")
        if self.grip_margin < 1.0:
            raise ValueError(f"LearnReward.grip_margin must be at least 1 (the least grip that holds), got {self.grip_margin!r}")
        if not self.least_success_return(time_limit_s) > 0.0:
            raise ValueError(
                f"LearnReward: a success must be worth more than doing nothing, but its least return is "
                f"{self.least_success_return(time_limit_s):.3g} over {time_limit_s:g} s (raise success or lower grip_per_s, grip_cap)"
            )
        return self

    @property
    def progress_total(self) -> float:
        """The potential of a placed grasp: every progress weight."""
        return self.touch + self.carry + self.lift + self.hold + self.place

    def least_success_return(self, time_limit_s: float) -> float:
        """The least a successful episode can return: progress and success, less the grip's capped cost
        over the whole episode."""
        return self.progress_total + self.success - self.grip_per_s * self.grip_cap * time_limit_s


@dataclass(frozen=True)
class ObjectDraw:
    """Where ``randomize=True`` draws each episode's object from, the seed's generator in order.

    Attributes
    ----------
    shapes : drawn uniformly: by default every shape the scene builds (scenarios.config.OBJECT_SHAPES,
        the registry's, scenarios/shapes.py); any registered shapes.
    friction : (low, high), uniform: 0.3 (glass on the pads' silicone) to 1.2 (rubber), the
        object catalogue's span.
    mass_kg : (low, high), kg, log-uniform: the gripper's rated 1 g to 10 kg, the top cut where
        the object could not be held ``crush_over_need`` below the fingers' force limit
        (m <= 2 mu F_limit / (g crush_over_need): 2.4 kg at mu 0.3, 9.8 kg at mu 1.2).
    size_m : (low, high), m, uniform: 20 to 80 mm, the catalogue's span (the scene takes 12-85 mm).
    crush_over_need : the crush force is at least this times the least grip that holds
        (m g / (2 mu)): 2.5, room for the grip margin of 2 the task is judged by.
    crush_floor_n : ... and at least this, N: 1, three times the grip a learning policy starts
        with and touches at (0.32 N; the house controller touches at 0.12-0.15 N,
        reports/touch_trade.py).  At 0.3 N a quarter of the light objects broke at the first
        touch and PPO learned to grip too little to lift (issue 46).
        Drawn log-uniformly from there to the fingers' force limit (beyond it no grip crushes).
    """

    shapes: tuple[str, ...] = OBJECT_SHAPES
    friction: tuple[float, float] = (0.3, 1.2)
    mass_kg: tuple[float, float] = RATED_MASS_KG
    size_m: tuple[float, float] = (0.02, 0.08)
    crush_over_need: float = 2.5
    crush_floor_n: float = 1.0

    def sample(self, rng: np.random.Generator, finger_force_limit_n: float, gravity_m_s2: float) -> ObjectConfig:
        """One object: shape, friction, mass, size, then the crush force (it depends on the need)."""
        shape = str(self.shapes[int(rng.integers(len(self.shapes)))])
        friction = float(rng.uniform(*self.friction))
        heaviest = 2.0 * friction * finger_force_limit_n / (gravity_m_s2 * self.crush_over_need)
        mass = _log_uniform(rng, self.mass_kg[0], min(self.mass_kg[1], heaviest))
        size = float(rng.uniform(*self.size_m))
        need = mass * gravity_m_s2 / (2.0 * friction)
        crush = _log_uniform(rng, max(self.crush_over_need * need, self.crush_floor_n), finger_force_limit_n)
        return ObjectConfig(shape=shape, mass_kg=mass, size_m=size, friction=friction, crush_force_n=crush)

    def validate(self, finger_force_limit_n: float, gravity_m_s2: float) -> ObjectDraw:
        """Check the shapes are known and every range's ends make objects the gripper can hold."""
        if not self.shapes or any(s not in shape_names() for s in self.shapes):
            raise ValueError(f"ObjectDraw.shapes must be some of {shape_names()}, got {self.shapes!r}")
        for name in ("friction", "mass_kg", "size_m"):
            pair = getattr(self, name)
            if len(pair) != 2 or not (0 < pair[0] <= pair[1]):
                raise ValueError(f"ObjectDraw.{name} must be (low, high) with 0 < low <= high, got {pair!r}")
        if not (self.crush_over_need >= 1 and 0 < self.crush_floor_n < finger_force_limit_n):
            raise ValueError(
                f"ObjectDraw needs crush_over_need >= 1 and 0 < crush_floor_n < the fingers' {finger_force_limit_n:g} N, "
                f"got {self.crush_over_need!r}, {self.crush_floor_n!r}"
            )
        heaviest = 2.0 * self.friction[0] * finger_force_limit_n / (gravity_m_s2 * self.crush_over_need)
        if heaviest < self.mass_kg[0]:
            raise ValueError(f"ObjectDraw: at friction {self.friction[0]:g} no mass from {self.mass_kg[0]:g} kg can be held")
        for end in (0, 1):
            ObjectConfig(mass_kg=self.mass_kg[end], size_m=self.size_m[end], friction=self.friction[end]).validate()
        return self


def _log_uniform(rng: np.random.Generator, low: float, high: float) -> float:
    return float(math.exp(rng.uniform(math.log(low), math.log(high))))


class GraspProgress:
    """The episode's progress from the simulator's truth, one control period at a time, by the
    referee's criteria (analysis.referee.judge): each stage's best progress so far (the reward's) and the slip.

    Parameters
    ----------
    lift_height_m, hold_s : what the scenario asks, m and s.
    control_period_s : one recorded row's time, s.
    weight_n : the object's weight, N.
    home_lift_m : the lift's home position, m.
    """

    def __init__(
        self,
        lift_height_m: float,
        hold_s: float,
        control_period_s: float,
        weight_n: float,
        home_lift_m: float,
        criteria: Criteria | None = None,
    ) -> None:
        self.lift_height_m, self.hold_s, self.dt = lift_height_m, hold_s, control_period_s
        self.weight_n, self.home_lift_m = weight_n, home_lift_m
        self.criteria = Criteria() if criteria is None else criteria
        self._z0: float | None = None
        self._carry_ref: tuple[float, float, float] | None = None
        self.slipped = False
        self.held_s = 0.0
        self.placed = False
        self.potentials = dict.fromkeys(PROGRESS, 0.0)
        self._carry_periods, self._table_sum_n = 0, 0.0
        self.carried = False  # both fingers on the object, off the table (the referee's "carried")

    def end_decision(self) -> None:
        """Close a decision's periods: if both fingers held the object through all of them with the
        lift above home, the carry is the share of the weight the table no longer bore on average."""
        if self._carry_periods > 0:
            share = 1.0 - self._table_sum_n / (self._carry_periods * self.weight_n)
            self.potentials["carry"] = max(self.potentials["carry"], min(max(share, 0.0), 1.0))
        self._carry_periods, self._table_sum_n = 0, 0.0

    @property
    def hold_done(self) -> bool:
        """Held at the height as long as the referee asks (its test: within one period of ``hold_s``)."""
        return self.held_s >= self.hold_s - self.dt - 1e-9

    def update(self, row) -> bool:
        """Take one recorded row (column name -> value); True if the object slipped in it (first time)."""
        c = self.criteria
        z = row["object_height_m"]
        if self._z0 is None:
            self._z0 = z
        rise = z - self._z0
        gripped = row["left_finger_force_n"] > c.contact_force_n and row["right_finger_force_n"] > c.contact_force_n
        carried = self.carried = gripped and rise > c.placed_tolerance_m
        slipped_now = False
        if carried:
            rel = (row["object_x_m"], row["object_y_m"], z - row["lift_m"])
            if self._carry_ref is None:
                self._carry_ref = rel
            if not self.slipped and math.dist(rel, self._carry_ref) > c.slip_tolerance_m:
                self.slipped = slipped_now = True
            if rise >= self.lift_height_m - c.slip_tolerance_m:  # the referee's held_s
                self.held_s += self.dt
        share = min(max(rise / self.lift_height_m, 0.0), 1.0)
        done = self.hold_done
        on_table = row["table_force_n"] > c.contact_force_n
        if done and gripped and abs(rise) <= c.placed_tolerance_m and on_table:
            self.placed = True
        # The carry is judged over a whole decision (end_decision): one period's table force
        # can drop to nothing as the object rings on a touch.  Only while the lift is above its
        # home by more than the placing tolerance: squeezed at home, the pads' gel can take the
        # object's weight off the table without lifting.
        pulling = row["lift_m"] - self.home_lift_m > c.placed_tolerance_m
        self._carry_periods = self._carry_periods + 1 if gripped and pulling else -(10**9)
        self._table_sum_n += row["table_force_n"]
        now = {
            "touch": 1.0 if gripped else 0.0,
            "lift": share if carried and not self.slipped else 0.0,
            "hold": 1.0 if done else self.held_s / self.hold_s,
            "place": 1.0 if self.placed else (1.0 - share if done and gripped else 0.0),
        }
        # The best so far: progress once made is never taken back (a slip or a drop ends the
        # episode with its penalty instead), so that an attempt that gets half way still pays
        # more than one never made (issue 46: taking it back taught PPO never to lift).
        for key, value in now.items():
            self.potentials[key] = max(self.potentials[key], value)
        return slipped_now


#: The opening action's threshold: at or below it the fingers close (their target is 0: they
#: squeeze what they meet with the grip), above it they open to home.  Not a target in
#: proportion: releasing a 40 mm object then took a mean action past 0.45, which a trained policy
#: reached only through its exploration noise (deterministic, it never let go); and 0.3 is 3 of
#: the initial noise's standard deviations (0.1) above 0, so an untrained policy keeps its grasp.
OPEN_ABOVE = 0.3

#: How far inside the fingers their set-point lies, and how little they moved in a decision, when
#: they have stopped on something, m: 1 mm (a free closing lags its set-point by more, and moves
#: 1.2 mm in 40 ms at the slowest grip that closes usefully, 0.3 N).
BLOCKED_M = 0.001

#: The mode action's first edge: below it the lowest mode (the most sensitive, the house
#: controller's at the touch), above it the other modes in equal bins.  An untrained policy's
#: actions scatter around 0; in equal bins 0 is the edge between modes 2 and 3, and a fingertip
#: switched every other decision is always settling and never reads (issue 46).
LOWEST_MODE_BELOW = 0.25


def mode_index(action: float, n_modes: int) -> int:
    """The mode index for the mode action: 0 below :data:`LOWEST_MODE_BELOW`, the others in equal
    bins of [LOWEST_MODE_BELOW, 1]."""
    if n_modes == 1 or action < LOWEST_MODE_BELOW:
        return 0
    share = (action - LOWEST_MODE_BELOW) / (1.0 - LOWEST_MODE_BELOW)
    return min(1 + int(share * (n_modes - 1)), n_modes - 1)


def grip_cost_per_s(grip_n: float, need_n: float, weights: LearnReward) -> float:
    """The grip's cost rate, 1/s: ``grip_per_s`` ln(grip / (margin need)) where positive, capped."""
    if not (grip_n > 0 and need_n > 0):
        return 0.0
    excess = math.log(grip_n / (weights.grip_margin * need_n))
    return weights.grip_per_s * min(max(excess, 0.0), weights.grip_cap)


class GraspLearnEnv(gym.Env):
    """A parallel gripper with multimode piezoelectric fingertips grasps, lifts, holds and puts back
    an object: the task of ``piezotip/Grasp-v0``, shaped for learning.

    ## Description

    The physics, readout and referee of :class:`~piezotip.gym_env.GraspEnv` (``env.unwrapped.grasp_env``).
    Each step is one decision held for ``LearnSettings.decision_period_s`` (40 ms, eight control
    periods).  The agent sees only what the robot senses; the object's truth sets the reward.
    Success is the referee's: lifted to the scenario's height (50 mm), held there for its hold
    time (1 s) without slipping more than 5 mm in the fingers, put back where it started without
    landing faster than 0.1 m/s, released, never squeezed past its crush force.

    ## Action Space

    ``Box(-1, 1, (4,), float32)``.  An action outside the box, not real numbers, non-finite or of
    another shape raises ``ValueError`` (Stable-Baselines3 clips its samples to the box first).

    | Index | Action | -1 | +1 | Unit |
    |---|---|---|---|---|
    | 0 | grip rate: the fingers' force limit (per finger, from 0.32 N) times 10^(a rate dt) | /1.58 | x1.58 | - |
    | 1 | fingers: closed (target 0) up to 0.3, open (home, 90 mm) above; at ``opening_speed_m_s`` | closed | open | - |
    | 2 | lift target, max(a, 0) x ``lift_span`` x lift height over home, at ``lift_speed_m_s``; up only when blocked | home | +60 mm | m |
    | 3 | mode of both fingertips: below 0.25 the lowest, then equal bins (:func:`mode_index`) | the lowest mode | the highest | - |

    The fingers' drive is a force-limited position servo: a closed target squeezes what the
    fingers meet with the grip, and they move no faster than the grip over their joints'
    damping (0.3 N closes at 30 mm/s, 3 mN at 0.3 mm/s), so a light grip closes slowly.  The
    grip starts each episode at 0.32 N (the log-centre of 1 mN .. 100 N) and moves by at most
    ``grip_rate_decades_per_s`` (x1.58 per decision at +-1).  The lift rises only while the
    fingers are blocked: their set-point more than 1 mm inside them and they moved less than
    1 mm over the last decision (:data:`BLOCKED_M`); it always comes down.

    ## Observation Space

    ``Box(-1, 1, (31,), float32)``, ``env.unwrapped.observation_names`` in order.  Forces are on
    one log scale (:func:`force_to_unit`: F_limit 10^-decades .. F_limit to -1 .. 1),
    pressures on the fingertip's (ln(P / P_min) / ln(P_max / P_min), P_min and P_max its
    ``dynamic_range()``).  Per pad (``{pad}``: ``left_pad``, ``right_pad``), then the robot:

    | Name | Observation | Scaled as |
    |---|---|---|
    | ``{pad}.pressure`` | the readout's pressure estimate (0 with none) | log range, 0 .. 1 |
    | ``{pad}.sigma`` | its standard deviation (1 with no estimate) | log range, 0 .. 1 |
    | ``{pad}.status_{s}`` | 1 if the readout's status is s: ok, below_detection, saturated, settling | one-hot |
    | ``{pad}.mode_{m}`` | 1 if the reading was taken in mode m | one-hot |
    | ``opening`` | the opening between the pads | / home opening, to -1 .. 1 |
    | ``opening_speed`` | its change over the last decision | / ``opening_speed_m_s`` |
    | ``lift`` | the lift above its home | / (``lift_span`` x lift height) |
    | ``lift_speed`` | the lift joint's velocity | / ``lift_speed_m_s`` |
    | ``grip_force`` | the fingers' actuator force (positive squeezes) | force log scale |
    | ``load`` | the load the lift carries: its servo's force less the gripper's inertia (the weight held) | force log scale |
    | ``grip_command`` | the grip the actions have set (the fingers' force limit) | force log scale |
    | ``opening_setpoint`` | the opening set-point | / home opening, to -1 .. 1 |
    | ``lift_setpoint`` | the lift set-point above home | / (``lift_span`` x lift height) |
    | ``time`` | the phase of the episode: time / ``time_limit_s`` | 0 .. 1 |
    | ``hold_clock`` | time the lift has spent at the lift height this episode (its joint, within 5 mm) / hold time | 0 .. 1 |

    Everything is clipped to the bounds.

    ## Rewards

    Per step, from the referee's truth (weights :class:`LearnReward`, in ``info`` under each name,
    ``reward`` their sum): ``reward_touch``, ``reward_carry``, ``reward_lift``, ``reward_hold``,
    ``reward_place``, each its weight times the growth of its best-so-far progress
    (:class:`GraspProgress`, each 0 to 1: both fingers on the object; the share of the weight
    they carry while the lift is above home, over a decision; the share of the lift height
    risen while carried without slip; the share of the hold time held; after the hold, the
    share of the way back down, 1 once resting at the start in the fingers);
    ``reward_grip`` = -``grip_per_s`` dt min(ln(grip / (1.25 need)), ln 10) for each period the
    object is carried (both fingers on it, off the table) where the mean finger force ``grip``
    exceeds 1.25 ``need`` = 1.25 m g / (2 mu); ``reward_crush`` (-0.5), ``reward_drop`` (dropped
    or lost), ``reward_slip`` (moved more than 5 mm in the fingers while carried; -0.1 each),
    once, ending the episode; ``reward_success``: +10 when the referee judges it a success,
    ending it.  A placed grasp at no excess grip returns 16.25; doing nothing returns 0; the
    least successful return is checked to be above 0 (``LearnReward.validate``).

    ## Starting State and Objects

    GraspEnv's: the gripper open around the object's centre height, the object at rest on the
    table.  ``randomize=True`` (or an :class:`ObjectDraw`) draws the object at each reset from
    the environment's generator (seeded by ``reset(seed=S)``, continued by a reset without a
    seed): its shape, friction, mass, size and crush force, across the gripper's rating
    (``info["object"]`` at the reset).  Else the scenario's object.

    ## Episode End

    Terminated on success, crushed, dropped, lost, slipped or a divergence; truncated at
    ``time_limit_s`` (or the scenario's duration, if shorter).  ``info`` at the last step has the
    referee's ``outcome``, ``reason``, ``grip_margin`` (its hold grip over ``needed_grip_n``),
    ``needed_grip_n``, ``hold_grip_n``, ``verdict``, ``ended`` and ``progress`` (each potential's
    best, 0 to 1).  ``step()`` after the end
    raises ``RuntimeError`` until ``reset()``.

    ## Arguments

    ``scenario``, ``overrides``, ``preset``, ``render_mode``, ``width``, ``height`` as GraspEnv;
    ``randomize`` (False, True or an ObjectDraw), ``settings`` (a :class:`LearnSettings`),
    ``reward`` (a :class:`LearnReward`).

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
        randomize: bool | ObjectDraw = False,
        settings: LearnSettings | None = None,
        reward: LearnReward | None = None,
        width: int = 640,
        height: int = 480,
    ) -> None:
        self.grasp_env = grasp = GraspEnv(scenario, overrides, preset, render_mode, False, None, width, height)
        self.render_mode = render_mode
        settings = LearnSettings() if settings is None else settings
        if not isinstance(settings, LearnSettings):
            raise ValueError(f"settings must be a LearnSettings, got {shown(settings)}")
        self.settings = settings.validate(grasp.dt)
        weights = LearnReward() if reward is None else reward
        if not isinstance(weights, LearnReward):
            raise ValueError(f"reward must be a LearnReward, got {shown(reward)}")
        self.weights = weights.validate(settings.time_limit_s)
        sim = CoSimulation(_with_blind_controller(grasp.base_config))  # the robot's design and fingertip; nothing run
        self.robot, fingertip = sim.robot, sim.fingertip
        self.grip_max_n = self.robot.finger_force_limit_n
        self.grip_min_n = self.grip_max_n * 10.0 ** (-settings.grip_decades)
        if randomize is True:
            randomize = ObjectDraw()
        if isinstance(randomize, ObjectDraw):
            self.object_draw: ObjectDraw | None = randomize.validate(self.grip_max_n, grasp.gravity_m_s2)
        elif randomize is False:
            self.object_draw = None
        else:
            raise ValueError(f"randomize must be True, False or an ObjectDraw, got {shown(randomize)}")
        span = fingertip.dynamic_range()
        self.p_min_pa, self.p_max_pa = float(span["p_min_pa"]), float(span["p_max_pa"])
        cfg = grasp.base_config.controller
        self.lift_height_m, self.hold_s = cfg.lift_height_m, cfg.hold_s
        self.periods_per_step = round(settings.decision_period_s / grasp.dt)
        self.max_steps = math.ceil(settings.time_limit_s / settings.decision_period_s - 1e-9)
        self.pads, self.modes = grasp.pads, grasp.modes
        self.action_space = spaces.Box(-1.0, 1.0, (4,), np.float32)
        self.observation_names = self._names()
        n = len(self.observation_names)
        self.observation_space = spaces.Box(-np.ones(n, np.float32), np.ones(n, np.float32), dtype=np.float32)
        self._gate = PlacedReleasedGate()
        self._ended: str | None = None
        self._grasp_obs: dict | None = None

    @property
    def grip_command_n(self) -> float:
        """The grip the actions have set so far, N per finger (the fingers' force limit)."""
        return self._grip_n

    def set_object_draw(self, draw: ObjectDraw) -> None:
        """Draw the objects of the next resets from ``draw`` (a curriculum's stage; only with
        ``randomize``): checked as the constructor checks it."""
        if self.object_draw is None or not isinstance(draw, ObjectDraw):
            raise ValueError(f"set_object_draw needs an environment made with randomize and an ObjectDraw, got {shown(draw)}")
        self.object_draw = draw.validate(self.grip_max_n, self.grasp_env.gravity_m_s2)

    # -- Gymnasium API -------------------------------------------------------------------

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        grasp = self.grasp_env
        obj = self.object_draw.sample(self.np_random, self.grip_max_n, grasp.gravity_m_s2) if self.object_draw is not None else None
        noise_seed = int(self.np_random.integers(2**31)) if seed is None else int(seed)
        obs, _ = grasp.reset(seed=noise_seed, options=None if obj is None else {"object": obj})
        self._grasp_obs = obs
        self.need_n = object_needed_grip_n(grasp.sim.model)
        self._home_lift_m, self._home_opening_m = float(obs["lift_setpoint_m"][0]), float(obs["opening_setpoint_m"][0])
        self._grip_n = unit_to_force(0.0, self.grip_min_n, self.grip_max_n)
        self._opening_before_m = float(obs["opening_m"][0])
        self._steps, self._at_height_s, self._lift_accel_m_s2 = 0, 0.0, 0.0
        weight_n = float(grasp.sim.model.body("object").mass[0]) * grasp.gravity_m_s2  # the simulated body's, as the need
        self._progress = GraspProgress(self.lift_height_m, self.hold_s, grasp.dt, weight_n, float(obs["lift_m"][0]))
        self._gate.start()
        self._ended = None
        info = {"object": asdict(grasp.config.object), "needed_grip_n": self.need_n}
        return self._observation(), info

    def step(self, action):
        a = self._begin_step(action)
        s = self.settings
        # The grip moves from where it is, by at most grip_rate_decades_per_s: a held object's grip
        # is a state the policy raises or lowers, not one redrawn with every decision's noise
        # (redrawn, a single low draw dropped what the mean held: issue 46).
        step_decades = float(a[0]) * s.grip_rate_decades_per_s * s.decision_period_s
        self._grip_n = min(max(self._grip_n * 10.0**step_decades, self.grip_min_n), self.grip_max_n)
        # Closed up to OPEN_ABOVE, the fingers squeezing whatever they meet with the grip; open to
        # home above it.  At or below 0 the lift's target is home: the object stays on (or goes
        # back to) the table.
        opening_target_m = self._home_opening_m if float(a[1]) > OPEN_ABOVE else 0.0
        lift_target_m = self._home_lift_m + max(float(a[2]), 0.0) * s.lift_span * self.lift_height_m
        if not self._fingers_blocked():
            # The lift rises only once the fingers have stopped on something: an empty gripper that
            # rises grasps the object high, at an edge, or not at all (what PPO did first, issue 46).
            lift_target_m = min(lift_target_m, float(self._grasp_obs["lift_setpoint_m"][0]))
        mode = mode_index(float(a[3]), len(self.modes))
        parts, terminated, truncated, ended, verdict = self._decide(lambda: self._grasp_action(opening_target_m, lift_target_m, mode))
        return self._end_step(parts, {"time_s": self.grasp_env.sim.time_s}, terminated, truncated, ended, verdict)

    def _begin_step(self, action) -> np.ndarray:
        """The action, checked (:meth:`_checked`), once a reset began an episode that has not ended."""
        if self._grasp_obs is None:
            raise RuntimeError("call reset() before step()")
        if self._ended is not None:
            raise RuntimeError(f"the episode has ended ({self._ended}); call reset() before step()")
        return self._checked(action)

    def _decide(self, command: Callable[[], dict]) -> tuple[dict, bool, bool, str, object]:
        """One decision: up to ``periods_per_step`` control periods, each stepping the grasp with
        ``command()`` (GraspEnv's action), the progress and the grip's cost accounted as they
        go, stopped by the grasp's own end, a slip or a success at the gate.  Returns the
        reward's parts so far (progress, grip), whether the episode terminated or was truncated,
        how it ended ("" while it runs) and the referee's verdict if the gate took one."""
        s, grasp, w, progress = self.settings, self.grasp_env, self.weights, self._progress
        before = dict(progress.potentials)
        parts = dict.fromkeys(REWARD_PARTS, 0.0)
        self._opening_before_m = float(self._grasp_obs["opening_m"][0])
        terminated = truncated = False
        ended, verdict = "", None
        for _ in range(self.periods_per_step):
            obs, _, terminated, truncated, info = grasp.step(command())
            self._lift_accel_m_s2 = (float(obs["lift_velocity_m_s"][0]) - float(self._grasp_obs["lift_velocity_m_s"][0])) / grasp.dt
            self._grasp_obs = obs
            row = grasp.last_row()
            slipped = progress.update(row)
            if progress.carried:  # what holding costs; a squeeze on the table risks only the crush
                grip = 0.5 * (row["left_finger_force_n"] + row["right_finger_force_n"])
                parts["reward_grip"] -= grip_cost_per_s(grip, self.need_n, w) * grasp.dt
            if terminated or truncated:
                ended = info.get("ended", "duration")
                break
            if slipped:
                terminated, ended = True, "slipped"
                break
            if self._gate.opens(row):
                verdict = grasp.verdict()
                if verdict.success:
                    terminated, ended = True, "success"
                    break
        progress.end_decision()
        self._steps += 1
        lift_m = float(self._grasp_obs["lift_m"][0])
        # The robot's own account of the hold (its lift joint, the referee's 5 mm): the agent's clock.
        at_height = lift_m >= self._home_lift_m + self.lift_height_m - progress.criteria.slip_tolerance_m
        # Summed, never reset: lowered after the hold, the agent still knows the hold is done (its
        # policy has no memory; a clock back at 0 would look like the time before the lift).
        self._at_height_s += s.decision_period_s if at_height else 0.0
        for p in PROGRESS:
            parts[f"reward_{p}"] = getattr(w, p) * (progress.potentials[p] - before[p])
        return parts, terminated, truncated, ended, verdict

    def _end_step(self, parts: dict, info: dict, terminated: bool, truncated: bool, ended: str, verdict):
        """The step's return: the time limit, the end's penalty or bonus and the referee's verdict
        in ``info`` at the last step, the reward's parts in ``info`` and their sum the reward."""
        w, grasp = self.weights, self.grasp_env
        if not (terminated or truncated) and self._steps >= self.max_steps:
            truncated, ended = True, "time_limit"
        if terminated or truncated:
            verdict = grasp.verdict() if verdict is None or ended != "success" else verdict
            penalty = {"crushed": ("reward_crush", w.crush), "dropped": ("reward_drop", w.drop), "lost": ("reward_drop", w.drop)}
            penalty["slipped"] = ("reward_slip", w.slip)
            if ended in penalty:
                key, value = penalty[ended]
                parts[key] = -value
            if ended == "success":
                parts["reward_success"] = w.success
            info.update(
                ended=ended,
                outcome=verdict.outcome,
                reason=verdict.reason,
                grip_margin=verdict.grip_margin,
                needed_grip_n=verdict.needed_grip_n,
                hold_grip_n=verdict.hold_grip_n,
                verdict=verdict.as_dict(),
                progress=dict(self._progress.potentials),
            )
            self._ended = f"{'terminated' if terminated else 'truncated'}: {ended}"
        info.update(parts)
        reward = float(sum(parts.values()))
        return self._observation(), reward, terminated, truncated, info

    def render(self):
        return self.grasp_env.render()

    def close(self) -> None:
        self.grasp_env.close()
        super().close()

    # -- internals ------------------------------------------------------------------------

    def _checked(self, action) -> np.ndarray:
        """The action as float64, or ValueError naming what is wrong with it."""
        a = real_numbers(action)
        if a is None or a.shape != (4,):
            raise ValueError(f"action must be 4 real numbers in [-1, 1] (grip rate, fingers, lift target, mode), got {shown(action)}")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"action must be finite, got {shown(action)}")
        if np.any(np.abs(a) > 1.0):
            raise ValueError(f"action must lie in the action space [-1, 1]^4, got {shown(action)}")
        return a

    def _grasp_action(self, opening_target_m: float, lift_target_m: float, mode: int) -> dict:
        """GraspEnv's action for one control period: the set-points slewed toward the targets."""
        s, dt, obs = self.settings, self.grasp_env.dt, self._grasp_obs
        opening_sp, lift_sp = float(obs["opening_setpoint_m"][0]), float(obs["lift_setpoint_m"][0])
        opening_rate = min(max((opening_target_m - opening_sp) / dt, -s.opening_speed_m_s), s.opening_speed_m_s)
        lift_rate = min(max((lift_target_m - lift_sp) / dt, -s.lift_speed_m_s), s.lift_speed_m_s)
        return {
            "grip_force_n": np.array([self._grip_n]),
            "opening_velocity_m_s": np.array([opening_rate]),
            "lift_velocity_m_s": np.array([lift_rate]),
            "mode": np.full(len(self.pads), mode, np.int64),
        }

    def _names(self) -> tuple[str, ...]:
        names = []
        for pad in self.pads:
            names += [f"{pad}.pressure", f"{pad}.sigma"]
            names += [f"{pad}.status_{s}" for s in STATUS_CODES]
            names += [f"{pad}.mode_{m}" for m in self.modes]
        names += ["opening", "opening_speed", "lift", "lift_speed", "grip_force", "load", "grip_command"]
        names += ["opening_setpoint", "lift_setpoint", "time", "hold_clock"]
        return tuple(names)

    def _fingers_blocked(self) -> bool:
        """Whether the fingers have stopped on something, from their own joints: their set-point
        lies more than :data:`BLOCKED_M` inside where they are, and they moved less than that over
        the last decision."""
        obs = self._grasp_obs
        opening, setpoint = float(obs["opening_m"][0]), float(obs["opening_setpoint_m"][0])
        return opening - setpoint > BLOCKED_M and abs(opening - self._opening_before_m) < BLOCKED_M

    def _load_n(self) -> float:
        """The load the lift carries, N, as the house controller reads it (RobotLimits.lift_load_n):
        its servo's force from its set-point, position and velocity, less the gripper's inertia
        (the acceleration over the last control period).  The actuator's force sensor reads 1.7 N
        more while the lift moves at 0.05 m/s, which would hide every object under 170 g."""
        obs = self._grasp_obs
        sp, q, v = float(obs["lift_setpoint_m"][0]), float(obs["lift_m"][0]), float(obs["lift_velocity_m_s"][0])
        return self.robot.lift_load_n(sp, q, v, self._lift_accel_m_s2)

    def _pressure_unit(self, pressure_pa: float) -> float:
        if not pressure_pa > self.p_min_pa:
            return 0.0
        return min(math.log(pressure_pa / self.p_min_pa) / math.log(self.p_max_pa / self.p_min_pa), 1.0)

    def _observation(self) -> np.ndarray:
        obs, s = self._grasp_obs, self.settings
        lo, hi = self.grip_min_n, self.grip_max_n
        values: list[float] = []
        for i in range(len(self.pads)):
            status = int(obs["status"][i])
            has_estimate = STATUS_CODES[status] in ("ok", "below_detection")
            values.append(self._pressure_unit(float(obs["pressure_pa"][i])) if has_estimate else 0.0)
            values.append(self._pressure_unit(float(obs["uncertainty_pa"][i])) if has_estimate else 1.0)
            values += [1.0 if k == status else 0.0 for k in range(len(STATUS_CODES))]
            values += [1.0 if k == int(obs["mode"][i]) else 0.0 for k in range(len(self.modes))]
        lift_scale = s.lift_span * self.lift_height_m
        opening = float(obs["opening_m"][0])
        values += [
            2.0 * opening / self._home_opening_m - 1.0,
            (opening - self._opening_before_m) / s.decision_period_s / s.opening_speed_m_s,
            (float(obs["lift_m"][0]) - self._home_lift_m) / lift_scale,
            float(obs["lift_velocity_m_s"][0]) / s.lift_speed_m_s,
            force_to_unit(float(obs["grip_force_n"][0]), lo, hi),
            force_to_unit(self._load_n(), lo, hi),
            force_to_unit(self._grip_n, lo, hi),
            2.0 * float(obs["opening_setpoint_m"][0]) / self._home_opening_m - 1.0,
            (float(obs["lift_setpoint_m"][0]) - self._home_lift_m) / lift_scale,
            self._steps / self.max_steps,
            min(self._at_height_s / self.hold_s, 1.0),
        ]
        return np.clip(np.asarray(values), -1.0, 1.0).astype(np.float32)


# -- the assisted grasp: residual learning over the house controller -------------------------

#: The house controller's phases, in code order: the assisted environment's phase one-hot.
PHASE_NAMES = tuple(p.label for p in Phase)


class GraspAssistEnv(GraspLearnEnv):
    """The grasp of ``piezotip/GraspLearn-v0`` with the house controller at the wheel: the policy
    corrects its grip (``piezotip/GraspAssist-v0``, issue 46).

    ## Description

    Residual policy learning (Silver et al. 2018, "Residual Policy Learning"; Johannink et al.
    2019, "Residual Reinforcement Learning for Robot Control"): the scenario's own controller (the
    gentle grasp by default, :class:`~piezotip.gym_env.MultimodePolicy`, exactly as it runs alone
    in ``Grasp-v0``) runs the grasp's skeleton at every control period (approach, touch, probe,
    carry, hold, place, release) and the policy, at each decision (40 ms, eight periods), scales
    the grip it commands.  A learner starting from nothing must find the whole sequence before
    any success pays (GraspLearn-v0 did not, in 100k-300k steps); here the untrained policy
    already grasps as the house does (20 of the 20 held-out objects of examples/train_ppo.py,
    median grip margin 1.29), and what is left to learn is where its grip is wrong.

    The controller is built at each reset for the episode's scenario (``grasp_env.config``, as
    :class:`~piezotip.gym_env.MultimodePolicy` builds it), so that its camera (``perception.*``)
    sees the episode's object, as it does when the command line runs that object.

    The physics, the readout, the referee, the object draws (``randomize``), the progress and the
    reward's parts are :class:`GraspLearnEnv`'s.

    ## Action Space

    ``Box(-1, 1, (1,), float32)``: ``a``, the grip factor's exponent.  Every control period until
    the next decision, the fingers' force limit is the controller's (``Command.grip_force_limit_n``)
    times ``2 ** (a * grip_octaves)``, at most the fingers' own limit.  ``grip_octaves`` = 1: x0.5
    to x2.  The span: the house holds at 1.1-1.5x the need (the least grip that holds), so x0.5
    reaches below the need (a policy can find where the object slips) and x2 reaches 2.2-3x, past
    the task's margin of 2 and up to the draws' crush floor (2.5x the need): nothing the task
    rewards lies outside, and a wider span only makes an untrained policy's noise coarser.  A
    factor, not a rate: each decision's noise changes the grip for 40 ms and is gone, nothing
    accumulates.  The controller's vibration modes, set-points and phases are its own.

    **Action 0 is the house controller, bit for bit** (the factor is exactly 1.0): the same
    commands, the same record, the referee's same outcome and grip margin as the controller run
    alone in ``Grasp-v0`` on the same object and seed, built for that episode's scenario
    (tests/test_gym_assist.py).

    An action outside the box, not real numbers, non-finite or of another shape raises
    ``ValueError``.

    ## Observation Space

    ``Box(-1, 1, (n,), float32)``, ``env.unwrapped.observation_names``: GraspLearnEnv's (with
    ``grip_command`` the grip applied, the controller's times the factor), then

    | Name | Observation | Scaled as |
    |---|---|---|
    | ``house_grip`` | the grip the controller commanded in the last period (before the factor) | force log scale |
    | ``grip_factor`` | the last action (the factor's exponent; 0 at the reset) | -1 .. 1 |
    | ``phase_{p}`` | 1 if the controller is in phase p (approach, close, squeeze, lift, hold, place, release, done, fault) | one-hot |

    ## Rewards

    GraspLearnEnv's parts (:data:`REWARD_PARTS`, each in ``info``, ``reward`` their sum; weights
    :class:`LearnReward`): the progress potentials (touch, carry, lift, hold, place: what an
    assisted grasp that lifts the heavy object the house gave up on earns over one that does
    not); ``reward_grip``, the cost of the grip beyond 1.25x the least grip that holds
    (``info["needed_grip_n"]``, m g / (2 mu)) while carried, ``grip_per_s`` x min(ln(grip / (1.25
    need)), ln 10) per second; ``reward_crush`` (-0.5), ``reward_drop`` (-0.1, dropped or lost),
    ``reward_slip`` (-0.1, 5 mm in the fingers while carried), ending the episode; and
    ``reward_success`` (+10) when the referee judges it a success, ending it.

    ## Episode End

    GraspLearnEnv's, with the time limit the scenario's duration (12 s for ``grasp``: the time the
    house has when it runs alone) unless ``settings`` says otherwise.  The last
    step's ``info`` has the referee's ``outcome``, ``grip_margin``, ``needed_grip_n`` and
    ``verdict``.

    ## Arguments

    GraspLearnEnv's, and ``grip_octaves`` (the factor's span, octaves each way: 1).

    ## Version History

    - v0: the first version.
    """

    def __init__(
        self,
        scenario: str = "grasp",
        overrides=None,
        preset: str | None = None,
        render_mode: str | None = None,
        randomize: bool | ObjectDraw = False,
        settings: LearnSettings | None = None,
        reward: LearnReward | None = None,
        width: int = 640,
        height: int = 480,
        grip_octaves: float = 1.0,
    ) -> None:
        super().__init__(scenario, overrides, preset, render_mode, randomize, settings, reward, width, height)
        grasp = self.grasp_env
        if settings is None:  # the scenario's whole time: the house's slowest grasps take it
            self.settings = LearnSettings(time_limit_s=grasp.base_config.duration_s).validate(grasp.dt)
            self.weights = self.weights.validate(self.settings.time_limit_s)
            self.max_steps = math.ceil(self.settings.time_limit_s / self.settings.decision_period_s - 1e-9)
        if not (isinstance(grip_octaves, (int, float)) and not isinstance(grip_octaves, bool) and 0 < grip_octaves <= 10):
            raise ValueError(f"grip_octaves must be a number in (0, 10], got {shown(grip_octaves)}")
        self.grip_octaves = float(grip_octaves)
        self.house = MultimodePolicy.for_env(grasp)
        self.action_space = spaces.Box(-1.0, 1.0, (1,), np.float32)
        self._house_grip_n, self._factor_action = 0.0, 0.0

    @property
    def phase(self) -> Phase:
        """The house controller's phase (APPROACH before its first period)."""
        controller = self.house.controller
        return Phase.APPROACH if controller is None else controller.phase

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        _, info = super().reset(seed=seed, options=options)
        self.house.reset()  # its next controller is the episode's (MultimodePolicy: the camera sees this object)
        self._grip_n, self._house_grip_n, self._factor_action = 0.0, 0.0, 0.0  # no command yet
        return self._observation(), info

    def step(self, action):
        a = self._begin_step(action)
        self._factor_action = float(a[0])
        factor = 2.0 ** (self._factor_action * self.grip_octaves)  # exactly 1.0 at 0: the house's own grip

        def command() -> dict:
            command = self.house(self._grasp_obs)
            self._house_grip_n = float(command["grip_force_n"][0])
            self._grip_n = min(self._house_grip_n * factor, self.grip_max_n)
            command["grip_force_n"] = np.array([self._grip_n])
            return command

        parts, terminated, truncated, ended, verdict = self._decide(command)
        info = {"time_s": self.grasp_env.sim.time_s, "grip_factor": factor, "phase": self.phase.label}
        return self._end_step(parts, info, terminated, truncated, ended, verdict)

    def _checked(self, action) -> np.ndarray:
        """The action as float64, or ValueError naming what is wrong with it."""
        a = real_numbers(action)
        if a is None or a.size != 1 or a.ndim > 1:
            raise ValueError(f"action must be 1 real number in [-1, 1] (the grip factor's exponent), got {shown(action)}")
        a = a.reshape(1)
        if not np.all(np.isfinite(a)):
            raise ValueError(f"action must be finite, got {shown(action)}")
        if np.any(np.abs(a) > 1.0):
            raise ValueError(f"action must lie in the action space [-1, 1], got {shown(action)}")
        return a

    def _names(self) -> tuple[str, ...]:
        return (*super()._names(), "house_grip", "grip_factor", *(f"phase_{p}" for p in PHASE_NAMES))

    def _observation(self) -> np.ndarray:
        base = super()._observation()
        phase = int(self.phase)
        extra = [force_to_unit(self._house_grip_n, self.grip_min_n, self.grip_max_n), self._factor_action]
        extra += [1.0 if k == phase else 0.0 for k in range(len(PHASE_NAMES))]
        return np.concatenate([base, np.clip(np.asarray(extra), -1.0, 1.0).astype(np.float32)])
