"""A load change while the object is held (``disturb.*``, :class:`~piezotip.cosim.config.DisturbConfig`).

An extra downward force on the object comes on at the middle of the hold, as the controller's
phases define it: the time its phase first turns to hold (the phase it commands, the record's
``phase`` column) plus half of ``controller.hold_s`` (:func:`onset_s`; the referee takes the
same time from the record, analysis.referee.disturb_onset_s).  It rises linearly over
``ramp_s`` and stays on to the end of the run.

MuJoCo applies it as ``xfrc_applied`` on the object body (a force at its centre of mass, world
frame), set once per control period to the ramp's mean over that period
(:func:`ramp_share`): the impulse each period gets is the linear ramp's exactly, and the
physics' substeps run untouched (cosim/_period.py).  At the default 5 ms period and 50 ms ramp
that is ten equal steps.
"""

from __future__ import annotations

import math

from .control.phases import Phase


def onset_s(hold_start_s: float, hold_s: float) -> float:
    """When the load comes on, s: the middle of a hold that began at ``hold_start_s`` (s) and
    lasts ``hold_s`` (s, the controller's ``hold_s``)."""
    return hold_start_s + 0.5 * hold_s


def _ramp_integral(s: float, ramp_s: float) -> float:
    """The integral from the onset to ``s`` (s after it) of the load's share, s: 0 before the
    onset, s^2 / (2 ramp) while it rises, ramp / 2 + (s - ramp) after."""
    if s <= 0.0:
        return 0.0
    if s <= ramp_s:
        return 0.5 * s * s / ramp_s
    return 0.5 * ramp_s + (s - ramp_s)


def ramp_share(t0_s: float, t1_s: float, onset: float, ramp_s: float) -> float:
    """The load's mean share of its full value over [``t0_s``, ``t1_s``] (s), for a load that
    rises linearly from 0 at ``onset`` (s) to 1 at ``onset + ramp_s`` and stays: in [0, 1]."""
    if not t1_s > t0_s:
        raise ValueError(f"ramp_share needs t1_s > t0_s, got {t0_s!r} and {t1_s!r}")
    return (_ramp_integral(t1_s - onset, ramp_s) - _ramp_integral(t0_s - onset, ramp_s)) / (t1_s - t0_s)


class LoadDisturbance:
    """The extra load on the object, scheduled by the controller's commanded phase.

    Parameters
    ----------
    load_n : the full extra load, N (downward).
    ramp_s : its rise time, s.
    hold_s : the controller's hold time, s.
    xfrc_row : the object body's row of MuJoCo's ``data.xfrc_applied`` (a live view, 6 values:
        force then torque, world frame); its z force is set to ``-load``.

    Attributes
    ----------
    hold_start_s : when the controller's phase first turned to hold, s (None until then).
    onset_s : when the load comes on, s (NaN until the hold begins).
    applied_n : the load applied over the current period, N.
    """

    def __init__(self, load_n: float, ramp_s: float, hold_s: float, xfrc_row) -> None:
        self.load_n = float(load_n)
        self.ramp_s = float(ramp_s)
        self.hold_s = float(hold_s)
        self._xfrc = xfrc_row
        self.hold_start_s: float | None = None
        self.onset_s = math.nan
        self.applied_n = 0.0

    def command(self, phase, time_s: float, dt_s: float) -> None:
        """The controller commanded ``phase`` at ``time_s`` (s) for the next period of ``dt_s``
        (s): note the hold's start, and set the load for [time_s, time_s + dt_s]."""
        if self.hold_start_s is None:
            if phase != Phase.HOLD:
                return
            self.hold_start_s = time_s
            self.onset_s = onset_s(time_s, self.hold_s)
        self.applied_n = self.load_n * ramp_share(time_s, time_s + dt_s, self.onset_s, self.ramp_s)
        self._xfrc[2] = -self.applied_n

    def bind(self, xfrc_row) -> None:
        """Apply the load through ``xfrc_row`` from now on (a copy of the simulation binds its own)."""
        self._xfrc = xfrc_row
        self._xfrc[2] = -self.applied_n
