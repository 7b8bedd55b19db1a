"""The scripted grasp: fixed targets, no sensing; a baseline and a smoke test of the loop."""

from __future__ import annotations

from typing import TYPE_CHECKING

from piezotip.cosim.control.config import ScriptedConfig
from piezotip.sensor import Fingertip

from .interface import Command, Event, Observation, RobotLimits, pad_names
from .phases import Phase
from .registry import register

if TYPE_CHECKING:  # annotations only: the scenario's config is above the controllers
    from piezotip.cosim.config import ScenarioConfig


@register("scripted", config=ScriptedConfig)
class ScriptedGrasp:
    """Approach, close, lift, hold, put back and open with fixed targets.

    The fingers close at ``closing_speed_m_s`` toward a closed target with the force limit
    ``grip_force_n``; contact is taken from proprioception (the fingers stop following the
    ramp); after a short settle the object is lifted at ``lift_speed_m_s`` by
    ``lift_height_m``, held for ``hold_s``, lowered at ``touchdown_speed_m_s`` to where it was
    picked up, and released at ``opening_speed_m_s``.  The fingertips stay in their first mode.
    """

    #: The squeeze at the fixed force settles for this long before the lift, s: the force limit
    #: is reached at the closing speed's end of travel (no touch sensing to cut it short).
    SETTLE_S = 0.3

    @classmethod
    def from_scenario(cls, config: ScenarioConfig, robot: RobotLimits, fingertip: Fingertip) -> ScriptedGrasp:
        """The scripted grasp of ``config``'s scenario (it reads no fingertip)."""
        return cls(config.controller, robot, pad_names(config.sensor.pads))

    def __init__(self, config: ScriptedConfig, robot: RobotLimits, pads: tuple[str, ...]) -> None:
        self.cfg = config
        self.robot = robot
        self.pads = pads
        self.phase = Phase.APPROACH
        self.events: list[Event] = []
        self.gave_up: str | None = None
        self._t_phase = 0.0
        self._opening = robot.home_opening_m
        self._lift = robot.home_lift_m

    def _enter(self, phase: Phase, t: float, why: str = "") -> None:
        self.phase, self._t_phase = phase, t
        self.events.append(Event(t, "", "phase", f"{phase.label}: {why}" if why else phase.label))

    def step(self, obs: Observation, dt_s: float) -> Command:
        cfg, t, home = self.cfg, obs.time_s, self.robot
        grip = cfg.grip_force_n
        if self.phase is Phase.APPROACH and t >= cfg.baseline_s:
            self._enter(Phase.CLOSE, t)
        if self.phase is Phase.CLOSE:
            self._opening = max(0.0, self._opening - cfg.closing_speed_m_s * dt_s)
            # The fingers lag the ramp by more than 3 mm: they are held by the object.
            if obs.opening_m - self._opening > 0.003:
                self._enter(Phase.SQUEEZE, t, f"contact: opening {1e3 * obs.opening_m:.1f} mm stopped following the ramp")
        if self.phase in (Phase.SQUEEZE, Phase.LIFT, Phase.HOLD, Phase.PLACE):
            self._opening = 0.0  # squeeze at the force limit
        if self.phase is Phase.SQUEEZE and t - self._t_phase >= self.SETTLE_S:
            self._enter(Phase.LIFT, t)
        top = home.home_lift_m + cfg.lift_height_m
        if self.phase is Phase.LIFT:
            self._lift = min(top, self._lift + cfg.lift_speed_m_s * dt_s)
            if self._lift >= top and abs(obs.lift_pos_m - self._lift) < 0.002:
                self._enter(Phase.HOLD, t)
        if self.phase is Phase.HOLD and t - self._t_phase >= cfg.hold_s:
            self._enter(Phase.PLACE, t)
        if self.phase is Phase.PLACE:
            self._lift = max(home.home_lift_m, self._lift - cfg.touchdown_speed_m_s * dt_s)
            if self._lift <= home.home_lift_m and abs(obs.lift_pos_m - self._lift) < 0.002:
                self._enter(Phase.RELEASE, t)
        if self.phase is Phase.RELEASE:
            # From where the fingers are (the squeeze's target lies inside the object).
            self._opening = min(home.home_opening_m, max(self._opening, obs.opening_m) + cfg.opening_speed_m_s * dt_s)
            grip = min(grip, cfg.drive_margin * (home.finger_damping_n_s_m * cfg.opening_speed_m_s + home.finger_friction_n))
            if obs.opening_m >= home.home_opening_m - 0.002:
                self._enter(Phase.DONE, t)
        modes = {pad: cfg.modes[0] for pad in self.pads}
        return Command(self._lift, self._opening, grip, modes, self.phase, f"scripted {self.phase.label}")

    @property
    def finished(self) -> bool:
        return self.phase is Phase.DONE
