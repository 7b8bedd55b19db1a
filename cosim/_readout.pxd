# The C types of _readout.py (its one source; piezotip.sensor.compiled explains the kernels).
cimport cython

cimport piezotip.sensor._channel as sc
cimport piezotip.sensor._kernel_helpers as kh

cdef Py_ssize_t VALUES_PER_TIP
cdef Py_ssize_t _LAST, _NEXT, _PERIOD, _HALF
cdef object _ESTIMATE_GET
cdef Py_ssize_t _ESTIMATE_AT[3]


@cython.final
cdef class ReadoutPass:
    cdef Py_ssize_t _n
    cdef list _samples, _cores, _readers, _fractions, _records
    cdef long[::1] _touch_adr, _sensor_adr, _touch_history
    cdef double[::1] _history
    cdef double[::1] _areas, _values, _sensordata, _code_at, _truths
    cdef signed char[::1] _pasts
    cdef double _gel_valid, _backstop
    cdef dict _codes
    cdef long _outside
    cdef long _clock_adr
    cdef Py_ssize_t _size
    cdef int _stage
    cdef double[::1] _clock
    cdef readonly Py_ssize_t periods

    @cython.locals(clock="double[::1]")
    cpdef set_clock(self, long clock_adr, int stage, double period_s, double timestep_s, double start_s)

    @cython.locals(t=double, half=double, sampled=int, clock="double[::1]")
    cpdef int tick(self, int stage) except? -2

    @cython.locals(history="double[::1]", due=double, k=Py_ssize_t)
    cdef int _touch_due(self, double t) except -1

    @cython.locals(clock="double[::1]")
    cpdef sample_now(self, double t)

    cpdef quick_state(self)

    @cython.locals(k=Py_ssize_t, size=Py_ssize_t, adr=long)
    cpdef bind_history(self, history, touch_history_adr)

    @cython.locals(i=Py_ssize_t, size=Py_ssize_t)
    cpdef bind(self, double[::1] sensordata)

    @cython.locals(
        k=Py_ssize_t, i=Py_ssize_t, j=Py_ssize_t, adr=long, n_cells=Py_ssize_t, p=double, peak=double, q=double, truth=double,
        past=bint, c=sc.ChannelCore, fractions=list, values="double[::1]", sensordata="double[::1]",
        gel_valid=double, backstop=double, share=double, mode=int, pressure=double, sigma=double, status=int, code=double,
    )
    cpdef sample(self, double period_s)

    @cython.locals(i=Py_ssize_t, sensordata="double[::1]", adr="long[::1]", values="double[::1]")
    cpdef write(self)

    cpdef list values(self)
