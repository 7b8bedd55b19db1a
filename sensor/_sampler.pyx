# cython: language_level=3, cdivision=True, boundscheck=False, wraparound=False
"""One reading of a table-driven channel, compiled: :class:`sensor.sampler.PyModeSampler` in C.

The co-simulation takes a reading of every instrumented pad every control step; in Python the
reading's arithmetic (a table lookup per cell, eq. 10, the envelope's rate and step, the
lock-in's noise and magnitude) cost about 3 us a pad.  This class is the Python reference's
twin, statement for statement, so its results are the reference's bit for bit
(tests/test_compiled_twins.py steps both through the same samples):

- complex arithmetic goes through CPython's own functions (``_Py_c_sum``, ``_Py_c_diff``,
  ``_Py_c_neg``, ``_Py_c_prod``, ``_Py_c_quot``, ``_Py_c_abs``), with a float operand made a
  complex of imaginary part 0.0 as Python 3.11 does (``1j * kappa``, ``noise * sigma``);
- ``cmath.exp``, ``math.atan2``, ``math.log`` and ``math.exp`` are written out for the finite
  arguments they meet here (the formulas of CPython's ``cmath_exp_impl``, ``m_atan2``,
  ``m_log``, ``math_1``), and anything else is handed to the Python function itself;
- the table lookup is :meth:`sensor.estimator.FoundationTable.at` with
  :func:`sensor.lookup.interp_pair` (``bisect_right``, then slope times offset plus value);
- ``-ffp-contract=off`` (setup.py): no fused multiply-adds.

The constants are read from :mod:`sensor.resonator` when this module is imported, the tables
from the channel's :class:`sensor.estimator.FoundationTable`.
"""

import cmath
import math

from cpython.complex cimport Py_complex
from cpython.mem cimport PyMem_Free
from libc.math cimport NAN, atan2, cos, exp, isfinite, isinf, isnan, log, sin

from _twin_helpers cimport bisect_right, copy_doubles, exp_py, fdiv, new_record, put_slot, slot_offsets

from . import resonator as _res


cdef extern from "Python.h":
    Py_complex PyComplex_AsCComplex(object) except *  # an error is raised, not ignored
    Py_complex _Py_c_sum(Py_complex, Py_complex)
    Py_complex _Py_c_diff(Py_complex, Py_complex)
    Py_complex _Py_c_neg(Py_complex)
    Py_complex _Py_c_prod(Py_complex, Py_complex)
    Py_complex _Py_c_quot(Py_complex, Py_complex)
    double _Py_c_abs(Py_complex)


cdef double _SETTLE_TAUS = _res._SETTLE_TAUS
cdef type Reading = _res.Reading
#: mode, v1, v1_true, phase_rad, time_in_mode_s, tau_s, settled, kappa, gamma, iq: the fields' order
cdef Py_ssize_t[10] _READING_AT
slot_offsets(Reading, _READING_AT, 10)
cdef object _py_cexp = cmath.exp
cdef object _py_atan2 = math.atan2
#: Below it CPython's cmath.exp computes exp(x) (cos y, sin y); log(DBL_MAX / 4) is its bound.
cdef double _EXP_DIRECT = 700.0
cdef Py_complex _J
_J.real, _J.imag = 0.0, 1.0


cdef inline Py_complex cx(double re, double im) noexcept:
    cdef Py_complex z
    z.real, z.imag = re, im
    return z


cdef inline Py_complex quot(Py_complex a, Py_complex b) except *:
    """a / b as Python's complex division (ZeroDivisionError for b == 0)."""
    if b.real == 0.0 and b.imag == 0.0:
        raise ZeroDivisionError("complex division by zero")
    return _Py_c_quot(a, b)


cdef inline double cabs_py(Py_complex z) except? -1.0:
    """abs(z) for a Python complex."""
    cdef double r = _Py_c_abs(z)
    if isinf(r) and isfinite(z.real) and isfinite(z.imag):
        raise OverflowError("absolute value too large")
    return r


cdef inline Py_complex cexp_py(Py_complex z) except *:
    """cmath.exp(z)."""
    cdef double l
    cdef object r
    if isfinite(z.real) and isfinite(z.imag) and z.real <= _EXP_DIRECT:
        l = exp(z.real)
        return cx(l * cos(z.imag), l * sin(z.imag))
    r = _py_cexp(complex(z.real, z.imag))
    return cx(r.real, r.imag)


cdef inline double atan2_py(double y, double x) except? -100.0:
    """math.atan2(y, x)."""
    if isfinite(x) and isfinite(y) and y != 0.0:
        return atan2(y, x)
    return _py_atan2(y, x)


cdef class ModeSampler:
    """The compiled :class:`sensor.sampler.PyModeSampler` (see there): the per-sample arithmetic
    of one mode of a table-driven channel."""

    cdef readonly object mode
    cdef public Py_ssize_t lookups
    cdef double _omega, _sigma, _c, _rho_a
    cdef bint _envelope
    cdef double *_weights
    cdef Py_ssize_t _n
    # The table (FoundationTable.at): log P, log k_e, log c_e, and the linear part below P0.
    cdef double *_log_p
    cdef double *_log_k
    cdef double *_log_c
    cdef Py_ssize_t _m
    cdef double _p0, _k0, _c0
    cdef object _args  # the constructor's arguments, for copies

    def __dealloc__(self):
        PyMem_Free(self._weights)
        PyMem_Free(self._log_p)
        PyMem_Free(self._log_k)
        PyMem_Free(self._log_c)

    def __init__(self, mode, omega, sigma, c, mass_per_length_kg_m, table, weights, envelope):
        weights = [float(w) for w in weights]
        if not weights:
            raise ValueError("a sampler needs at least one pressure cell")
        self._args = (mode, omega, sigma, c, mass_per_length_kg_m, table, weights, envelope)
        self.mode = int(mode)
        self._omega, self._sigma, self._c = float(omega), float(sigma), float(c)
        self._rho_a = float(mass_per_length_kg_m)
        self._envelope = bool(envelope)
        self._n = len(weights)
        self._weights = copy_doubles(weights)
        self._m = len(table._log_p_list)
        if self._m < 2 or len(table._log_k_list) != self._m or len(table._log_c_list) != self._m:
            raise ValueError("a table needs two or more points and columns of its length")
        self._log_p = copy_doubles(table._log_p_list)
        self._log_k = copy_doubles(table._log_k_list)
        self._log_c = copy_doubles(table._log_c_list)
        self._p0, self._k0, self._c0 = table._p0_f, table._k0_f, table._c0_f
        self.lookups = 0

    cdef int _at(self, double p, double *k_e, double *c_e) except -1:
        """FoundationTable.at(p): (k_e, c_e) at p, Pa."""
        cdef double x, dx, h, log_k, log_c
        cdef Py_ssize_t j, last = self._m - 1
        cdef double *xp = self._log_p
        cdef double *fa = self._log_k
        cdef double *fb = self._log_c
        if p < self._p0:
            k_e[0], c_e[0] = p * self._k0, p * self._c0
            return 0
        x = p if isnan(p) else log(p)  # math.log of p >= P0 > 0, inf or NaN
        if x >= xp[last]:
            log_k, log_c = fa[last], fb[last]
        elif x >= xp[0]:
            j = bisect_right(xp, self._m, x) - 1
            dx, h = x - xp[j], xp[j + 1] - xp[j]
            log_k = (fa[j + 1] - fa[j]) / h * dx + fa[j]
            log_c = (fb[j + 1] - fb[j]) / h * dx + fb[j]
        elif x < xp[0]:
            log_k, log_c = fa[0], fb[0]
        else:
            log_k = log_c = NAN
        k_e[0] = exp_py(log_k)
        c_e[0] = exp_py(log_c)
        return 0

    def sample(self, pressure_cells_pa, envelope, double dt_s, time_in_mode_s, noise_iq):
        """(the reading, the new envelope): :meth:`sensor.sampler.PyModeSampler.sample`."""
        cdef double k_e, c_e, kappa, gamma, omega = self._omega, c = self._c, tau, v1_true, v1, phase
        cdef double t = time_in_mode_s
        cdef Py_ssize_t i, n = self._n
        cdef Py_complex a0, steady, rate, jk, env, iq, noise
        cdef bint settled
        a0 = PyComplex_AsCComplex(envelope)
        self.lookups += n
        if n == 1:
            self._at(pressure_cells_pa[0], &k_e, &c_e)
            kappa, gamma = k_e * self._weights[0], c_e * self._weights[0]
        else:
            if len(pressure_cells_pa) != n:
                raise ValueError(f"zip() argument 2 is shorter or longer than argument 1: {len(pressure_cells_pa)} cells for {n} weights")
            kappa = gamma = 0.0
            for i in range(n):
                self._at(pressure_cells_pa[i], &k_e, &c_e)
                kappa += k_e * self._weights[i]
                gamma += c_e * self._weights[i]
        # normalized_response: omega c / (omega (gamma + c) - 1j kappa)
        jk = _Py_c_prod(_J, cx(kappa, 0.0))
        steady = quot(cx(omega * c, 0.0), _Py_c_diff(cx(omega * (gamma + c), 0.0), jk))
        # _rate: (c + gamma) / (2 rho A) - 1j kappa / (2 omega rho A)
        rate = _Py_c_diff(cx(fdiv(c + gamma, 2.0 * self._rho_a), 0.0), quot(jk, cx(2.0 * omega * self._rho_a, 0.0)))
        tau = fdiv(1.0, rate.real)
        if self._envelope:
            # _step: steady + (envelope - steady) exp(-rate dt)
            env = _Py_c_sum(steady, _Py_c_prod(_Py_c_diff(a0, steady), cexp_py(_Py_c_prod(_Py_c_neg(rate), cx(dt_s, 0.0)))))
            settled = t >= tau * _SETTLE_TAUS
        else:
            env, settled = steady, True
        v1_true = cabs_py(env)
        if noise_iq is not None:
            noise = PyComplex_AsCComplex(noise_iq)
            iq = _Py_c_sum(env, _Py_c_prod(noise, cx(self._sigma, 0.0)))
        else:
            iq = env
        phase = -atan2_py(env.imag, env.real) if v1_true > 0 else 0.0
        v1 = cabs_py(iq)
        new_envelope = complex(env.real, env.imag)
        # The Reading's slots written at once, as sensor.resonator._reading sets them.
        reading = new_record(Reading)
        put_slot(reading, _READING_AT[0], self.mode)
        put_slot(reading, _READING_AT[1], v1)
        put_slot(reading, _READING_AT[2], v1_true)
        put_slot(reading, _READING_AT[3], phase)
        put_slot(reading, _READING_AT[4], time_in_mode_s)
        put_slot(reading, _READING_AT[5], tau)
        put_slot(reading, _READING_AT[6], settled)
        put_slot(reading, _READING_AT[7], kappa)
        put_slot(reading, _READING_AT[8], gamma)
        put_slot(reading, _READING_AT[9], complex(iq.real, iq.imag) if noise_iq is not None else new_envelope)
        return reading, new_envelope

    def __reduce__(self):
        return ModeSampler, self._args, self.lookups

    def __setstate__(self, lookups):
        self.lookups = lookups

