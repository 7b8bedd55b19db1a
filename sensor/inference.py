"""The readout's inference of the steady reading from a resonator that has not settled.

With resonator dynamics a reading lags the load by the envelope's time constant (0.66 s with
Table I's damping, physics.md section 6), so the readout infers the steady reading of the
present load from its recent readings: :class:`SteadyInference`, a least-squares fit of the
envelope's own equation over a window, restarted when a change test says the load changed.

:class:`SteadyInference` is a kernel: one source, ``sensor/_inference.py`` (which documents the
model, the fit, the change test and the window), compiled where built (:mod:`sensor.compiled`;
:data:`COMPILED` says); ``PIEZOTIP_PURE_PYTHON=1`` runs it as Python, and
:class:`PySteadyInference` is that source run as Python.  The constants below are its.
:class:`sensor.channel.SensorChannel` feeds it the lock-in's readings and hands its steady
reading to the estimator (:meth:`sensor.estimator.ModeInverse.inferred`) with its noise gain.
"""

from __future__ import annotations

import math

from .compiled import is_compiled, source_module

# The readout's inference of the steady reading (see :class:`SteadyInference`).
#: An inferred steady reading is trusted ("ok", "below_detection", "saturated") only while it
#: amplifies the lock-in's noise at most this much: its uncertainty carries the gain, so the
#: controller sees the cost of reading a resonator that has not settled.
MAX_GAIN = 10.0
#: ...and never reports less than this many single readings' noise.  A window of many readings
#: averages the noise down, but it cannot see a load change in its last few readings (with
#: Table I's damping a ramp that starts moves the envelope by under one sigma in its first ten
#: readings while the steady value has moved by several): the floor is the allowance for that
#: latency, measured by tests/test_readout_honesty.py (coverage of "ok" intervals).
GAIN_FLOOR = 2.0
#: The inference window: at most this long, s.  Long enough that a held load near unloaded
#: (the slowest envelope, tau0 = 0.66 s with Table I's damping) is inferred to better than
#: GAIN_FLOOR, with the load's ramp as a free parameter.
WINDOW_S = 0.5
#: ...at least this long while the load ramps, s.
MIN_WINDOW_S = 0.02
#: While the load ramps (significantly), the window spans at most this fraction of the time in
#: which the ramp would change the gel's modal load (mu - 1, below) by its own size, so that
#: the linear-in-time model of the load holds over the window (its error is about
#: fraction^2 / 12 of the load, 0.08 % at 0.1).
RAMP_WINDOW_FRACTION = 0.1
#: A ramp is significant at this chi-square (2 degrees of freedom: exceeded by chance 4e-6 of the
#: time, about 5 sigma; a looser test shortens the window of a held load by chance).
_RAMP_CHI2 = 25.0
#: A reading taken while the window's ramp passes this chi-square, with the window reaching back
#: past the span the ramp allows (RAMP_WINDOW_FRACTION), is reported "settling": the load
#: changes under it, and the window may hold the ramp's onset, which the linear-in-time model
#: does not (issue 29: "a reading taken across a load change is settling, not ok").  Once the
#: window lies within the ramp's own span the model holds over it (its error fraction^2 / 12
#: of the load), and the reading is trusted: a load that creeps, as MuJoCo's soft dry friction
#: lets a friction drive's contact creep for seconds, read "settling" all through (a ramp of
#: 10 % a second: 5 % of its readings trusted, now 99 %, every one within 3 sigma of the
#: truth: tests/test_readout_ramps.py).  12 with 2 degrees of freedom is exceeded by chance
#: e^-6 = 0.25 % of the time, the change test's own SUSPECT_STAT rate: a held load still reads
#: "ok" 99 % of the time.  Over the scenario library the 3-sigma coverage of "ok" readings,
#: load changes included, went from 98.9 % to 99.3 % with the rule; over the hold-out grasps
#: (reports/coverage.py) from 99.15 % to 99.5 %.
RAMP_SUSPECT_CHI2 = 12.0
#: ...and its relative rate is taken against a modal load of at least this (|mu - 1| of a load
#: about ten times the noise: a ramp from unloaded does not shrink the window to nothing).
_MIN_LOAD = 0.01
#: The change test's statistics are Exp(1) under a steady (or steadily ramping) load: a reading
#: whose statistic passes CHANGE_STAT (by chance 6e-6 per look-back) restarts the inference at
#: the change; one past SUSPECT_STAT (0.25 % per look-back: a held load reads "ok" 99 % of the
#: time) is itself reported "settling" but does not restart.
CHANGE_STAT = 12.0
SUSPECT_STAT = 6.0
#: The change test looks back over the last 1, 3, 5, 9 and 27 readings
_SCALES = (1, 3, 5, 9, 27)
#: (the longest look-back's statistic runs about 1.2 to 1.5 times Exp(1) under a held load -- the
#: fit's extrapolation over 27 readings is a little worse than the white-noise formula says -- so
#: it suspects a change at a correspondingly higher threshold).
_SUSPECT_STAT_LONGEST = 7.5
#: ...the latest reading on every reading, the longer look-backs in turn (the per-reading cost:
#: two or three of them a reading; the coverage measured with all five every reading is the same).
_SCALE_TURNS = ((1, 5), (1, 3, 9), (1, 5, 27), (1, 3))
#: Weight of the integrated noise in the fit's residual (see SteadyInference, "noise").
_INTEGRATED_NOISE = 0.05
#: The inferred load mu (and so 1 / mu) is trusted only while known to this fraction (1 sigma):
#: beyond, the first-order uncertainty of 1 / mu no longer describes it.
_MAX_REL = 0.1
#: The window keeps at least this many readings however short it is.
_MIN_SAMPLES = 6
#: An inference older than this re-bases its integrals on its window (precision), s.
_REBASE_S = 30.0
_MAX_REL_SQ = _MAX_REL * _MAX_REL
_TWELFTH = 1.0 / 12.0
_NAN_ENVELOPE = complex(math.nan, math.nan)


def change_detection_s(mu_rate_per_s: float, tau0_s: float, sigma: float, reading_period_s: float) -> float:
    """How long after a load starts to ramp from none the readout's change test flags it
    ("settling"), s, with its readings ``reading_period_s`` apart (s), their noise ``sigma`` (V_1
    units, on each of I and Q), the unloaded envelope time constant ``tau0_s`` (s) and the ramp's
    rate of the load's complex factor, ``mu_rate_per_s`` = |d mu / dt| (1/s; mu = 1 / steady
    envelope, :class:`SteadyInference`).

    The envelope obeys tau0 a' = 1 - mu a; from rest unloaded (a = 1), a ramp mu = 1 + mu' t
    moves tau0 a off the steady fit's prediction by int_0^t (mu - 1) a dt = mu' t^2 / 2 (while
    mu' t << 1).  The change test sums the prediction errors of the last m readings against
    their noise, tau0 sigma each (physics.md section 6; the integrals' noise is small at
    tau0 >> dt): with m = t / dt readings over the ramp, |sum| = mu' t^3 / (6 dt), and its
    statistic |sum|^2 / (2 m tau0^2 sigma^2) = mu'^2 t^5 / (72 dt tau0^2 sigma^2) passes
    SUSPECT_STAT at

        t_d = (72 SUSPECT_STAT dt tau0^2 sigma^2 / mu'^2)^(1/5).

    The readout's own flag comes within a reading before it noise-free, and with noise at most a
    reading after it (sooner at the median, by a reading or two): when a touch is seen, to within
    a reading (tests/test_readout_ramps.py::test_the_change_tests_latency_on_a_ramp_from_no_load).  So a
    ramp from no load is seen after a time that falls only as its rate to the -2/5: a touch at
    Table I's damping is flagged 15-40 ms after it starts, where the steady readout sees it within
    a reading.  Infinite for no ramp."""
    for name, value in (("tau0_s", tau0_s), ("sigma", sigma), ("reading_period_s", reading_period_s)):
        if not (math.isfinite(value) and value > 0.0):
            raise ValueError(f"{name} must be positive and finite, got {value!r}")
    if not (mu_rate_per_s >= 0.0):
        raise ValueError(f"mu_rate_per_s must be non-negative, got {mu_rate_per_s!r}")
    if mu_rate_per_s == 0.0:
        return math.inf
    return (72.0 * SUSPECT_STAT * reading_period_s * (tau0_s * sigma / mu_rate_per_s) ** 2) ** 0.2


def __getattr__(name: str):
    if name == "PySteadyInference":  # the kernel's source run as Python, loaded when asked for
        return source_module(_inference.__name__).SteadyInference
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


# The inference the readout uses (a kernel, sensor/_inference.py, compiled where built; the same
# results bit for bit as its source run as Python: tests/test_compiled_twins.py).  Imported last:
# it reads the constants above.
from . import _inference  # noqa: E402
from ._inference import SteadyInference  # noqa: E402, F401  (the readout's, re-exported)

#: Whether :class:`SteadyInference` runs compiled (sensor/_inference.py built), not as Python.
COMPILED = is_compiled(_inference)
