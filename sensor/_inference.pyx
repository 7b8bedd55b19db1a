# cython: language_level=3, cdivision=True
"""The readout's steady-reading inference, compiled: :class:`sensor.inference.PySteadyInference`
in typed C, the same arithmetic in the same order (the co-simulation calls it on every reading
of every pad; in Python it was a fifth of a control step's own cost).

The Python class is the reference and holds the documentation (the model, the fit, the change
test, the window): this file mirrors it statement for statement, with the window's readings and
the fits in C ring buffers instead of deques of tuples.  Its results are the Python class's bit
for bit (tests/test_compiled_twins.py steps both through the same readings).  Complex
arithmetic: C99 ``double complex`` products and sums are Python's formulas; the one division,
1 / mu, calls CPython's own ``_Py_c_quot``.  The constants are read from
:mod:`sensor.inference` when this module is imported (one owner for each value).
"""

from cpython.complex cimport Py_complex
from cpython.mem cimport PyMem_Free, PyMem_Malloc
from libc.math cimport NAN, INFINITY, sqrt, fabs

from . import inference as _py


cdef extern from "Python.h":
    Py_complex _Py_c_quot(Py_complex, Py_complex)


cdef double WINDOW_S = _py.WINDOW_S
cdef double MIN_WINDOW_S = _py.MIN_WINDOW_S
cdef double RAMP_WINDOW_FRACTION = _py.RAMP_WINDOW_FRACTION
cdef double _RAMP_CHI2 = _py._RAMP_CHI2
cdef double _MIN_LOAD = _py._MIN_LOAD
cdef double CHANGE_STAT = _py.CHANGE_STAT
cdef double SUSPECT_STAT = _py.SUSPECT_STAT
cdef double RAMP_SUSPECT_CHI2 = _py.RAMP_SUSPECT_CHI2
cdef double _SUSPECT_STAT_LONGEST = _py._SUSPECT_STAT_LONGEST
cdef int _LONGEST = max(_py._SCALES)
cdef double _INTEGRATED_NOISE = _py._INTEGRATED_NOISE
cdef double _MAX_REL_SQ = _py._MAX_REL_SQ
cdef Py_ssize_t _MIN_SAMPLES = _py._MIN_SAMPLES
cdef double _REBASE_S = _py._REBASE_S
cdef double _TWELFTH = _py._TWELFTH
cdef int _TURNS[4][4]
cdef int _TURN_LENGTHS[4]


def _load_turns():
    turns = _py._SCALE_TURNS
    if len(turns) != 4 or max(len(t) for t in turns) > 4:
        raise ImportError("sensor._inference mirrors four turns of at most four look-backs: rebuild it for _SCALE_TURNS")
    for i, scales in enumerate(turns):
        _TURN_LENGTHS[i] = len(scales)
        for j, m in enumerate(scales):
            _TURNS[i][j] = m


_load_turns()

#: The fits' ring holds the last _LONGEST + 1 fits (the Python deque's maxlen).
cdef enum:
    _FITS = 32

if _LONGEST + 1 > _FITS:
    raise ImportError(f"sensor._inference keeps {_FITS} fits, _SCALES needs {_LONGEST + 1}: rebuild it")


cdef struct Sample:
    double t
    double complex a, x1, x2, y
    # The running sums since the segment's start (index 5.. of the Python sample tuple).
    double complex s5, s6, s7
    double s8, s9
    double complex s10, s11, s12


cdef struct Fit:
    bint valid
    double complex c, b1, b2
    double inv_n
    double complex m1, m2
    double i11, i22
    double complex i12
    double n0, n1, n2, n_fit


cdef struct FitResult:
    double complex mu
    double mu_sq, var_mu, ramp_chi2, b2_sq
    Fit record


cdef inline double abs2(double complex z) noexcept:
    return z.real * z.real + z.imag * z.imag


cdef inline object reciprocal(double complex z):
    """1 / z as Python computes it (float / complex: CPython's _Py_c_quot), a Python complex."""
    cdef Py_complex one, den, q
    one.real, one.imag = 1.0, 0.0
    den.real, den.imag = z.real, z.imag
    q = _Py_c_quot(one, den)
    return complex(q.real, q.imag)


cdef class SteadyInference:
    """The compiled :class:`sensor.inference.PySteadyInference` (see there): the readout's
    inference of the steady reading from the lock-in's recent readings (one mode)."""

    cdef readonly double tau0, tau0_sq, sigma
    cdef double sig_sq, sig_sq_tau0, sig_sq_tau0_sq, half_sig_sq
    cdef Sample *_samples
    cdef Py_ssize_t _cap, _head, _n
    cdef Sample _base
    cdef Fit _fits[_FITS]
    cdef Py_ssize_t _fit_head, _n_fits
    cdef int turn
    cdef double tr
    cdef bint _has_c_known, _has_q1, _has_q2
    cdef double complex _c_known
    cdef double _q1_t, _q2_t
    cdef double complex _q1_a, _q1_x1, _q1_x2, _q2_a
    cdef readonly double w_target

    def __cinit__(self, double tau0_s, double sigma):
        self._cap = 64
        self._samples = <Sample *> PyMem_Malloc(self._cap * sizeof(Sample))
        if self._samples == NULL:
            raise MemoryError()

    def __dealloc__(self):
        PyMem_Free(self._samples)

    def __init__(self, double tau0_s, double sigma):
        self.tau0, self.tau0_sq, self.sigma = tau0_s, tau0_s * tau0_s, sigma
        self.sig_sq = sigma * sigma
        self.sig_sq_tau0, self.sig_sq_tau0_sq, self.half_sig_sq = self.sig_sq * tau0_s, self.sig_sq * self.tau0_sq, 0.5 * self.sig_sq
        self.turn = 0
        self._restart(0.0, False, 0j)

    # -- the ring buffers ------------------------------------------------------------------

    cdef inline Sample *_at(self, Py_ssize_t i) noexcept:
        """The i-th sample of the window (0 the oldest; negative from the newest)."""
        if i < 0:
            i += self._n
        return &self._samples[(self._head + i) % self._cap]

    cdef int _push(self, Sample *s) except -1:
        cdef Sample *grown
        cdef Py_ssize_t k
        if self._n == self._cap:
            grown = <Sample *> PyMem_Malloc(2 * self._cap * sizeof(Sample))
            if grown == NULL:
                raise MemoryError()
            for k in range(self._n):
                grown[k] = self._samples[(self._head + k) % self._cap]
            PyMem_Free(self._samples)
            self._samples, self._head, self._cap = grown, 0, 2 * self._cap
        self._samples[(self._head + self._n) % self._cap] = s[0]
        self._n += 1
        return 0

    cdef inline Fit *_fit_at(self, Py_ssize_t m) noexcept:
        """fits[-m]"""
        return &self._fits[(self._fit_head + self._n_fits - m) % _FITS]

    cdef inline void _append_fit(self, Fit *f) noexcept:
        if self._n_fits == _LONGEST + 1:  # the deque's maxlen: the oldest drops
            self._fit_head = (self._fit_head + 1) % _FITS
            self._n_fits -= 1
        self._fits[(self._fit_head + self._n_fits) % _FITS] = f[0]
        self._n_fits += 1

    # -- the Python class's methods --------------------------------------------------------

    def restart(self, double t_ref, a_start=None):
        """A new segment at ``t_ref``: from a known envelope ``a_start`` (0 after a switch), or
        from the next reading (``None``: the envelope there is a free parameter)."""
        if a_start is None:
            self._restart(t_ref, False, 0j)
        else:
            self._restart(t_ref, True, a_start)

    cdef void _restart(self, double t_ref, bint known, double complex a_start) noexcept:
        self._head = self._n = 0
        self._fit_head = self._n_fits = 0
        self._base = Sample(0.0, 0j, 0j, 0j, 0j, 0j, 0j, 0j, 0.0, 0.0, 0j, 0j, 0j)
        self.tr = t_ref
        self._has_c_known = known
        if known:
            self._c_known = self.tau0 * a_start
            self._q1_t, self._q1_a, self._q1_x1, self._q1_x2 = t_ref, a_start, 0j, 0j
        self._has_q1 = known
        self._has_q2 = False
        self.w_target = WINDOW_S

    def seed(self, a, double t_end, double dt_s):
        """Fill the window with a settled history (the instrument ran unloaded before the scene)."""
        cdef Py_ssize_t n = int(WINDOW_S / dt_s), k
        cdef double complex z = a
        cdef FitResult f
        self._restart(t_end - n * dt_s, False, 0j)
        for k in range(n + 1):
            self._append(t_end - (n - k) * dt_s, z)
        self._fit(t_end, &f)
        self._append_fit(&f.record)

    cdef inline void _integrate(self, double t, double complex a, double complex *x1, double complex *x2, double complex *y) noexcept:
        cdef double tr = self.tr, tp, h, tq
        cdef double complex ap, aq
        if not self._has_q1:
            x1[0] = x2[0] = 0j
        else:
            tp, ap, x1[0], x2[0] = self._q1_t, self._q1_a, self._q1_x1, self._q1_x2
            h = t - tp
            if self._has_q2 and fabs(tp - self._q2_t - h) <= 1e-6 * h:  # three-point rule (uniform steps)
                tq, aq = self._q2_t, self._q2_a
                x1[0] = x1[0] + h * (5.0 * a + 8.0 * ap - aq) * _TWELFTH
                x2[0] = x2[0] + h * (5.0 * (t - tr) * a + 8.0 * (tp - tr) * ap - (tq - tr) * aq) * _TWELFTH
            else:
                x1[0] = x1[0] + 0.5 * h * (a + ap)
                x2[0] = x2[0] + 0.5 * h * ((t - tr) * a + (tp - tr) * ap)
            self._q2_t, self._q2_a, self._has_q2 = tp, ap, True
        self._q1_t, self._q1_a, self._q1_x1, self._q1_x2, self._has_q1 = t, a, x1[0], x2[0], True
        y[0] = self.tau0 * a - (t - tr)

    cdef int _append(self, double t, double complex a) except -1:
        cdef double complex x1, x2, y
        self._integrate(t, a, &x1, &x2, &y)
        return self._add(t, a, x1, x2, y)

    cdef int _add(self, double t, double complex a, double complex x1, double complex x2, double complex y) except -1:
        cdef Sample *s = self._at(-1) if self._n else &self._base
        cdef double complex c1 = x1.conjugate(), c2 = x2.conjugate()
        cdef Sample new = Sample(
            t,
            a,
            x1,
            x2,
            y,
            s.s5 + x1,
            s.s6 + x2,
            s.s7 + y,
            s.s8 + (x1.real * x1.real + x1.imag * x1.imag),
            s.s9 + (x2.real * x2.real + x2.imag * x2.imag),
            s.s10 + c1 * x2,
            s.s11 + c1 * y,
            s.s12 + c2 * y,
        )
        return self._push(&new)

    cdef void _fit(self, double t, FitResult *out) noexcept:
        """The Python class's _fit: out.record.valid is False where it returns None."""
        cdef Sample *last
        cdef Sample *b = &self._base
        cdef Py_ssize_t n = self._n
        cdef double complex s1, s2, sy, c, c12, c1y, c2y, m1, m2, my, m1c, m2c, b1, b2, mu
        cdef double c11, c22, inv_n, det, inv_det, tp, h, d, width, mu_sq, sig_sq, s2_res, var_mu, b2_sq, ramp_chi2
        out.mu = NAN + NAN * 1j
        out.mu_sq, out.var_mu, out.ramp_chi2, out.b2_sq = NAN, INFINITY, 0.0, 0.0
        out.record.valid = False
        last = self._at(-1)
        s1, s2, sy = last.s5 - b.s5, last.s6 - b.s6, last.s7 - b.s7
        if self._has_c_known:  # known start: no intercept
            if n < 2:
                return
            c = self._c_known
            c11, c22, c12 = last.s8 - b.s8, last.s9 - b.s9, last.s10 - b.s10
            c1y = last.s11 - b.s11 - s1.conjugate() * c
            c2y = last.s12 - b.s12 - s2.conjugate() * c
            m1 = m2 = 0j
            inv_n = 0.0
        else:
            if n < 4:
                return
            inv_n = 1.0 / n
            m1, m2, my = s1 * inv_n, s2 * inv_n, sy * inv_n
            m1c, m2c = m1.conjugate(), m2.conjugate()
            c11 = last.s8 - b.s8 - (s1.real * m1.real + s1.imag * m1.imag)
            c22 = last.s9 - b.s9 - (s2.real * m2.real + s2.imag * m2.imag)
            c12 = last.s10 - b.s10 - m1c * s2
            c1y = last.s11 - b.s11 - m1c * sy
            c2y = last.s12 - b.s12 - m2c * sy
        det = c11 * c22 - (c12.real * c12.real + c12.imag * c12.imag)
        if not det > 0.0:
            return
        inv_det = 1.0 / det
        b1 = (c22 * c1y - c12 * c2y) * inv_det
        b2 = (c11 * c2y - c12.conjugate() * c1y) * inv_det
        if not self._has_c_known:
            c = my - b1 * m1 - b2 * m2
        tp = self._at(-2).t if n > 1 else t
        h = t - tp
        d = 0.5 * (t + tp) - self.tr
        mu = -(b1 + b2 * d)
        width = t - self._at(0).t
        mu_sq = mu.real * mu.real + mu.imag * mu.imag
        sig_sq = self.sig_sq
        s2_res = sig_sq * (self.tau0_sq + _INTEGRATED_NOISE * mu_sq * width * width)
        var_mu = s2_res * (c22 + d * d * c11 - 2.0 * d * c12.real) * inv_det
        b2_sq = b2.real * b2.real + b2.imag * b2.imag
        ramp_chi2 = b2_sq * det / (s2_res * c11) if c11 > 0 else 0.0
        out.mu, out.mu_sq, out.var_mu, out.ramp_chi2, out.b2_sq = mu, mu_sq, var_mu, ramp_chi2, b2_sq
        out.record = Fit(
            True,
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

    def step(self, double t, a):
        """Take the lock-in's reading ``a`` at time ``t``; return (a_ss, gain, trusted)."""
        return self._step(t, a)

    cdef tuple _step(self, double t, double complex a):
        cdef double complex x1, x2, y, g1, g2, r, w, c, b1, b2, m1, m2, i12
        cdef double worst, stat, q, inv_n, i11, i22, n0, n1, n2, n_fit, load, wr, w_target, mf
        cdef Py_ssize_t n_f, n_s, worst_m, m, j, k
        cdef int turn
        cdef bint trusted
        cdef Sample *last
        cdef Sample *ref
        cdef Fit *fit
        cdef FitResult f
        cdef list keep
        if t - self.tr > _REBASE_S and self._n:
            self._replay([(self._at(k).t, self._at(k).a) for k in range(self._n)])
        self._integrate(t, a, &x1, &x2, &y)
        trusted = True
        n_f = self._n_fits
        if n_f and self._fit_at(1).valid:
            # The change test, before the reading joins the fit.
            last = self._at(-1)
            n_s = self._n
            worst, worst_m = 0.0, 0
            self.turn = turn = (self.turn + 1) & 3
            for j in range(_TURN_LENGTHS[turn]):
                m = _TURNS[turn][j]
                if m > n_f or m > n_s:
                    break
                fit = self._fit_at(m)
                if not fit.valid:
                    break
                c, b1, b2, inv_n, m1, m2 = fit.c, fit.b1, fit.b2, fit.inv_n, fit.m1, fit.m2
                i11, i22, i12, n0, n1, n2, n_fit = fit.i11, fit.i22, fit.i12, fit.n0, fit.n1, fit.n2, fit.n_fit
                mf = <double> m
                if m == 1:
                    g1, g2, r = x1 - m1, x2 - m2, y - c - b1 * x1 - b2 * x2
                else:
                    ref = self._at(-m)
                    g1, g2 = last.s5 - ref.s5 + x1, last.s6 - ref.s6 + x2
                    r = (last.s7 - ref.s7 + y) - mf * c - b1 * g1 - b2 * g2
                    g1, g2 = g1 - mf * m1, g2 - mf * m2
                w = i12 * g2
                q = (
                    i11 * (g1.real * g1.real + g1.imag * g1.imag)
                    + i22 * (g2.real * g2.real + g2.imag * g2.imag)
                    - (g1.real * w.real + g1.imag * w.imag)
                )
                stat = (r.real * r.real + r.imag * r.imag) / (2.0 * (mf * (n0 + mf * (n1 + mf * n2)) + n_fit * (mf * mf * inv_n + q)))
                if stat > worst:
                    worst, worst_m = stat, m
            if worst > CHANGE_STAT:
                # Restart at the change: the last worst_m readings (this one included) follow it.
                keep = [(self._at(k).t, self._at(k).a) for k in range(n_s - worst_m + 1, n_s)] if worst_m > 1 else []
                keep.append((t, a))
                self._replay(keep)
                return complex(NAN, NAN), INFINITY, False
            trusted = worst <= (SUSPECT_STAT if worst_m < _LONGEST else _SUSPECT_STAT_LONGEST)
        self._add(t, a, x1, x2, y)
        w_target = self.w_target
        while t - self._at(0).t > w_target and self._n > _MIN_SAMPLES:
            self._base = self._at(0)[0]
            self._head = (self._head + 1) % self._cap
            self._n -= 1
            self._has_c_known = False  # the window no longer starts at the known start
        self._fit(t, &f)
        self._append_fit(&f.record)
        if not f.record.valid:
            return complex(NAN, NAN), INFINITY, False
        if f.ramp_chi2 > RAMP_SUSPECT_CHI2:
            trusted = False  # the load changes under this reading (RAMP_SUSPECT_CHI2)
        if f.ramp_chi2 > _RAMP_CHI2:
            load = abs(f.mu - 1.0)
            wr = RAMP_WINDOW_FRACTION * (load if load > _MIN_LOAD else _MIN_LOAD) / sqrt(f.b2_sq)
            self.w_target = WINDOW_S if wr > WINDOW_S else (MIN_WINDOW_S if wr < MIN_WINDOW_S else wr)
        elif w_target != WINDOW_S:
            self.w_target = WINDOW_S
        if not f.var_mu < _MAX_REL_SQ * f.mu_sq:
            return (reciprocal(f.mu) if f.mu_sq > 0 else complex(NAN, NAN)), INFINITY, False
        return reciprocal(f.mu), sqrt(f.var_mu) / (f.mu_sq * self.sigma), trusted

    cdef int _replay(self, list readings) except -1:
        """Restart the segment at the first of ``readings`` (envelope unknown there) and refit."""
        cdef FitResult f
        cdef double t
        cdef double complex a
        self._restart(readings[0][0], False, 0j)
        for t, a in readings:
            self._append(t, a)
        self._fit(readings[-1][0], &f)
        self._append_fit(&f.record)
        return 0

    # -- copies (a CoSimulation is deep-copied whole) ----------------------------------------

    def __reduce__(self):
        return _rebuild, (self.tau0, self.sigma, self._state())

    def _state(self):
        samples = [self._at(k)[0] for k in range(self._n)]  # structs as dicts
        fits = [self._fit_at(m)[0] for m in range(self._n_fits, 0, -1)]
        return (
            samples,
            self._base,
            fits,
            self.turn,
            self.tr,
            (self._has_c_known, self._c_known),
            (self._has_q1, self._q1_t, self._q1_a, self._q1_x1, self._q1_x2),
            (self._has_q2, self._q2_t, self._q2_a),
            self.w_target,
        )

    def _set_state(self, state):
        samples, base, fits, turn, tr, c_known, q1, q2, w_target = state
        cdef Sample s
        cdef Fit fit
        self._head = self._n = 0
        for row in samples:
            s = row
            self._push(&s)
        self._base = base
        self._fit_head = self._n_fits = 0
        for entry in fits:
            fit = entry
            self._append_fit(&fit)
        self.turn, self.tr = turn, tr
        self._has_c_known, self._c_known = c_known
        self._has_q1, self._q1_t, self._q1_a, self._q1_x1, self._q1_x2 = q1
        self._has_q2, self._q2_t, self._q2_a = q2
        self.w_target = w_target


def _rebuild(tau0_s, sigma, state):
    inference = SteadyInference(tau0_s, sigma)
    inference._set_state(state)
    return inference
