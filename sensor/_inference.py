"""The readout's inference of the steady reading from a resonator that has not settled (see :mod:`sensor.inference`).

A kernel (:mod:`sensor.compiled`): this module runs as Python and, where built, compiled
(``_inference.pxd`` types it: the window's readings and fits are objects with C fields, their
complex numbers C complex numbers, held in lists).  The constants are :mod:`sensor.inference`'s
(one owner for each value), read when this module is imported: its names for them are this
module's globals, which a test may change (in the source run as Python; compiled, they are C
constants).
"""

from __future__ import annotations

import math

from piezotip.sensor import _kernel_helpers as kh
from piezotip.sensor.inference import (
    _INTEGRATED_NOISE,
    _MAX_REL_SQ,
    _MIN_LOAD,
    _MIN_SAMPLES,
    _NAN_ENVELOPE,
    _RAMP_CHI2,
    _REBASE_S,
    _SCALE_TURNS,
    _SCALES,
    _SUSPECT_STAT_LONGEST,
    _TWELFTH,
    CHANGE_STAT,
    MIN_WINDOW_S,
    RAMP_SUSPECT_CHI2,
    RAMP_WINDOW_FRACTION,
    SUSPECT_STAT,
    WINDOW_S,
)

#: The change test's longest look-back, readings.
_LONGEST = _SCALES[-1]
_INF = math.inf  # (compiled, a C double: no lookup of math's)


class _Sample:
    """One reading in the window: its time t (s) and envelope a, and the running sums since the
    segment's start of its integrals X1, X2, Y (:meth:`SteadyInference._integrate`), |X1|^2,
    |X2|^2, conj(X1) X2, conj(X1) Y and conj(X2) Y (s1 ... s2y): the window's sums are its
    newest sample's less its base's (the sample before the window).  Not changed once made."""

    __slots__ = ("a", "s1", "s1y", "s2", "s2y", "s11", "s12", "s22", "sy", "t")


def _zero_sample() -> _Sample:
    """The sums before any reading (a segment's first base)."""
    s = _Sample.__new__(_Sample)
    s.t, s.a = 0.0, 0j
    s.s1, s.s2, s.sy, s.s11, s.s22, s.s12, s.s1y, s.s2y = 0j, 0j, 0j, 0.0, 0.0, 0j, 0j, 0j
    return s


_NO_SUMS = _zero_sample()


class _Fit:
    """The least-squares fit over the window after one reading (:meth:`SteadyInference._fit`):
    mu(t), |mu(t)|^2, its variance, the ramp's chi-square and |mu1|^2; and what the change test
    needs to predict the next readings: the coefficients (c, b1, b2), 1 / n and the regressors'
    means m1, m2 (0 with a known start), the inverse of their centered sums as (C22, C11,
    2 C12) / det (i11, i22, i12), and the noise terms n0, n1, n2 and n_fit."""

    __slots__ = (
        "b1",
        "b2",
        "b2_sq",
        "c",
        "i11",
        "i12",
        "i22",
        "inv_n",
        "m1",
        "m2",
        "mu",
        "mu_sq",
        "n0",
        "n1",
        "n2",
        "n_fit",
        "ramp_chi2",
        "var_mu",
    )


class SteadyInference:
    """The readout's inference of the steady reading from the lock-in's recent readings (one mode).

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
        "first",
        "fits",
        "half_sig_sq",
        "has_q1",
        "has_q2",
        "known_start",
        "q1_a",
        "q1_t",
        "q1_x1",
        "q1_x2",
        "q2_a",
        "q2_t",
        "samples",
        "sig_sq",
        "sig_sq_tau0",
        "sig_sq_tau0_sq",
        "sigma",
        "spare_fits",
        "spare_samples",
        "tau0",
        "tau0_sq",
        "tr",
        "turn",
        "w_target",
    )

    def __init__(self, tau0_s: float, sigma: float) -> None:
        tau0_s, sigma = float(tau0_s), float(sigma)
        self.tau0, self.tau0_sq, self.sigma = tau0_s, tau0_s * tau0_s, sigma
        # The noise terms' constant factors, once (the same products _fit formed every reading:
        # sigma^2, sigma^2 tau0, sigma^2 tau0^2 and sigma^2 / 2, left to right as written there).
        self.sig_sq = sig_sq = sigma * sigma
        self.sig_sq_tau0, self.sig_sq_tau0_sq, self.half_sig_sq = sig_sq * tau0_s, sig_sq * self.tau0_sq, 0.5 * sig_sq
        # The window's readings (_Sample), oldest first, from samples[first] on (the ones before
        # it have left the window; dropped from the list now and then).
        self.samples: list[_Sample] = []
        self.first = 0
        self.turn = 0  # which of the longer look-backs the change test takes this reading
        self.fits = []  # the fit made after each of the last readings (_Fit, or None; _add_fit)
        # Fits and readings that have left the window, made again in place of new ones (no
        # allocation a reading: _fit, _add); nothing else holds them.
        self.spare_fits, self.spare_samples = [], []
        self.restart(0.0, None)

    def restart(self, t_ref: float, a_start: complex | None = None) -> None:
        """A new segment at ``t_ref``: from a known envelope ``a_start`` (0 after a switch), or
        from the next reading (``None``: the envelope there is a free parameter)."""
        t_ref = float(t_ref)
        if a_start is not None:
            a_start = kh.as_complex(a_start)
        self.samples, self.first = [], 0
        self.fits = []
        self.base = _NO_SUMS  # the sample before the window
        self.tr = t_ref
        # A known start: the fit's intercept c = tau0 a_start, known.
        self.known_start = a_start is not None
        if a_start is not None:
            self.c_known = self.tau0 * a_start
            self.q1_t, self.q1_a, self.q1_x1, self.q1_x2 = t_ref, a_start, 0j, 0j
        # The last point integrated (t, a, X1, X2), and the point before it (t, a).
        self.has_q1, self.has_q2 = self.known_start, False
        self.w_target = WINDOW_S

    def seed(self, a: complex, t_end: float, dt_s: float) -> None:
        """Fill the window with a settled history (the instrument ran unloaded before the scene)."""
        a, t_end, dt_s = kh.as_complex(a), float(t_end), float(dt_s)
        n = int(WINDOW_S / dt_s)
        self.restart(t_end - n * dt_s, None)
        for k in range(n + 1):
            self._append(t_end - (n - k) * dt_s, a)
        self._add_fit(self._fit(t_end))

    def _size(self) -> int:
        """The number of readings in the window."""
        return len(self.samples) - self.first

    def _sample(self, i: int) -> _Sample:
        """The window's i-th reading (0 the oldest, -1 the newest)."""
        return self.samples[i] if i < 0 else self.samples[self.first + i]

    def _past_fit(self, m: int) -> _Fit | None:
        """The fit made m readings ago (1: after the last reading)."""
        return self.fits[-m]

    def _add_fit(self, fit: _Fit | None) -> None:
        """Keep the fit made after the last reading: ``fits`` holds at least the last _LONGEST
        + 1 (the change test looks back at most _LONGEST), older ones dropped now and then."""
        self.fits.append(fit)
        if len(self.fits) > 2 * (_LONGEST + 1):
            self.spare_fits.extend([f for f in self.fits[: _LONGEST + 1] if f is not None])
            del self.fits[: _LONGEST + 1]

    def _drop_oldest(self) -> None:
        """The window's oldest reading leaves it, and becomes its base."""
        self.base = self.samples[self.first]
        self.first += 1
        if self.first >= 64 and 2 * self.first >= len(self.samples):  # the readings before the window go
            self.spare_samples.extend(self.samples[: self.first - 1])  # (not the base, the last of them)
            del self.samples[: self.first]
            self.first = 0

    def _integrate(self, t: float, a: complex) -> tuple[complex, complex, complex]:
        """(X1, X2, Y) of a reading ``a`` at ``t`` (the integrals continued from the last reading)."""
        tr = self.tr
        if not self.has_q1:
            x1 = x2 = 0j
        else:
            tp, ap, x1, x2 = self.q1_t, self.q1_a, self.q1_x1, self.q1_x2
            h = t - tp
            if self.has_q2 and abs(tp - self.q2_t - h) <= 1e-6 * h:  # three-point rule (uniform steps)
                tq, aq = self.q2_t, self.q2_a
                x1 = x1 + h * (5.0 * a + 8.0 * ap - aq) * _TWELFTH
                x2 = x2 + h * (5.0 * (t - tr) * a + 8.0 * (tp - tr) * ap - (tq - tr) * aq) * _TWELFTH
            else:
                x1 = x1 + 0.5 * h * (a + ap)
                x2 = x2 + 0.5 * h * ((t - tr) * a + (tp - tr) * ap)
            self.q2_t, self.q2_a, self.has_q2 = tp, ap, True
        self.q1_t, self.q1_a, self.q1_x1, self.q1_x2, self.has_q1 = t, a, x1, x2, True
        return x1, x2, self.tau0 * a - (t - tr)

    def _append(self, t: float, a: complex) -> None:
        """Integrate to ``t`` and add the reading to the window's sums."""
        x1, x2, y = self._integrate(t, a)
        self._add(t, a, x1, x2, y)

    def _add(self, t: float, a: complex, x1: complex, x2: complex, y: complex) -> None:
        """Add an integrated reading to the window."""
        s = self._sample(-1) if self._size() else self.base
        c1, c2 = x1.conjugate(), x2.conjugate()
        new = self.spare_samples.pop() if self.spare_samples else _Sample.__new__(_Sample)
        new.t, new.a = t, a
        new.s1, new.s2, new.sy = s.s1 + x1, s.s2 + x2, s.sy + y
        new.s11 = s.s11 + (x1.real * x1.real + x1.imag * x1.imag)
        new.s22 = s.s22 + (x2.real * x2.real + x2.imag * x2.imag)
        new.s12, new.s1y, new.s2y = s.s12 + c1 * x2, s.s1y + c1 * y, s.s2y + c2 * y
        self.samples.append(new)

    def _fit(self, t: float) -> _Fit | None:
        """Least squares over the window at ``t``: the fit (None while the window is too young
        or its regressors are degenerate)."""
        b = self.base
        last = self._sample(-1)
        n = self._size()
        s1, s2, sy = last.s1 - b.s1, last.s2 - b.s2, last.sy - b.sy
        if self.known_start:  # known start: no intercept
            if n < 2:
                return None
            c = self.c_known
            c11, c22, c12 = last.s11 - b.s11, last.s22 - b.s22, last.s12 - b.s12
            c1y = last.s1y - b.s1y - s1.conjugate() * c
            c2y = last.s2y - b.s2y - s2.conjugate() * c
            m1 = m2 = 0j
            inv_n = 0.0
        else:
            if n < 4:
                return None
            inv_n = 1.0 / n
            m1, m2, my = s1 * inv_n, s2 * inv_n, sy * inv_n
            m1c, m2c = m1.conjugate(), m2.conjugate()
            c11 = last.s11 - b.s11 - (s1.real * m1.real + s1.imag * m1.imag)
            c22 = last.s22 - b.s22 - (s2.real * m2.real + s2.imag * m2.imag)
            c12 = last.s12 - b.s12 - m1c * s2
            c1y = last.s1y - b.s1y - m1c * sy
            c2y = last.s2y - b.s2y - m2c * sy
        det = c11 * c22 - (c12.real * c12.real + c12.imag * c12.imag)
        if not det > 0.0:
            return None
        inv_det = 1.0 / det
        b1 = (c22 * c1y - c12 * c2y) * inv_det
        b2 = (c11 * c2y - c12.conjugate() * c1y) * inv_det
        if not self.known_start:
            c = my - b1 * m1 - b2 * m2
        tp = self._sample(-2).t if n > 1 else t
        h = t - tp
        # The load over the last sample period (held over it, as the co-simulation holds the
        # pad's pressure): mu at its middle.
        d = 0.5 * (t + tp) - self.tr
        mu = -(b1 + b2 * d)
        width = t - self._sample(0).t
        mu_sq = mu.real * mu.real + mu.imag * mu.imag
        sig_sq = self.sig_sq
        s2_res = sig_sq * (self.tau0_sq + _INTEGRATED_NOISE * mu_sq * width * width)
        f = self.spare_fits.pop() if self.spare_fits else _Fit.__new__(_Fit)
        f.mu, f.mu_sq = mu, mu_sq
        f.var_mu = s2_res * (c22 + d * d * c11 - 2.0 * d * c12.real) * inv_det
        f.b2_sq = b2.real * b2.real + b2.imag * b2.imag
        f.ramp_chi2 = f.b2_sq * det / (s2_res * c11) if c11 > 0 else 0.0
        f.c, f.b1, f.b2, f.inv_n, f.m1, f.m2 = c, b1, b2, inv_n, m1, m2
        f.i11, f.i22, f.i12 = c22 * inv_det, c11 * inv_det, 2.0 * c12 * inv_det
        # For the change test: the noise of the residuals of a block of m new readings,
        # sigma^2 sum_l |tau0 + mu h (l - 1/2)|^2 (a reading enters tau0 a and, through the
        # integral, every later X1) ~ m (n0 + m (n1 + m n2)); and the fit's own error at them,
        # n_fit (m^2 / n + q) with q the quadratic form of the block's centered regressors
        # (the residual level n_fit: tau0^2 plus the integrated noise over the window).
        f.n0 = self.sig_sq_tau0_sq
        f.n1 = self.sig_sq_tau0 * mu.real * h
        f.n2 = self.half_sig_sq * mu_sq * h * h
        f.n_fit = sig_sq * (self.tau0_sq + mu_sq * h * width)
        return f

    def step(self, t: float, a: complex) -> tuple[complex, float, bool]:
        """Take the lock-in's reading ``a`` at time ``t``; return (a_ss, gain, trusted)."""
        # A Python float and complex, as the compiled kernel's C double and complex are (NumPy's
        # scalars would carry NumPy's arithmetic through the window: its complex division rounds
        # differently from CPython's, kh.cquot's).
        t, a = float(t), kh.as_complex(a)
        if t - self.tr > _REBASE_S and self._size():
            self._replay([(self._sample(k).t, self._sample(k).a) for k in range(self._size())])
        x1, x2, y = self._integrate(t, a)
        trusted = True
        n_f = len(self.fits)
        if n_f and self._past_fit(1) is not None:
            # The change test, before the reading joins the fit: the last m readings predicted
            # with the fit made before them.
            last = self._sample(-1)
            n_s = self._size()
            worst, worst_m = 0.0, 0
            self.turn = turn = (self.turn + 1) & 3
            for m in _SCALE_TURNS[turn]:
                if m > n_f or m > n_s:
                    break
                fit = self._past_fit(m)
                if fit is None:
                    break
                c, b1, b2, inv_n, m1, m2 = fit.c, fit.b1, fit.b2, fit.inv_n, fit.m1, fit.m2
                i11, i22, i12, n0, n1, n2, n_fit = fit.i11, fit.i22, fit.i12, fit.n0, fit.n1, fit.n2, fit.n_fit
                if m == 1:
                    g1, g2, r = x1 - m1, x2 - m2, y - c - b1 * x1 - b2 * x2
                else:
                    ref = self._sample(-m)
                    g1, g2 = last.s1 - ref.s1 + x1, last.s2 - ref.s2 + x2
                    r = (last.sy - ref.sy + y) - m * c - b1 * g1 - b2 * g2
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
                keep = [(self._sample(k).t, self._sample(k).a) for k in range(n_s - worst_m + 1, n_s)] if worst_m > 1 else []
                keep.append((t, a))
                self._replay(keep)
                return _NAN_ENVELOPE, _INF, False
            trusted = worst <= (SUSPECT_STAT if worst_m < _LONGEST else _SUSPECT_STAT_LONGEST)
        self._add(t, a, x1, x2, y)  # the reading into the window's running sums
        w_target = self.w_target
        while t - self._sample(0).t > w_target and self._size() > _MIN_SAMPLES:
            self._drop_oldest()
            self.known_start = False  # the window no longer starts at the known start
        fit = self._fit(t)
        self._add_fit(fit)
        if fit is None:
            return _NAN_ENVELOPE, _INF, False
        if fit.ramp_chi2 > RAMP_SUSPECT_CHI2:
            trusted = False  # the load changes under this reading (RAMP_SUSPECT_CHI2)
        # Shorten the window while the load ramps (see RAMP_WINDOW_FRACTION).
        if fit.ramp_chi2 > _RAMP_CHI2:
            load = kh.cabs(fit.mu - 1.0)
            w_ramp = RAMP_WINDOW_FRACTION * (load if load > _MIN_LOAD else _MIN_LOAD) / kh.sqrt(fit.b2_sq)
            self.w_target = WINDOW_S if w_ramp > WINDOW_S else (MIN_WINDOW_S if w_ramp < MIN_WINDOW_S else w_ramp)
        elif w_target != WINDOW_S:
            self.w_target = WINDOW_S
        if not fit.var_mu < _MAX_REL_SQ * fit.mu_sq:
            return (kh.cquot(1.0, fit.mu) if fit.mu_sq > 0 else _NAN_ENVELOPE), _INF, False
        return kh.cquot(1.0, fit.mu), kh.sqrt(fit.var_mu) / (fit.mu_sq * self.sigma), trusted

    def _replay(self, readings: list[tuple[float, complex]]) -> None:
        """Restart the segment at the first of ``readings`` (envelope unknown there) and refit."""
        self.restart(readings[0][0], None)
        for t, a in readings:
            self._append(t, a)
        self._add_fit(self._fit(readings[-1][0]))
