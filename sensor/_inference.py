# cython: boundscheck=False, wraparound=False, initializedcheck=False
# (compiled, an index is not checked where it is read: every one lies in the window's rows or the
# ring of fits by construction, none is negative.)
"""The readout's inference of the steady reading from a resonator that has not settled (see :mod:`sensor.inference`).

A kernel (:mod:`sensor.compiled`): this module runs as Python and, where built, compiled
(``_inference.pxd`` types it: the window's readings and fits are rows of C doubles in two
buffers, :mod:`array` objects read through typed memoryviews, a complex number as its real and
imaginary parts).  The constants are :mod:`sensor.inference`'s (one owner for each value), read
when this module is imported: its names for them are this module's globals, which a test may
change (in the source run as Python; compiled, they are C constants).
"""

from __future__ import annotations

import math
from array import array

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
_LONGEST = max(_SCALES)
_INF = math.inf  # (compiled, a C double: no lookup of math's)

# The window's readings are rows of _ROW doubles in one buffer (a complex value its real part,
# then its imaginary part), a row a reading: its time t (s) and envelope a, and the running sums
# since the segment's start of its integrals X1, X2, Y (SteadyInference._integrate), |X1|^2,
# |X2|^2, conj(X1) X2, conj(X1) Y and conj(X2) Y (s1 ... s2y): the window's sums are its newest
# row's less its base's (the row before the window).  A row is not changed once written.  Each
# field's offset in a row:
_T, _A, _S1, _S2, _SY, _S11, _S22, _S12, _S1Y, _S2Y = 0, 1, 3, 5, 7, 9, 10, 11, 13, 15
_ROW = 17
#: A new buffer's rows, at least.
_MIN_ROWS = 64

# The fits made after the last readings (SteadyInference._fit) are rows of _FIT doubles in a
# ring of _FITS (a power of two past the longest look-back): whether a fit was made (1.0; 0.0
# while the window was too young or its regressors degenerate), and what the change test needs
# to predict the next readings: the coefficients (c, b1, b2), 1 / n and the regressors' means
# m1, m2 (0 with a known start), the inverse of their centered sums as (C22, C11, 2 C12) / det
# (i11, i22, i12), and the noise terms n0, n1, n2 and n_fit.  Each field's offset in a row:
_F_MADE, _F_C, _F_B1, _F_B2, _F_M1, _F_M2, _F_I12 = 0, 1, 3, 5, 7, 9, 11
_F_INV_N, _F_I11, _F_I22, _F_N0, _F_N1, _F_N2, _F_N_FIT = 13, 14, 15, 16, 17, 18, 19
_FIT = 20
_FITS = 1 << _LONGEST.bit_length()

#: The change test's look-backs by turn (_SCALE_TURNS), _TURN places a turn, 0 after its last.
_TURN = 1 + max(len(turn) for turn in _SCALE_TURNS)
_TURN_SCALES = [m for turn in _SCALE_TURNS for m in turn + (0,) * (_TURN - len(turn))]


def _cget(w, i: int) -> complex:
    """The complex number at ``w[i]`` (its real part) and ``w[i + 1]`` (its imaginary part)."""
    return kh.cx(w[i], w[i + 1])


def _cput(w, i: int, z: complex) -> None:
    """``z`` into ``w[i]`` (its real part) and ``w[i + 1]`` (its imaginary part)."""
    w[i] = z.real
    w[i + 1] = z.imag


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
    young for a fit, the last readings suggest a change, the load ramps under the reading with
    the window reaching back past the ramp's own span (RAMP_SUSPECT_CHI2), or mu is known to
    worse than _MAX_REL; the caller also requires
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
        "_b2_sq",
        "_fits",
        "_mu",
        "_mu_sq",
        "_ramp_chi2",
        "_rows",
        "_var_mu",
        "c_known",
        "end",
        "first",
        "half_sig_sq",
        "has_q1",
        "has_q2",
        "known_start",
        "n_fits",
        "q1_a",
        "q1_t",
        "q1_x1",
        "q1_x2",
        "q2_a",
        "q2_t",
        "ramp_from",
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
        tau0_s, sigma = float(tau0_s), float(sigma)
        self.tau0, self.tau0_sq, self.sigma = tau0_s, tau0_s * tau0_s, sigma
        # The noise terms' constant factors, once (the same products _fit formed every reading:
        # sigma^2, sigma^2 tau0, sigma^2 tau0^2 and sigma^2 / 2, left to right as written there).
        self.sig_sq = sig_sq = sigma * sigma
        self.sig_sq_tau0, self.sig_sq_tau0_sq, self.half_sig_sq = sig_sq * tau0_s, sig_sq * self.tau0_sq, 0.5 * sig_sq
        # The window's rows (C doubles, compiled), oldest first, from row ``first`` to row
        # ``end`` - 1; row ``first`` - 1 is its base.  The rows before the base have left the
        # window, dropped when the buffer is full (_grow): no allocation a reading.
        self._rows = array("d", bytes(8 * _ROW * _MIN_ROWS))
        self.first = self.end = 1
        self.turn = 0  # which of the longer look-backs the change test takes this reading
        # The fits made since the segment's start (n_fits of them), the last _FITS kept: the
        # k-th (from 0) in the ring's row k mod _FITS.
        self._fits = array("d", bytes(8 * _FIT * _FITS))
        self.n_fits = 0
        # The last fit's values that only its reading reads (_fit): mu, |mu|^2, its variance,
        # |mu1|^2 and the ramp's chi-square.
        self._mu, self._mu_sq, self._var_mu, self._b2_sq, self._ramp_chi2 = 0j, 0.0, 0.0, 0.0, 0.0
        # (Set before they are read: restart, _integrate.)
        self.c_known = self.q1_a = self.q1_x1 = self.q1_x2 = self.q2_a = 0j
        self.q1_t = self.q2_t = 0.0
        self.restart(0.0, None)

    def restart(self, t_ref: float, a_start: complex | None = None) -> None:
        """A new segment at ``t_ref``: from a known envelope ``a_start`` (0 after a switch), or
        from the next reading (``None``: the envelope there is a free parameter)."""
        t_ref = float(t_ref)
        if a_start is not None:
            a_start = kh.as_complex(a_start)
        for k in range(_ROW):  # the first row: the window's base, no sums yet
            self._rows[k] = 0.0
        self.first = self.end = 1
        self.n_fits = 0
        self.tr = t_ref
        # A known start: the fit's intercept c = tau0 a_start, known.
        self.known_start = a_start is not None
        if a_start is not None:
            self.c_known = self.tau0 * a_start
            self.q1_t, self.q1_a, self.q1_x1, self.q1_x2 = t_ref, a_start, 0j, 0j
        # The last point integrated (t, a, X1, X2), and the point before it (t, a).
        self.has_q1, self.has_q2 = self.known_start, False
        self.w_target = WINDOW_S
        self.ramp_from = _INF  # when this segment's load was first seen ramping, s (step)

    def seed(self, a: complex, t_end: float, dt_s: float) -> None:
        """Fill the window with a settled history (the instrument ran unloaded before the scene)."""
        a, t_end, dt_s = kh.as_complex(a), float(t_end), float(dt_s)
        n = int(WINDOW_S / dt_s)
        self.restart(t_end - n * dt_s, None)
        for k in range(n + 1):
            self._append(t_end - (n - k) * dt_s, a)
        self._fit(t_end)

    def _size(self) -> int:
        """The number of readings in the window."""
        return self.end - self.first

    def _readings(self, start: int) -> list[tuple[float, complex]]:
        """The window's readings (t, a) from its ``start``-th on (0 the oldest)."""
        return [(self._rows[i * _ROW + _T], _cget(self._rows, i * _ROW + _A)) for i in range(self.first + start, self.end)]

    def _grow(self) -> None:
        """Room for more rows: the rows from the base on (those before it have left the window)
        moved to the buffer's start, where they take at most half of it (they do not overlap
        where they were), else to the start of a new buffer four times their number."""
        keep = self.end - self.first + 1
        if 2 * keep > len(self._rows) // _ROW:
            rows = array("d", bytes(8 * _ROW * max(4 * keep, _MIN_ROWS)))
        else:
            rows = self._rows
        rows[: keep * _ROW] = self._rows[(self.first - 1) * _ROW : self.end * _ROW]
        self._rows = rows
        self.first, self.end = 1, keep

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
        """Add an integrated reading to the window: a row after the last (the newest reading's,
        or the base's in an empty window), its sums that row's plus the reading's terms."""
        if self.end * _ROW == len(self._rows):
            self._grow()
        # (The buffer read as self._rows where a reading reads it, not as a local: compiled, a
        # local memoryview would be acquired and released, atomic operations, each call.)
        s, new = (self.end - 1) * _ROW, self.end * _ROW
        c1, c2 = x1.conjugate(), x2.conjugate()
        self._rows[new + _T] = t
        _cput(self._rows, new + _A, a)
        _cput(self._rows, new + _S1, _cget(self._rows, s + _S1) + x1)
        _cput(self._rows, new + _S2, _cget(self._rows, s + _S2) + x2)
        _cput(self._rows, new + _SY, _cget(self._rows, s + _SY) + y)
        self._rows[new + _S11] = self._rows[s + _S11] + (x1.real * x1.real + x1.imag * x1.imag)
        self._rows[new + _S22] = self._rows[s + _S22] + (x2.real * x2.real + x2.imag * x2.imag)
        _cput(self._rows, new + _S12, _cget(self._rows, s + _S12) + c1 * x2)
        _cput(self._rows, new + _S1Y, _cget(self._rows, s + _S1Y) + c1 * y)
        _cput(self._rows, new + _S2Y, _cget(self._rows, s + _S2Y) + c2 * y)
        self.end += 1

    def _fit(self, t: float) -> bool:
        """Least squares over the window at ``t``, kept as the fit after the last reading (its
        row of the ring, and its mu, |mu|^2, variance, |mu1|^2 and ramp chi-square in this
        inference's fields): whether one was made (not while the window is too young or its
        regressors are degenerate)."""
        at = (self.n_fits & (_FITS - 1)) * _FIT  # (k mod _FITS: k >= 0, _FITS a power of two)
        self.n_fits += 1
        self._fits[at + _F_MADE] = 0.0
        b, last = (self.first - 1) * _ROW, (self.end - 1) * _ROW  # the base's row, the newest's
        n = self._size()
        s1 = _cget(self._rows, last + _S1) - _cget(self._rows, b + _S1)
        s2 = _cget(self._rows, last + _S2) - _cget(self._rows, b + _S2)
        sy = _cget(self._rows, last + _SY) - _cget(self._rows, b + _SY)
        if self.known_start:  # known start: no intercept
            if n < 2:
                return False
            c = self.c_known
            c11, c22 = self._rows[last + _S11] - self._rows[b + _S11], self._rows[last + _S22] - self._rows[b + _S22]
            c12 = _cget(self._rows, last + _S12) - _cget(self._rows, b + _S12)
            c1y = _cget(self._rows, last + _S1Y) - _cget(self._rows, b + _S1Y) - s1.conjugate() * c
            c2y = _cget(self._rows, last + _S2Y) - _cget(self._rows, b + _S2Y) - s2.conjugate() * c
            m1 = m2 = 0j
            inv_n = 0.0
        else:
            if n < 4:
                return False
            inv_n = 1.0 / n
            m1, m2, my = s1 * inv_n, s2 * inv_n, sy * inv_n
            m1c, m2c = m1.conjugate(), m2.conjugate()
            c11 = self._rows[last + _S11] - self._rows[b + _S11] - (s1.real * m1.real + s1.imag * m1.imag)
            c22 = self._rows[last + _S22] - self._rows[b + _S22] - (s2.real * m2.real + s2.imag * m2.imag)
            c12 = _cget(self._rows, last + _S12) - _cget(self._rows, b + _S12) - m1c * s2
            c1y = _cget(self._rows, last + _S1Y) - _cget(self._rows, b + _S1Y) - m1c * sy
            c2y = _cget(self._rows, last + _S2Y) - _cget(self._rows, b + _S2Y) - m2c * sy
        det = c11 * c22 - (c12.real * c12.real + c12.imag * c12.imag)
        if not det > 0.0:
            return False
        inv_det = 1.0 / det
        b1 = (c22 * c1y - c12 * c2y) * inv_det
        b2 = (c11 * c2y - c12.conjugate() * c1y) * inv_det
        if not self.known_start:
            c = my - b1 * m1 - b2 * m2
        tp = self._rows[last - _ROW + _T] if n > 1 else t
        h = t - tp
        # The load over the last sample period (held over it, as the co-simulation holds the
        # pad's pressure): mu at its middle.
        d = 0.5 * (t + tp) - self.tr
        mu = -(b1 + b2 * d)
        width = t - self._rows[self.first * _ROW + _T]
        mu_sq = mu.real * mu.real + mu.imag * mu.imag
        sig_sq = self.sig_sq
        s2_res = sig_sq * (self.tau0_sq + _INTEGRATED_NOISE * mu_sq * width * width)
        self._mu, self._mu_sq = mu, mu_sq
        self._var_mu = s2_res * (c22 + d * d * c11 - 2.0 * d * c12.real) * inv_det
        self._b2_sq = b2_sq = b2.real * b2.real + b2.imag * b2.imag
        self._ramp_chi2 = b2_sq * det / (s2_res * c11) if c11 > 0 else 0.0
        _cput(self._fits, at + _F_C, c)
        _cput(self._fits, at + _F_B1, b1)
        _cput(self._fits, at + _F_B2, b2)
        self._fits[at + _F_INV_N] = inv_n
        _cput(self._fits, at + _F_M1, m1)
        _cput(self._fits, at + _F_M2, m2)
        self._fits[at + _F_I11], self._fits[at + _F_I22] = c22 * inv_det, c11 * inv_det
        _cput(self._fits, at + _F_I12, 2.0 * c12 * inv_det)
        # For the change test: the noise of the residuals of a block of m new readings,
        # sigma^2 sum_l |tau0 + mu h (l - 1/2)|^2 (a reading enters tau0 a and, through the
        # integral, every later X1) ~ m (n0 + m (n1 + m n2)); and the fit's own error at them,
        # n_fit (m^2 / n + q) with q the quadratic form of the block's centered regressors
        # (the residual level n_fit: tau0^2 plus the integrated noise over the window).
        self._fits[at + _F_N0] = self.sig_sq_tau0_sq
        self._fits[at + _F_N1] = self.sig_sq_tau0 * mu.real * h
        self._fits[at + _F_N2] = self.half_sig_sq * mu_sq * h * h
        self._fits[at + _F_N_FIT] = sig_sq * (self.tau0_sq + mu_sq * h * width)
        self._fits[at + _F_MADE] = 1.0
        return True

    def step(self, t: float, a: complex) -> tuple[complex, float, bool]:
        """Take the lock-in's reading ``a`` at time ``t``; return (a_ss, gain, trusted)."""
        # A Python float and complex, as the compiled kernel's C double and complex are (NumPy's
        # scalars would carry NumPy's arithmetic through the window: its complex division rounds
        # differently from CPython's, kh.cquot's).
        t, a = float(t), kh.as_complex(a)
        if t - self.tr > _REBASE_S and self._size():
            self._replay(self._readings(0))
        x1, x2, y = self._integrate(t, a)
        trusted = True
        n_f = self.n_fits
        if n_f and self._fits[((n_f - 1) & (_FITS - 1)) * _FIT + _F_MADE]:
            # The change test, before the reading joins the fit: the last m readings predicted
            # with the fit made before them.
            last = (self.end - 1) * _ROW  # the newest reading's row
            n_s = self._size()
            worst, worst_m = 0.0, 0
            self.turn = turn = (self.turn + 1) & 3
            for i in range(turn * _TURN, turn * _TURN + _TURN):
                m = _TURN_SCALES[i]
                if m == 0 or m > n_f or m > n_s:  # (0: the turn's look-backs are done)
                    break
                at = ((n_f - m) & (_FITS - 1)) * _FIT  # the fit made m readings ago
                if not self._fits[at + _F_MADE]:
                    break
                c, b1, b2 = _cget(self._fits, at + _F_C), _cget(self._fits, at + _F_B1), _cget(self._fits, at + _F_B2)
                m1, m2, i12 = _cget(self._fits, at + _F_M1), _cget(self._fits, at + _F_M2), _cget(self._fits, at + _F_I12)
                inv_n, i11, i22 = self._fits[at + _F_INV_N], self._fits[at + _F_I11], self._fits[at + _F_I22]
                n0, n1, n2, n_fit = self._fits[at + _F_N0], self._fits[at + _F_N1], self._fits[at + _F_N2], self._fits[at + _F_N_FIT]
                if m == 1:
                    g1, g2, r = x1 - m1, x2 - m2, y - c - b1 * x1 - b2 * x2
                else:
                    ref = last - (m - 1) * _ROW  # the row of the reading m - 1 before the newest
                    g1 = _cget(self._rows, last + _S1) - _cget(self._rows, ref + _S1) + x1
                    g2 = _cget(self._rows, last + _S2) - _cget(self._rows, ref + _S2) + x2
                    r = (_cget(self._rows, last + _SY) - _cget(self._rows, ref + _SY) + y) - m * c - b1 * g1 - b2 * g2
                    g1, g2 = g1 - m * m1, g2 - m * m2
                ig2 = i12 * g2
                q = (
                    i11 * (g1.real * g1.real + g1.imag * g1.imag)
                    + i22 * (g2.real * g2.real + g2.imag * g2.imag)
                    - (g1.real * ig2.real + g1.imag * ig2.imag)
                )
                stat = (r.real * r.real + r.imag * r.imag) / (2.0 * (m * (n0 + m * (n1 + m * n2)) + n_fit * (m * m * inv_n + q)))
                if stat > worst:
                    worst, worst_m = stat, m
            if worst > CHANGE_STAT:
                # Restart at the change: the last worst_m readings (this one included) follow it.
                keep = self._readings(n_s - worst_m + 1) if worst_m > 1 else []
                keep.append((t, a))
                self._replay(keep)
                return _NAN_ENVELOPE, _INF, False
            trusted = worst <= (SUSPECT_STAT if worst_m < _LONGEST else _SUSPECT_STAT_LONGEST)
        self._add(t, a, x1, x2, y)  # the reading into the window's running sums
        w_target = self.w_target
        while t - self._rows[self.first * _ROW + _T] > w_target and self._size() > _MIN_SAMPLES:
            self.first += 1  # the window's oldest reading leaves it, and becomes its base
            self.known_start = False  # the window no longer starts at the known start
        if not self._fit(t):
            return _NAN_ENVELOPE, _INF, False
        curve_var = 0.0
        w_next = WINDOW_S  # the window's target: its longest, shortened while the load ramps significantly
        if self._ramp_chi2 > RAMP_SUSPECT_CHI2 or self._ramp_chi2 > _RAMP_CHI2:
            # The load ramps under this reading: the window the ramp allows (RAMP_WINDOW_FRACTION).
            load = kh.cabs(self._mu - 1.0)
            load = load if load > _MIN_LOAD else _MIN_LOAD
            w_ramp = RAMP_WINDOW_FRACTION * load / kh.sqrt(self._b2_sq)
            w_ramp = WINDOW_S if w_ramp > WINDOW_S else (MIN_WINDOW_S if w_ramp < MIN_WINDOW_S else w_ramp)
            span = t - self._rows[self.first * _ROW + _T]
            if self._ramp_chi2 > RAMP_SUSPECT_CHI2:
                if self.ramp_from > t:
                    self.ramp_from = t
                if span > w_ramp or t - self.ramp_from < self.tau0:
                    # The window reaches back past the ramp's span (its onset may lie in it), or
                    # the segment's first ramp is younger than the envelope's own time constant
                    # (the envelope's transient after a change, which the fit has not absorbed,
                    # reads as one): RAMP_SUSPECT_CHI2.
                    trusted = False
                # The linear-in-time model's error at the window's end, a ramp whose rate changes
                # on its own time scale (|mu''| ~ |mu1|^2 / load): |mu''| span^2 / 12, in mu's
                # variance (at high signal to noise it is many of the readings' sigmas).
                curve = _TWELFTH * self._b2_sq * span * span / load
                # ...and the load's change over the reading's own period (a lock-in reading
                # integrates over it): the truth at the period's end is up to |mu1| dt away.
                lag = t - self._rows[(self.end - 2) * _ROW + _T] if self.end - 2 >= self.first else 0.0
                curve_var = curve * curve + self._b2_sq * lag * lag
            if self._ramp_chi2 > _RAMP_CHI2:
                w_next = w_ramp
        if w_target != w_next:
            self.w_target = w_next
        if not self._var_mu < _MAX_REL_SQ * self._mu_sq:
            return (kh.cquot(1.0, self._mu) if self._mu_sq > 0 else _NAN_ENVELOPE), _INF, False
        return kh.cquot(1.0, self._mu), kh.sqrt(self._var_mu + curve_var) / (self._mu_sq * self.sigma), trusted

    def _replay(self, readings: list[tuple[float, complex]]) -> None:
        """Restart the segment at the first of ``readings`` (envelope unknown there, one or
        more of them) and refit."""
        self.restart(readings[0][0], None)
        for t, a in readings:
            self._append(t, a)
        self._fit(t)

    def __reduce__(self):
        """A copy: the constructor's arguments, then the state (:meth:`__setstate__`): the
        window's rows from its base on and the ring of fits as lists of floats."""
        rows = [self._rows[k] for k in range((self.first - 1) * _ROW, self.end * _ROW)]
        fits = [self._fits[k] for k in range(_FIT * _FITS)]
        segment = (self.tr, self.known_start, self.c_known, self.w_target, self.turn, self.n_fits, self.ramp_from)
        points = (self.has_q1, self.q1_t, self.q1_a, self.q1_x1, self.q1_x2, self.has_q2, self.q2_t, self.q2_a)
        return type(self), (self.tau0, self.sigma), (rows, self.end - self.first, fits, segment, points)

    def __setstate__(self, state) -> None:
        rows, size, fits, segment, points = state
        if len(rows) != _ROW * (size + 1) or len(fits) != _FIT * _FITS:
            raise ValueError("a SteadyInference's state has rows or fits of other lengths")
        self._rows, self.first, self.end = array("d", rows), 1, size + 1
        self._fits = array("d", fits)
        self.tr, self.known_start, self.c_known, self.w_target, self.turn, self.n_fits, self.ramp_from = segment
        self.has_q1, self.q1_t, self.q1_a, self.q1_x1, self.q1_x2, self.has_q2, self.q2_t, self.q2_a = points
