# The C types of _sampler.py (its one source; sensor/compiled.py explains the kernels).
cimport cython

cimport piezotip.sensor._kernel_helpers as kh

cdef double _SETTLE_TAUS
cdef Py_ssize_t _READING_AT[10]


@cython.final
cdef class ModeSampler:
    cdef readonly int mode
    cdef public Py_ssize_t lookups, unloaded_samples
    cdef double _omega, _sigma, _c, _rho_a
    cdef bint _envelope, _skip_unloaded
    cdef double[::1] _weights, _log_p, _log_k, _log_c
    cdef Py_ssize_t _n
    cdef double _p0, _k0, _c0
    cdef double complex _u_steady, _u_rate, _u_decay
    cdef double _u_tau, _u_dt
    cdef object _args  # the constructor's arguments, for copies

    @cython.locals(log_k=double, log_c=double)
    cdef (double, double) _at(self, double p) except *

    @cython.locals(omega=double, c=double, jk="double complex", steady="double complex", rate="double complex")
    cdef (double complex, double complex, double) _response(self, double kappa, double gamma) except *

    @cython.locals(i=Py_ssize_t, k_e=double, c_e=double, kappa=double, gamma=double)
    cdef (double, double) _load(self, pressure_cells_pa) except *

    @cython.locals(
        tau=double, settled=bint,
        steady="double complex", rate="double complex", decay="double complex", iq="double complex",
    )
    cdef (double complex, double complex, double, bint) _step(
        self, double kappa, double gamma, double complex envelope, double dt_s, double t_s, bint noisy, double complex noise
    ) except *

    @cython.locals(kappa=double, gamma=double, iq="double complex", tau=double, settled=bint)
    cpdef (double complex, double complex, double, bint, double, double) values(
        self, pressure_cells_pa, double complex envelope, double dt_s, double time_in_mode_s, bint noisy, double complex noise
    ) except *

    @cython.locals(k_e=double, c_e=double, kappa=double, gamma=double, iq="double complex", tau=double, settled=bint)
    cpdef (double complex, double complex, double, bint, double, double) values_one(
        self, double pressure_pa, double complex envelope, double dt_s, double time_in_mode_s, bint noisy, double complex noise
    ) except *

    @cython.locals(kappa=double, gamma=double, iq="double complex", tau=double, settled=bint)
    cpdef (double complex, double complex, double, double, bint, double, double) advance(
        self, pressure_cells_pa, double complex envelope, double dt_s, double time_in_mode_s, bint noisy, double complex noise
    ) except *

    @cython.locals(kappa=double, gamma=double, iq="double complex", tau=double, settled=bint)
    cpdef (double complex, double complex, double, double, bint, double, double) advance_one(
        self, double pressure_pa, double complex envelope, double dt_s, double time_in_mode_s, bint noisy, double complex noise
    ) except *

    @cython.locals(
        noisy=bint, draw="double complex", iq="double complex", v1_true=double,
        tau=double, settled=bint, kappa=double, gamma=double,
    )
    cpdef tuple sample(self, pressure_cells_pa, double complex envelope, double dt_s, double time_in_mode_s, noise_iq)


@cython.locals(phase=double)
cpdef object reading(
    int mode, double complex iq, double complex envelope, double v1_true, double time_in_mode_s, double tau_s, bint settled,
    double kappa, double gamma,
)
