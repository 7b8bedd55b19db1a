# The C types of _inference.py (its one source; sensor/compiled.py explains the kernels).
cimport cython

cimport piezotip.sensor._kernel_helpers as kh

cdef double WINDOW_S, MIN_WINDOW_S, RAMP_WINDOW_FRACTION, _RAMP_CHI2, RAMP_SUSPECT_CHI2, _MIN_LOAD
cdef double CHANGE_STAT, SUSPECT_STAT, _SUSPECT_STAT_LONGEST, _INTEGRATED_NOISE, _MAX_REL_SQ, _REBASE_S, _TWELFTH
cdef tuple _SCALE_TURNS, _SCALES
cdef Py_ssize_t _LONGEST, _MIN_SAMPLES
cdef double _INF
cdef object _NAN_ENVELOPE


@cython.final
@cython.freelist(64)
cdef class _Sample:
    cdef double t, s11, s22
    cdef double complex a, s1, s2, sy, s12, s1y, s2y

@cython.locals(s=_Sample)
cdef _Sample _zero_sample()
cdef _Sample _NO_SUMS


@cython.final
@cython.freelist(64)
cdef class _Fit:
    cdef double complex mu, c, b1, b2, m1, m2, i12
    cdef double mu_sq, var_mu, b2_sq, ramp_chi2, inv_n, i11, i22, n0, n1, n2, n_fit


@cython.final
cdef class SteadyInference:
    cdef readonly double tau0, tau0_sq, sigma
    cdef double sig_sq, sig_sq_tau0, sig_sq_tau0_sq, half_sig_sq
    cdef list samples, fits, spare_fits, spare_samples
    cdef Py_ssize_t first
    cdef _Sample base
    cdef int turn
    cdef double tr
    cdef bint known_start, has_q1, has_q2
    cdef double complex c_known, q1_a, q1_x1, q1_x2, q2_a
    cdef double q1_t, q2_t
    cdef readonly double w_target

    cpdef restart(self, double t_ref, a_start=*)

    @cython.locals(n=Py_ssize_t, k=Py_ssize_t)
    cpdef seed(self, double complex a, double t_end, double dt_s)

    cdef Py_ssize_t _size(self) noexcept
    cdef _Sample _sample(self, Py_ssize_t i)
    cdef _Fit _past_fit(self, Py_ssize_t m)
    cdef int _add_fit(self, _Fit fit) except -1
    cdef int _drop_oldest(self) except -1

    @cython.locals(tr=double, tp=double, h=double, tq=double, x1="double complex", x2="double complex", ap="double complex", aq="double complex")
    cdef (double complex, double complex, double complex) _integrate(self, double t, double complex a) except *

    @cython.locals(x1="double complex", x2="double complex", y="double complex")
    cdef int _append(self, double t, double complex a) except -1

    @cython.locals(s=_Sample, new=_Sample, c1="double complex", c2="double complex")
    cdef int _add(self, double t, double complex a, double complex x1, double complex x2, double complex y) except -1

    @cython.locals(
        b=_Sample, last=_Sample, n=Py_ssize_t, f=_Fit,
        s1="double complex", s2="double complex", sy="double complex", c="double complex", c12="double complex",
        c1y="double complex", c2y="double complex", m1="double complex", m2="double complex", my="double complex",
        m1c="double complex", m2c="double complex", b1="double complex", b2="double complex", mu="double complex",
        c11=double, c22=double, inv_n=double, det=double, inv_det=double, tp=double, h=double, d=double, width=double,
        mu_sq=double, sig_sq=double, s2_res=double,
    )
    cdef _Fit _fit(self, double t)

    @cython.locals(
        last=_Sample, ref=_Sample, fit=_Fit, keep=list, trusted=bint,
        n_f=Py_ssize_t, n_s=Py_ssize_t, worst_m=Py_ssize_t, m=Py_ssize_t, k=Py_ssize_t, turn=int,
        x1="double complex", x2="double complex", y="double complex", g1="double complex", g2="double complex",
        r="double complex", w="double complex", c="double complex", b1="double complex", b2="double complex",
        m1="double complex", m2="double complex", i12="double complex",
        worst=double, stat=double, q=double, inv_n=double, i11=double, i22=double, n0=double, n1=double, n2=double,
        n_fit=double, load=double, w_ramp=double, w_target=double,
    )
    cpdef (double complex, double, bint) step(self, double t, double complex a) except *

    @cython.locals(t=double, a="double complex")
    cdef int _replay(self, list readings) except -1
