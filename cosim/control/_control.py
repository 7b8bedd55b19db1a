"""The controller's per-reading parts and the records a control step passes between stages.

A kernel (:mod:`piezotip.sensor.compiled`): this module runs as Python and, where built,
compiled (``_control.pxd`` types it: the selector's and detector's state in C fields).
:class:`ModeSelector` and :class:`TouchDetector` are documented in
:mod:`cosim.control.selector`; :func:`make_pad_signal`, :func:`make_observation` and
:func:`make_command` make the frozen records of :mod:`cosim.control.interface` by writing their
slots, not through their constructors (``object.__setattr__`` per field).
"""

from __future__ import annotations

import math

from piezotip.cosim.control.interface import Command, Observation, PadSignal, Why
from piezotip.sensor import _kernel_helpers as kh

# Where each field of a record is written, in its fields' order (Why: its two attributes).
_PAD_SIGNAL_AT = kh.slot_offsets(PadSignal, 2)
_OBSERVATION_AT = kh.slot_offsets(Observation, 7)
_COMMAND_AT = kh.slot_offsets(Command, 6)
_WHY_AT = kh.slot_offsets(Why, 2, ("template", "args"))


def make_pad_signal(reading, estimate) -> PadSignal:
    """``PadSignal(reading, estimate)`` for the per-step path: an ordinary, equal, frozen instance."""
    return kh.record2(PadSignal, _PAD_SIGNAL_AT, reading, estimate)


def make_observation(time_s, pads, lift_pos_m, opening_m, lift_force_n, grip_force_n, lift_vel_m_s=0.0) -> Observation:
    """``Observation(...)`` for the per-step path (see :func:`make_pad_signal`)."""
    return kh.record7(Observation, _OBSERVATION_AT, time_s, pads, lift_pos_m, opening_m, lift_force_n, grip_force_n, lift_vel_m_s)


def make_command(lift_m, opening_m, grip_force_limit_n, modes, phase, reason) -> Command:
    """``Command(...)`` for the per-step path (see :func:`make_pad_signal`)."""
    return kh.record6(Command, _COMMAND_AT, lift_m, opening_m, grip_force_limit_n, modes, phase, reason)


def _why(template: str, args: tuple) -> Why:
    """``Why(template, *args)``, its attributes set without the call of its ``__init__`` (which
    would cost a third of an update)."""
    return kh.record2(Why, _WHY_AT, template, args)


class ModeSelector:
    """Chooses one fingertip's drive mode from its readout, with hysteresis and settling
    (:mod:`cosim.control.selector` says how and why).

    Parameters
    ----------
    fingertip : the fingertip model whose switch pressures and limits the selector uses.
    modes : the allowed modes (a subset of the fingertip's), ascending.
    hysteresis : fractional band around each switch pressure.
    persist : consecutive readings that call for the same switch (saturated, below detection,
        above the switch up, below the switch down) before it is made.
    """

    __slots__ = (
        "_above_switch",
        "_neighbours",
        "_saturated",
        "_under_switch",
        "bands",
        "blind",
        "estimate_pa",
        "fingertip",
        "hysteresis",
        "mode",
        "modes",
        "p_max_pa",
        "p_min_pa",
        "persist",
        "status",
        "switch_pa",
        "trusted",
        "uncertainty_pa",
    )

    def __init__(self, fingertip, modes: tuple[int, ...], hysteresis: float = 0.25, persist: int = 3) -> None:
        from piezotip.cosim.control.selector import allowed_ranges  # it imports this module

        self.modes = tuple(sorted(modes))
        self.fingertip, self.bands, self.p_min_pa, self.p_max_pa = allowed_ranges(fingertip, self.modes)
        # Switch pressure between consecutive allowed modes (the band edge), Pa.
        self.switch_pa = {(a[0], b[0]): a[2] for a, b in zip(self.bands, self.bands[1:], strict=False)}
        # Each allowed mode's neighbours (next mode up, next mode down; None past either end)
        # and its switch pressures up and down (Pa; inf and 0 past either end), looked up on
        # every reading rather than searched for.
        self._neighbours = {}
        for i, m in enumerate(self.modes):
            up = self.modes[i + 1] if i + 1 < len(self.modes) else None
            down = self.modes[i - 1] if i > 0 else None
            up_pa = self.switch_pa[(m, up)] if up is not None else math.inf
            down_pa = self.switch_pa[(down, m)] if down is not None else 0.0
            self._neighbours[m] = (up, down, up_pa, down_pa)
        self.hysteresis = hysteresis
        self.persist = persist
        self.mode = self.modes[0]
        self._saturated = 0  # consecutive saturated readings
        self._above_switch = 0  # consecutive readings past the switch up (saturated, or "ok" above it)
        self._under_switch = 0  # and past the switch down (below detection, or "ok" below it)
        self.blind = False  # saturated in the highest allowed mode
        self.estimate_pa = 0.0  # last trusted estimate
        self.uncertainty_pa = math.nan
        self.status = "below_detection"  # status of the last trusted estimate
        self.trusted = True

    def update(self, estimate) -> tuple[int, object]:
        """Take one readout estimate; return (mode to drive next, why).

        A "settling" estimate (the readout cannot yet tell the new mode's steady reading) is
        not used: the last trusted estimate is held and no switch is made.
        """
        status = estimate.status
        if status == "settling":
            self.trusted = False
            return self.mode, _why("mode {}: settling, holding {:.3g} Pa", (self.mode, self.estimate_pa))
        self.trusted = True
        self.blind = False
        if status == "ok" or status == "below_detection":
            pressure = estimate.pressure_pa
            if kh.isfinite(pressure):
                self.estimate_pa, self.uncertainty_pa, self.status = pressure, estimate.uncertainty_pa, status
        up, down, up_pa, down_pa = self._neighbours[self.mode]
        p = self.estimate_pa
        # A saturated reading is past the switch up (P_max lies above it), a below-detection
        # one past the switch down: one streak each, whatever mix of readings makes it.
        self._saturated = self._saturated + 1 if status == "saturated" else 0
        h = self.hysteresis
        above = up is not None and (status == "saturated" or (status == "ok" and p > up_pa * (1 + h)))
        under = down is not None and (status == "below_detection" or (status == "ok" and p < down_pa * (1 - h)))
        self._above_switch = self._above_switch + 1 if above else 0
        self._under_switch = self._under_switch + 1 if under else 0
        if up is None and self._saturated >= self.persist:
            self.blind = True
            why = _why("mode {}: saturated and no higher mode allowed (blind above {:.3g} Pa)", (self.mode, self.p_max_pa[self.mode]))
            return self.mode, why
        if self._above_switch >= self.persist:
            if status == "saturated":
                return self._switch(up, f"mode {self.mode} saturated (P > {self.p_max_pa[self.mode]:.3g} Pa)")
            return self._switch(up, f"P {p:.3g} Pa above switch {up_pa:.3g} Pa x {1 + h:g}")
        if self._under_switch >= self.persist:
            if status == "below_detection":
                return self._switch(down, f"mode {self.mode} below detection (P < {self.p_min_pa[self.mode]:.3g} Pa)")
            return self._switch(down, f"P {p:.3g} Pa below switch {down_pa:.3g} Pa x {1 - h:g}")
        return self.mode, _why("mode {}: {}, P {:.3g} Pa", (self.mode, status, self.estimate_pa))

    def _switch(self, mode: int, why: str) -> tuple[int, str]:
        old, self.mode = self.mode, mode
        self._saturated = self._above_switch = self._under_switch = 0
        self.trusted = False
        return mode, f"switch {old} -> {mode}: {why}"

    @property
    def empty(self) -> bool:
        """The fingertip reads no load: below detection in its lowest allowed mode."""
        return self.trusted and self.status == "below_detection" and self.mode == self.modes[0]


class TouchDetector:
    """One-sided CUSUM on the drop of a reading below its unloaded baseline, in sigmas, with a
    Shewhart limit on single readings (:mod:`cosim.control.selector`).

    Parameters
    ----------
    sigma : one reading's standard deviation, dimensionless (V_1 units).
    drift_sigma : the CUSUM's allowance k, sigmas (half the smallest shift to detect).
    alarm_sigma : the CUSUM's threshold h, sigmas.
    single_sigma : one reading's drop that alarms alone, sigmas.
    """

    __slots__ = (
        "_armed_count",
        "_armed_sum",
        "_count",
        "_sum",
        "alarm_sigma",
        "baseline",
        "drift_sigma",
        "score",
        "sigma",
        "single_sigma",
        "touched",
    )

    def __init__(self, sigma: float, drift_sigma: float = 0.5, alarm_sigma: float = 8.0, single_sigma: float = 6.0) -> None:
        self.sigma = sigma
        self.drift_sigma, self.alarm_sigma, self.single_sigma = drift_sigma, alarm_sigma, single_sigma
        self.baseline = math.nan
        self._sum = 0.0
        self._count = 0
        self._armed_sum = 0.0  # the readings update() took since the detector was (re)armed
        self._armed_count = 0
        self.score = 0.0
        self.touched = False

    def learn(self, v1: float) -> None:
        """Add an unloaded reading to the baseline."""
        self._sum += v1
        self._count += 1
        self.baseline = self._sum / self._count

    def rearm(self) -> None:
        """Forget an alarm (the baseline stays): the next significant drop alarms again."""
        self.score, self.touched = 0.0, False
        self._armed_sum, self._armed_count = 0.0, 0

    def rearm_unloaded(self) -> None:
        """Forget an alarm the fingertips showed false: the readings taken since the detector was
        armed were unloaded, so they join the baseline.  A baseline of the approach's few
        readings (twenty: a standard error of 0.22 sigma) can sit a third of a sigma high, which
        leaves the CUSUM's half-sigma allowance a sixth of a sigma against noise: it alarms
        again within tens of readings, at every restart of the closing."""
        self._sum += self._armed_sum
        self._count += self._armed_count
        if self._count:
            self.baseline = self._sum / self._count
        self.rearm()

    def update(self, v1: float) -> bool:
        """Take a reading; True once the drop is significant (latched)."""
        if not self.touched:
            self._armed_sum += v1
            self._armed_count += 1
            drop = (self.baseline - v1) / self.sigma
            self.score = max(0.0, self.score + drop - self.drift_sigma)
            self.touched = self.score > self.alarm_sigma or drop > self.single_sigma
        return self.touched
