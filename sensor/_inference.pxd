# The C types of _inference.py (its one source; sensor/compiled.py explains the kernels).
cimport cython

cimport piezotip.sensor._kernel_helpers as kh

cdef double WINDOW_S, MIN_WINDOW_S, RAMP_WINDOW_FRACTION, _RAMP_CHI2, RAMP_SUSPECT_CHI2, _MIN_LOAD
cdef double CHANGE_STAT, SUSPECT_STAT, _SUSPECT_STAT_LONGEST, _INTEGRATED_NOISE, _MAX_REL_SQ, _REBASE_S, _TWELFTH
cdef tuple _SCALE_TURNS, _SCALES
cdef Py_ssize_t _LONGEST, _MIN_SAMPLES
cdef double _INF
cdef object _NAN_ENVELOPE
# A window row's and a fit's fields (their offsets), their lengths, the ring's fits.
cdef Py_ssize_t _T, _A, _S1, _S2, _SY, _S11, _S22, _S12, _S1Y, _S2Y, _ROW, _MIN_ROWS
cdef Py_ssize_t _F_MADE, _F_C, _F_B1, _F_B2, _F_M1, _F_M2, _F_I12, _F_INV_N, _F_I11, _F_I22, _F_N0, _F_N1, _F_N2, _F_N_FIT
cdef Py_ssize_t _FIT, _FITS
# The look-backs of the four turns, _TURN (4) places each.
cdef Py_ssize_t _TURN
cdef Py_ssize_t _TURN_SCALES[16]


cdef inline double complex _cget(double[::1] w, Py_ssize_t i) noexcept
cdef inline void _cput(double[::1] w, Py_ssize_t i, double complex z) noexcept


@cython.final
cdef class SteadyInference:
    cdef readonly double tau0, tau0_sq, sigma
    cdef double sig_sq, sig_sq_tau0, sig_sq_tau0_sq, half_sig_sq
    cdef double[::1] _rows, _fits
    cdef Py_ssize_t first, end, n_fits
    cdef int turn
    cdef double tr
    cdef bint known_start, has_q1, has_q2
    cdef double complex c_known, q1_a, q1_x1, q1_x2, q2_a
    cdef double q1_t, q2_t
    cdef readonly double w_target
    cdef double ramp_from
    cdef double complex _mu
    cdef double _mu_sq, _var_mu, _b2_sq, _ramp_chi2

    @cython.locals(k=Py_ssize_t)
    cpdef restart(self, double t_ref, a_start=*)

    @cython.locals(n=Py_ssize_t, k=Py_ssize_t)
    cpdef seed(self, double complex a, double t_end, double dt_s)

    cdef inline Py_ssize_t _size(self) noexcept

    @cython.locals(i=Py_ssize_t)
    cdef list _readings(self, Py_ssize_t start)

    @cython.locals(keep=Py_ssize_t, rows="double[::1]")
    cdef int _grow(self) except -1

    @cython.locals(tr=double, tp=double, h=double, tq=double, x1="double complex", x2="double complex", ap="double complex", aq="double complex")
    cdef inline (double complex, double complex, double complex) _integrate(self, double t, double complex a) noexcept

    @cython.locals(x1="double complex", x2="double complex", y="double complex")
    cdef int _append(self, double t, double complex a) except -1

    @cython.locals(s=Py_ssize_t, new=Py_ssize_t, c1="double complex", c2="double complex")
    cdef inline int _add(self, double t, double complex a, double complex x1, double complex x2, double complex y) except -1

    @cython.locals(
        at=Py_ssize_t, b=Py_ssize_t, last=Py_ssize_t, n=Py_ssize_t,
        s1="double complex", s2="double complex", sy="double complex", c="double complex", c12="double complex",
        c1y="double complex", c2y="double complex", m1="double complex", m2="double complex", my="double complex",
        m1c="double complex", m2c="double complex", b1="double complex", b2="double complex", mu="double complex",
        c11=double, c22=double, inv_n=double, det=double, inv_det=double, tp=double, h=double, d=double, width=double,
        mu_sq=double, sig_sq=double, s2_res=double, b2_sq=double,
    )
    cdef bint _fit(self, double t) except -1

    @cython.locals(
        last=Py_ssize_t, ref=Py_ssize_t, at=Py_ssize_t, keep=list, trusted=bint,
        n_f=Py_ssize_t, n_s=Py_ssize_t, worst_m=Py_ssize_t, m=Py_ssize_t, i=Py_ssize_t, turn=int,
        x1="double complex", x2="double complex", y="double complex", g1="double complex", g2="double complex",
        r="double complex", ig2="double complex", c="double complex", b1="double complex", b2="double complex",
        m1="double complex", m2="double complex", i12="double complex",
        worst=double, stat=double, q=double, inv_n=double, i11=double, i22=double, n0=double, n1=double, n2=double,
        n_fit=double, load=double, w_ramp=double, w_target=double, span=double, curve=double, curve_var=double, lag=double, w_next=double,
    )
    cpdef (double complex, double, bint) step(self, double t, double complex a) except *

    @cython.locals(t=double, a="double complex")
    cdef int _replay(self, list readings) except -1
