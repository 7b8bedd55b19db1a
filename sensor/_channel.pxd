# The C types of _channel.py (its one source; sensor/compiled.py explains the kernels).
cimport cython

cimport piezotip.sensor._estimator as se
cimport piezotip.sensor._inference as si
cimport piezotip.sensor._kernel_helpers as kh
cimport piezotip.sensor._sampler as sm

cdef Py_ssize_t _NOISE_BLOCK
cdef double _MAX_GAIN
cdef object _SETTLING, _SATURATED, _MODE_INVERSE, _READING_GET
cdef Py_ssize_t _READING_AT[3]


@cython.final
cdef class ChannelCore:
    cdef object _args  # the constructor's arguments, for copies
    cdef readonly dict _samplers, _inverse, _sigma, _low_amplitude
    cdef readonly double _tau0, _saturation_s
    cdef bint _steady
    cdef object _inverse_seen
    cdef se.InverseCore _core_of
    # The envelope and the seed as written (a physical unit's may be numpy complex numbers).
    cdef public object noise, rng, mode, envelope, _seed_a, _inference, _inference_mode, _last_estimate, _low_since_s
    cdef public list _noise
    cdef public Py_ssize_t evaluations
    cdef public double time_in_mode_s, _clock_s, _dt_s, _estimated_at

    cpdef object iq_noise(self)

    @cython.locals(t=double, s=sm.ModeSampler, out=tuple)
    cpdef object update(self, pressure_cells_pa, double dt_s)

    @cython.locals(t=double, gain=double, trusted=bint, a_ss="double complex", inf=si.SteadyInference, core=se.InverseCore)
    cpdef object estimate(self, reading)

    cpdef tuple sample(self, pressure_cells_pa, double dt_s)
