"""The readout's inference of the steady reading from a resonator that has not settled.

With resonator dynamics a reading lags the load by the envelope's time constant (0.66 s with
Table I's damping, physics.md section 6), so the readout infers the steady reading of the
present load from its recent readings: :class:`SteadyInference`, a least-squares fit of the
envelope's own equation over a window, restarted when a change test says the load changed.

:class:`PySteadyInference` is the inference in Python, the reference that documents it;
``sensor/_inference.pyx`` is the same class compiled (C ring buffers instead of deques of
tuples, the same operations in the same order), 11 -> 0.5 us a reading.
:data:`SteadyInference` is the compiled class where the package was built with it (``pip
install`` builds it; :data:`COMPILED` says), else the reference; ``PIEZOTIP_PURE_PYTHON=1``
makes the readout use the reference (:mod:`sensor.compiled`).
:class:`sensor.channel.SensorChannel` feeds it the lock-in's readings and hands its steady
reading to the estimator (:meth:`sensor.estimator.ModeInverse.inferred`) with its noise gain.
"""

from __future__ import annotations

import math
from collections import deque

from .compiled import twin

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
#: A reading taken while the window's ramp passes this chi-square is reported "settling": the
#: load is changing under it, and the linear-in-time model's steady reading is then no better
#: than the load's change over the readout's detection horizon, which the uncertainty does not
#: carry (issue 29: "a reading taken across a load change is settling, not ok").  12 with 2
#: degrees of freedom is exceeded by chance e^-6 = 0.25 % of the time, the change test's own
#: SUSPECT_STAT rate: a held load still reads "ok" 99 % of the time.  Over the scenario library
#: the 3-sigma coverage of "ok" readings, load changes included, went from 98.9 % to 99.3 %;
#: over the hold-out grasps (analysis/coverage.py) from 99.15 % to 99.5 %.
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
#: The prefix sums of a sample before any (index 5.. of a sample tuple, see SteadyInference).
_NO_SUMS = (0.0, 0j, 0j, 0j, 0j, 0j, 0j, 0j, 0.0, 0.0, 0j, 0j, 0j)


class PySteadyInference:
    """The readout's inference of the steady reading from the lock-in's recent readings (one mode).

    The reference implementation; the readout uses :data:`SteadyInference`, its compiled twin
    (``sensor/_inference.pyx``, the same arithmetic in C, bit for bit) where it is built.

    The problem (physics.md section 6): driven at a fixed frequency, the envelope a(t) relaxes
    toward the steady envelope a_ss of the present load with the complex rate lambda, and both
    are fixed by one unknown, the gel's load on the mode: a_ss = 1 / mu and
    lambda = mu / tau0, with mu = 1 + gamma / c - j kappa / (omega c) and tau0 = 2 rho A / c
    the unloaded time constant (:func:`sensor.readout.ring_up_steady`).  So the envelope obeys

        tau0 a'(t) = 1 - mu(t) a(t)

    for any load history, and a_ss(t) = 1 / mu(t) is what the readout wants, now.  With Table
    I's damping tau0 = 0.66 s: a reading settles seconds after the load changes, so the readout
    must infer mu from how the envelope moves, not wait.

    The model: over a window of recent readings the load is steady or ramps,
    mu(t) = alpha + mu1 (t - t_r).  Integrated from the segment's start t_s,

        tau0 a_k - (t_k - t_r) = c - alpha X1_k - mu1 X2_k,
        X1_k = int_{t_s}^{t_k} a dt,  X2_k = int_{t_s}^{t_k} (t - t_r) a dt,

    is linear in (c, alpha, mu1) (c = tau0 a(t_s), unknown, or 0 for a ring-up from rest after a
    switch), exact for any decay rate while the integrals are (a three-point rule on the
    readings, exact to (lambda dt)^4).  A complex least-squares fit over the window, from running
    sums (a few complex operations per reading), gives mu(now) = alpha + mu1 (now - t_r) and its
    variance, hence a_ss = 1 / mu and its noise in units of a reading's sigma (the "gain").

    Noise: a reading's noise sigma enters tau0 a_k (white, tau0 sigma) and the integrals
    (a random walk of steps sigma dt, weighted by mu).  The fit's parameters are given the
    variance of a white residual sigma^2 (tau0^2 + 0.05 |mu|^2 W^2) (W the window's span): the
    second term is what the integrated noise adds to a least-squares slope's variance (0.05 =
    0.6 / 12, from the fitted slope of a random walk); it matters only for fast decay
    (|mu| W >> tau0: a realistic Q, or a heavy load).  Checked: the inferred |a_ss| scatters by
    0.9 of its stated sigma with Table I's damping, 0.75 with Q = 70 (tests/test_readout_honesty.py).

    The window: at most WINDOW_S, shortened while the load ramps (RAMP_WINDOW_FRACTION), and
    restarted when the load changes.  The change test: the last m = 1, 3, 5, 9, 27 readings are
    predicted with the fit made just before them (so a change has not pulled it yet) and the
    mean prediction error, normalized by its variance (the readings' own noise through tau0 a
    and the integrals, sigma^2 sum_l |tau0 + mu dt (l - 1/2)|^2, plus the old fit's error at
    them), is Exp(1)-distributed while the load holds or ramps steadily (measured means 1.0 to
    1.07 for m <= 9, 1.2 to 1.5 for m = 27).  Past CHANGE_STAT the window restarts at the
    change (the last m readings); past SUSPECT_STAT this reading is reported "settling".

    :meth:`step` returns (a_ss, gain, trusted): ``trusted`` is False while the window is too
    young for a fit, the last readings suggest a change, the load ramps under the reading
    (RAMP_SUSPECT_CHI2), or mu is known to worse than _MAX_REL; the caller also requires
    gain <= MAX_GAIN.

    Settling time (the contract's, in code): after a load change, the time from the change
    until this inference is trusted again with gain <= MAX_GAIN, i.e. until it has detected the
    change and its restarted window pins mu down.  It is set by tau0, the readings' noise and
    the size of the change, not by the envelope's own decay (seconds with Table I's damping).
    Measured at 5 ms readings (tests/test_readout_honesty.py): after the load is removed, 0.17 to
    0.37 s with Table I's damping (0.22 s for 1400 Pa in mode 2; longer from heavier loads,
    whose envelope starts far from unloaded), 20 ms (4 readings) with Q = 70; a ring-up after a
    switch, 0.06 to 0.35 s and 10 to 45 ms.
    """

    __slots__ = (
        "base",
        "c_known",
        "fits",
        "half_sig_sq",
        "q1",
        "q2",
        "samples",
        "sig_sq",
        "sig_sq_tau0",
        "sig_sq_tau0_sq",
        "sigma",
        "tau0",
        "tau0_sq",
        "tr",
        "turn",
        "w_target",
    )

    def __init__(self, tau0_s: float, sigma: float) -> None:
        self.tau0, self.tau0_sq, self.sigma = tau0_s, tau0_s * tau0_s, sigma
        # The noise terms' constant factors, once (the same products _fit formed every reading:
        # sigma^2, sigma^2 tau0, sigma^2 tau0^2 and sigma^2 / 2, left to right as written there).
        self.sig_sq = sig_sq = sigma * sigma
        self.sig_sq_tau0, self.sig_sq_tau0_sq, self.half_sig_sq = sig_sq * tau0_s, sig_sq * self.tau0_sq, 0.5 * sig_sq
        # Per reading in the window: (t, a, X1, X2, Y, then the running sums since the segment's
        # start of X1, X2, Y, |X1|^2, |X2|^2, conj(X1) X2, conj(X1) Y, conj(X2) Y); the window's
        # sums are the last reading's minus ``base``'s (the reading before the window).
        self.samples: deque[tuple] = deque()
        self.turn = 0  # which of the longer look-backs the change test takes this reading
        # The fit made after each of the last readings: (c, b1, b2, residual variance, 1 / n,
        # the regressors' means and centered sums, and their determinant).
        self.fits: deque[tuple | None] = deque(maxlen=_SCALES[-1] + 1)
        self.restart(0.0, None)

    def restart(self, t_ref: float, a_start: complex | None) -> None:
        """A new segment at ``t_ref``: from a known envelope ``a_start`` (0 after a switch), or
        from the next reading (``None``: the envelope there is a free parameter)."""
        self.samples.clear()
        self.fits.clear()
        self.base = _NO_SUMS
        self.tr = t_ref
        self.c_known = None if a_start is None else self.tau0 * a_start
        self.q1 = None if a_start is None else (t_ref, a_start, 0j, 0j)  # last point: t, a, X1, X2
        self.q2 = None  # the point before: t, a
        self.w_target = WINDOW_S

    def seed(self, a: complex, t_end: float, dt_s: float) -> None:
        """Fill the window with a settled history (the instrument ran unloaded before the scene)."""
        n = int(WINDOW_S / dt_s)
        self.restart(t_end - n * dt_s, None)
        for k in range(n + 1):
            self._append(t_end - (n - k) * dt_s, a)
        self.fits.append(self._fit(t_end)[-1])

    def _integrate(self, t: float, a: complex) -> tuple[complex, complex, complex]:
        """(X1, X2, Y) of a reading ``a`` at ``t`` (the integrals continued from the last reading)."""
        tr, q1 = self.tr, self.q1
        if q1 is None:
            x1 = x2 = 0j
        else:
            tp, ap, x1, x2 = q1
            h = t - tp
            q2 = self.q2
            if q2 is not None and abs(tp - q2[0] - h) <= 1e-6 * h:  # three-point rule (uniform steps)
                tq, aq = q2
                x1 = x1 + h * (5.0 * a + 8.0 * ap - aq) * _TWELFTH
                x2 = x2 + h * (5.0 * (t - tr) * a + 8.0 * (tp - tr) * ap - (tq - tr) * aq) * _TWELFTH
            else:
                x1 = x1 + 0.5 * h * (a + ap)
                x2 = x2 + 0.5 * h * ((t - tr) * a + (tp - tr) * ap)
            self.q2 = (tp, ap)
        self.q1 = (t, a, x1, x2)
        return x1, x2, self.tau0 * a - (t - tr)

    def _append(self, t: float, a: complex) -> tuple:
        """Integrate to ``t`` and add the reading to the window's sums; returns its tuple."""
        x1, x2, y = self._integrate(t, a)
        return self._add(t, a, x1, x2, y)

    def _add(self, t: float, a: complex, x1: complex, x2: complex, y: complex) -> tuple:
        """Add an integrated reading to the window."""
        samples = self.samples
        s = samples[-1] if samples else self.base
        c1, c2 = x1.conjugate(), x2.conjugate()
        new = (
            t,
            a,
            x1,
            x2,
            y,
            s[5] + x1,
            s[6] + x2,
            s[7] + y,
            s[8] + (x1.real * x1.real + x1.imag * x1.imag),
            s[9] + (x2.real * x2.real + x2.imag * x2.imag),
            s[10] + c1 * x2,
            s[11] + c1 * y,
            s[12] + c2 * y,
        )
        samples.append(new)
        return new

    def _fit(self, t: float) -> tuple:
        """Least squares over the window: (mu(t), |mu(t)|^2, its variance, ramp chi-square, |mu1|^2,
        fit record) (|mu1|^2, not |mu1|: its root is wanted only while the load ramps).

        The record keeps what the change test needs to predict the next readings: the
        coefficients (c, b1, b2), 1 / n and the regressors' means (0 with a known start), the
        inverse of their centered sums as (C22, C11, 2 C12) / det, and the noise terms below.
        """
        samples, b = self.samples, self.base
        last = samples[-1]
        n = len(samples)
        s1, s2, sy = last[5] - b[5], last[6] - b[6], last[7] - b[7]
        c = self.c_known
        if c is not None:  # known start: no intercept
            if n < 2:
                return None, math.nan, math.inf, 0.0, 0.0, None
            c11, c22, c12 = last[8] - b[8], last[9] - b[9], last[10] - b[10]
            c1y = last[11] - b[11] - s1.conjugate() * c
            c2y = last[12] - b[12] - s2.conjugate() * c
            m1 = m2 = 0j
            inv_n = 0.0
        else:
            if n < 4:
                return None, math.nan, math.inf, 0.0, 0.0, None
            inv_n = 1.0 / n
            m1, m2, my = s1 * inv_n, s2 * inv_n, sy * inv_n
            m1c, m2c = m1.conjugate(), m2.conjugate()
            c11 = last[8] - b[8] - (s1.real * m1.real + s1.imag * m1.imag)
            c22 = last[9] - b[9] - (s2.real * m2.real + s2.imag * m2.imag)
            c12 = last[10] - b[10] - m1c * s2
            c1y = last[11] - b[11] - m1c * sy
            c2y = last[12] - b[12] - m2c * sy
        det = c11 * c22 - (c12.real * c12.real + c12.imag * c12.imag)
        if not det > 0.0:
            return None, math.nan, math.inf, 0.0, 0.0, None
        inv_det = 1.0 / det
        b1 = (c22 * c1y - c12 * c2y) * inv_det
        b2 = (c11 * c2y - c12.conjugate() * c1y) * inv_det
        if c is None:
            c = my - b1 * m1 - b2 * m2
        tp = samples[-2][0] if n > 1 else t
        h = t - tp
        # The load over the last sample period (held over it, as the co-simulation holds the
        # pad's pressure): mu at its middle.
        d = 0.5 * (t + tp) - self.tr
        mu = -(b1 + b2 * d)
        width = t - samples[0][0]
        mu_sq = mu.real * mu.real + mu.imag * mu.imag
        sig_sq = self.sig_sq
        s2_res = sig_sq * (self.tau0_sq + _INTEGRATED_NOISE * mu_sq * width * width)
        var_mu = s2_res * (c22 + d * d * c11 - 2.0 * d * c12.real) * inv_det
        b2_sq = b2.real * b2.real + b2.imag * b2.imag
        ramp_chi2 = b2_sq * det / (s2_res * c11) if c11 > 0 else 0.0
        # For the change test: the noise of the residuals of a block of m new readings,
        # sigma^2 sum_l |tau0 + mu h (l - 1/2)|^2 (a reading enters tau0 a and, through the
        # integral, every later X1) ~ m (n0 + m (n1 + m n2)); and the fit's own error at them,
        # n_fit (m^2 / n + q) with q the quadratic form of the block's centered regressors
        # (the residual level n_fit: tau0^2 plus the integrated noise over the window).
        record = (
            c,
            b1,
            b2,
            inv_n,
            m1,
            m2,
            c22 * inv_det,
            c11 * inv_det,
            2.0 * c12 * inv_det,
            self.sig_sq_tau0_sq,
            self.sig_sq_tau0 * mu.real * h,
            self.half_sig_sq * mu_sq * h * h,
            sig_sq * (self.tau0_sq + mu_sq * h * width),
        )
        return mu, mu_sq, var_mu, ramp_chi2, b2_sq, record

    def step(self, t: float, a: complex) -> tuple[complex, float, bool]:
        """Take the lock-in's reading ``a`` at time ``t``; return (a_ss, gain, trusted)."""
        if t - self.tr > _REBASE_S and self.samples:
            self._replay([(s[0], s[1]) for s in self.samples])
        samples, fits = self.samples, self.fits
        x1, x2, y = self._integrate(t, a)
        trusted = True
        n_f = len(fits)
        if n_f and fits[-1] is not None:
            # The change test, before the reading joins the fit: the last m readings predicted
            # with the fit made before them.
            last = samples[-1]
            n_s = len(samples)
            worst, worst_m = 0.0, 0
            self.turn = turn = (self.turn + 1) & 3
            for m in _SCALE_TURNS[turn]:
                if m > n_f or m > n_s:
                    break
                fit = fits[-m]
                if fit is None:
                    break
                c, b1, b2, inv_n, m1, m2, i11, i22, i12, n0, n1, n2, n_fit = fit
                if m == 1:
                    g1, g2, r = x1 - m1, x2 - m2, y - c - b1 * x1 - b2 * x2
                else:
                    ref = samples[-m]
                    g1, g2 = last[5] - ref[5] + x1, last[6] - ref[6] + x2
                    r = (last[7] - ref[7] + y) - m * c - b1 * g1 - b2 * g2
                    g1, g2 = g1 - m * m1, g2 - m * m2
                w = i12 * g2
                q = (
                    i11 * (g1.real * g1.real + g1.imag * g1.imag)
                    + i22 * (g2.real * g2.real + g2.imag * g2.imag)
                    - (g1.real * w.real + g1.imag * w.imag)
                )
                stat = (r.real * r.real + r.imag * r.imag) / (2.0 * (m * (n0 + m * (n1 + m * n2)) + n_fit * (m * m * inv_n + q)))
                if stat > worst:
                    worst, worst_m = stat, m
            if worst > CHANGE_STAT:
                # Restart at the change: the last worst_m readings (this one included) follow it.
                keep = [(s[0], s[1]) for s in list(samples)[n_s - worst_m + 1 :]] if worst_m > 1 else []
                keep.append((t, a))
                self._replay(keep)
                return _NAN_ENVELOPE, math.inf, False
            trusted = worst <= (SUSPECT_STAT if worst_m < _SCALES[-1] else _SUSPECT_STAT_LONGEST)
        self._add(t, a, x1, x2, y)  # the reading into the window's running sums
        w_target = self.w_target
        while t - samples[0][0] > w_target and len(samples) > _MIN_SAMPLES:
            self.base = samples.popleft()
            self.c_known = None  # the window no longer starts at the known start
        mu, mu_sq, var_mu, ramp_chi2, ramp_rate_sq, record = self._fit(t)
        fits.append(record)
        if record is None:
            return _NAN_ENVELOPE, math.inf, False
        if ramp_chi2 > RAMP_SUSPECT_CHI2:
            trusted = False  # the load changes under this reading (RAMP_SUSPECT_CHI2)
        # Shorten the window while the load ramps (see RAMP_WINDOW_FRACTION).
        if ramp_chi2 > _RAMP_CHI2:
            load = abs(mu - 1.0)
            w = RAMP_WINDOW_FRACTION * (load if load > _MIN_LOAD else _MIN_LOAD) / math.sqrt(ramp_rate_sq)
            self.w_target = WINDOW_S if w > WINDOW_S else (MIN_WINDOW_S if w < MIN_WINDOW_S else w)
        elif w_target != WINDOW_S:
            self.w_target = WINDOW_S
        if not var_mu < _MAX_REL_SQ * mu_sq:
            return (1.0 / mu if mu_sq > 0 else _NAN_ENVELOPE), math.inf, False
        return 1.0 / mu, math.sqrt(var_mu) / (mu_sq * self.sigma), trusted

    def _replay(self, readings: list[tuple[float, complex]]) -> None:
        """Restart the segment at the first of ``readings`` (envelope unknown there) and refit."""
        self.restart(readings[0][0], None)
        for t, a in readings:
            self._append(t, a)
        self.fits.append(self._fit(readings[-1][0])[-1])


#: The inference the readout uses: the compiled twin of :class:`PySteadyInference` where it is
#: built (same results bit for bit: tests/test_compiled_twins.py), else the reference
#: (:mod:`sensor.compiled`); :data:`COMPILED` says which.
SteadyInference, COMPILED = twin("piezotip.sensor._inference", "SteadyInference", PySteadyInference)
