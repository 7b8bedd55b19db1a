# The C types of _channel.py (its one source; sensor/compiled.py explains the kernels).
cimport cython

cimport piezotip.sensor._estimator as se
cimport piezotip.sensor._inference as si
cimport piezotip.sensor._kernel_helpers as kh
cimport piezotip.sensor._sampler as sm

cdef Py_ssize_t _NOISE_BLOCK
cdef double _MAX_GAIN
cdef object _SETTLING, _SATURATED, _MODE_INVERSE, _READING_GET, _ESTIMATE_GET
cdef Py_ssize_t _READING_AT[3]
cdef Py_ssize_t _ESTIMATE_AT[3]
cdef dict _STATUS_INDEX
cdef int _SATURATED_AT, _SETTLING_AT
cdef double _NAN
cdef object _LAST_READING


@cython.final
cdef class ChannelCore:
    cdef object _args  # the constructor's arguments, for copies
    cdef readonly dict _samplers, _inverse, _sigma, _low_amplitude
    cdef readonly double _tau0, _saturation_s
    cdef bint _steady
    cdef object _inverse_seen
    cdef se.InverseCore _core_of
    # The envelope (where written since the last reading: _r_envelope holds a reading's) and the
    # seed as written (a physical unit's may be numpy complex numbers).
    cdef object _envelope
    cdef public object noise, rng, mode, _seed_a, _inference, _inference_mode, _low_since_s
    # The last estimate's values, and its record once made (the _last_estimate property).
    cdef double _last_p, _last_sigma
    cdef int _last_status
    cdef object _last_record, _a_record
    # The last reading's values, and its record once made (last_reading).
    cdef int _r_mode
    cdef double complex _r_iq, _r_envelope
    cdef double _r_v1, _r_t, _r_tau, _r_kappa, _r_gamma
    cdef bint _r_settled
    cdef object _r_record
    # The driven mode's sampler and the last reading's mode's low amplitude, as last looked up.
    cdef object _mode_seen, _mode_sampler
    cdef int _low_mode
    cdef double _low
    cdef double[::1] _draws
    cdef Py_ssize_t _left
    cdef public Py_ssize_t evaluations
    cdef public double time_in_mode_s, _clock_s, _dt_s, _estimated_at

    @cython.locals(j=Py_ssize_t)
    cdef double complex _draw(self) except *

    cpdef object iq_noise(self)

    @cython.locals(
        t=double, s=sm.ModeSampler, noisy=bint, draw="double complex",
        iq="double complex", envelope="double complex", tau=double, settled=bint, kappa=double, gamma=double,
    )
    cdef int _read(self, pressure_cells_pa, double pressure_pa, double dt_s) except -1

    cpdef object last_reading(self)

    cpdef object update(self, pressure_cells_pa, double dt_s)

    @cython.locals(
        t=double, gain=double, trusted=bint, a_ss="double complex", inf=si.SteadyInference, core=se.InverseCore,
        p=double, sigma=double, status=int, low=double,
    )
    cdef (double, double, int, bint) _estimate_of(self, int mode, double complex iq) except *

    @cython.locals(kept=bint)
    cpdef object estimate(self, reading)

    cpdef tuple sample(self, pressure_cells_pa, double dt_s)

    cpdef (int, double, double, int) advance(self, pressure_cells_pa, double dt_s) except *

    cpdef (int, double, double, int) advance_one(self, double pressure_pa, double dt_s) except *

    @cython.locals(mode=int, v1=double, p=double, sigma=double, status=int, kept=bint)
    cdef (int, double, double, int) _estimated(self) except *

    cpdef object last_estimate(self)


cdef (double, double, int) _values_of(object record) except *
