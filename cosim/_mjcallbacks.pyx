# cython: language_level=3, boundscheck=False, wraparound=False
"""MuJoCo's two callbacks as C functions: :mod:`cosim.mjhooks`'s dispatchers, compiled.

Not a kernel with a Python twin: the twin is :mod:`cosim.mjhooks`'s ctypes dispatchers, which
run where this module was not built (no C compiler at install) or under
``PIEZOTIP_PURE_PYTHON``; both run the same hooks in the same order, so ``sensordata`` is the
same bits either way (``tests/test_attach_sensordata.py``).  What the C spares is the step's
way into Python: MuJoCo calls ``mjcb_passive`` and ``mjcb_sensor`` for every model in the
process, and a ctypes callback costs ~0.4 us a call even where it only finds that the MjData has
no hooks.  Here that finding is a scan of a C table of the bound MjData's addresses, without the
GIL; only a bound MjData's step goes into Python: its sensor hook's fast path (``fast[address](stage)``,
:data:`cosim.mjhooks._FAST`), or, where there is none or it returns < 0, mjhooks' own Python
dispatch of its hooks (the ctypes functions ``configure`` is given).

The tables are replaced, never changed in place, and a replaced one is never freed: a thread
stepping another model without the GIL (``mujoco.rollout``) may still be reading it.  One table
is a few bytes a bound MjData; they accumulate with every register and unregister (a Gym
environment made and dropped a thousand times: tens of kB).  The buffers a table's readout
entries point into are kept alive for the newest two tables (a stepping thread reads the newest,
or the one it took just before a swap).
"""

from cpython.ref cimport PyObject
from libc.stdint cimport uintptr_t
from libc.stdlib cimport malloc

from piezotip.cosim._readout cimport ReadoutPass

ctypedef void (*passive_fn)(const void*, void*) noexcept nogil
ctypedef void (*sensor_fn)(const void*, void*, int) noexcept nogil


cdef struct Quick:
    # A readout pass's buffers (cosim._readout.ReadoutPass.quick_state), for the steps that
    # sample nothing: taken here without the GIL as its tick takes them.
    double* sensordata
    Py_ssize_t clock_adr
    int stage
    double* clock  # the last step's time, the next sample's, the period, half a step (s)
    Py_ssize_t n_values
    long* sensor_adr
    double* values
    Py_ssize_t n_touch
    long* touch_history
    double* history  # NULL: no touch sensor computed once a period
    PyObject* owner  # the pass (its tick, called in C for a step that samples; kept alive by _kept)


cdef struct Table:
    Py_ssize_t n
    uintptr_t* address  # the MjData's mjData* addresses
    char* fast  # 1 where the MjData's sensor hook has a fast path
    Quick* quick  # its readout pass's buffers (sensordata NULL: none; the fast path's call)


cdef Table _EMPTY
_EMPTY.n = 0
cdef Table* _passive_table = &_EMPTY
cdef Table* _sensor_table = &_EMPTY
cdef passive_fn _passive_previous = NULL
cdef passive_fn _passive_hooks = NULL
cdef sensor_fn _sensor_previous = NULL
cdef sensor_fn _sensor_hooks = NULL
cdef dict _fast_of = {}
cdef object _failed = None


cdef Py_ssize_t _find(const Table* table, uintptr_t address) noexcept nogil:
    cdef Py_ssize_t i
    for i in range(table.n):
        if table.address[i] == address:
            return i
    return -1


cdef void passive(const void* m, void* d) noexcept nogil:
    if _passive_previous != NULL:
        _passive_previous(m, d)
    if _passive_hooks != NULL and _find(_passive_table, <uintptr_t>d) >= 0:
        _passive_hooks(m, d)


cdef int _fast_sensor(uintptr_t address, int stage) noexcept with gil:
    """The fast path's verdict (mjhooks' ``_sensor``): >= 0 done, < 0 the hooks' own dispatch
    must run.  An exception is kept by ``failed`` (for mjhooks.raise_failure), which raises it
    again: printed here as ctypes prints its callbacks' (MuJoCo's C cannot take it), and 0."""
    fast = _fast_of.get(address)
    if fast is None:
        return -1
    try:
        return fast(stage)
    except BaseException as err:
        _failed(address, err)
        raise


cdef int _quick(const Quick* q, int stage) noexcept nogil:
    """ReadoutPass.tick on a step that samples nothing (its twin: the same branches, the same
    writes; tests/test_attach_sensordata.py compares the two dispatchers' sensordata): 0 done,
    -1 the pass's own tick must run (a sample, or the time went back)."""
    cdef double t, half, due
    cdef Py_ssize_t i
    if stage != q.stage:
        return 0
    t = q.sensordata[q.clock_adr]
    half = q.clock[3]
    if t < q.clock[0] - half or t >= q.clock[1] - half:
        return -1
    q.clock[0] = t
    if q.history != NULL and t >= q.clock[1] - 3.0 * half:  # the step before a sample: the touch sensors due
        due = t - q.clock[2] - half
        for i in range(q.n_touch):
            if q.touch_history[i] >= 0:
                q.history[q.touch_history[i]] = due
    for i in range(q.n_values):
        q.sensordata[q.sensor_adr[i]] = q.values[i]
    return 0


cdef int _pass_tick(PyObject* owner, uintptr_t address, int stage) noexcept with gil:
    """The pass's own tick, called in C (a step that samples, or goes back): as :func:`_fast_sensor`."""
    try:
        return (<ReadoutPass>owner).tick(stage)
    except BaseException as err:
        _failed(address, err)
        raise


cdef void sensor(const void* m, void* d, int stage) noexcept nogil:
    cdef const Table* table
    cdef Py_ssize_t i
    if _sensor_previous != NULL:
        _sensor_previous(m, d, stage)
    table = _sensor_table
    i = _find(table, <uintptr_t>d)
    if i < 0:
        return
    if table.quick[i].sensordata != NULL:  # (its tick is the fast path: not asked twice)
        if _quick(&table.quick[i], stage) >= 0 or _pass_tick(table.quick[i].owner, <uintptr_t>d, stage) >= 0:
            return
    elif table.fast[i] and _fast_sensor(<uintptr_t>d, stage) >= 0:
        return
    if _sensor_hooks != NULL:
        _sensor_hooks(m, d, stage)


def addresses():
    """The C dispatchers' addresses, (passive, sensor): for ctypes function pointers MuJoCo's
    ``set_mjcb_*`` take."""
    return <uintptr_t>&passive, <uintptr_t>&sensor


def configure(uintptr_t passive_previous, uintptr_t sensor_previous, uintptr_t passive_hooks, uintptr_t sensor_hooks, dict fast_of, failed):
    """The callbacks set before the dispatchers (called first, for every model; 0: none), the
    Python dispatch of a bound MjData's hooks (C function pointers of mjhooks' ctypes functions),
    the fast paths by address (mjhooks' dict, read at each call) and what keeps a fast path's
    exception (``failed(address, error)``)."""
    global _passive_previous, _sensor_previous, _passive_hooks, _sensor_hooks, _fast_of, _failed
    _passive_previous = <passive_fn>passive_previous
    _sensor_previous = <sensor_fn>sensor_previous
    _passive_hooks = <passive_fn>passive_hooks
    _sensor_hooks = <sensor_fn>sensor_hooks
    _fast_of, _failed = fast_of, failed


#: The buffers the tables' Quick entries point into, kept alive while a table may be read (the
#: last few tables': a replaced table is never freed, but a stepping thread reads only the newest
#: or the one before it).
_kept = []


cdef double* _doubles(object buffer, list keep) except? NULL:
    cdef double[::1] view = buffer
    keep.append(view)
    return &view[0] if view.shape[0] else NULL


cdef long* _longs(object buffer, list keep) except? NULL:
    cdef long[::1] view = buffer
    keep.append(view)
    return &view[0] if view.shape[0] else NULL


cdef int _fill_quick(Quick* q, object owner, list keep) except -1:
    """``q`` from a pass's quick_state() (``owner`` None, or no state: no quick path, its
    sensordata NULL)."""
    q.sensordata = NULL
    state = None if owner is None else owner.quick_state()
    if state is None:
        return 0
    keep.append(owner)
    q.owner = <PyObject*>owner
    sensordata, clock_adr, stage, clock, sensor_adr, values, touch_history, history = state
    q.n_values, q.n_touch = len(values), len(touch_history)
    if len(sensor_adr) != q.n_values or len(clock) != 4:
        raise ValueError("quick_state: a sensor address per value and a clock of four times")
    q.clock_adr, q.stage = clock_adr, stage
    q.clock = _doubles(clock, keep)
    q.sensor_adr, q.values = _longs(sensor_adr, keep), _doubles(values, keep)
    q.touch_history = _longs(touch_history, keep)
    q.history = NULL if history is None else _doubles(history, keep)
    q.sensordata = _doubles(sensordata, keep)
    return 0


cdef Table* _table(list addresses, list fast, list quick, list keep) except NULL:
    cdef Py_ssize_t i, n = len(addresses)
    cdef Table* table = <Table*>malloc(sizeof(Table) + n * (sizeof(Quick) + sizeof(uintptr_t) + 1))
    if table == NULL:
        raise MemoryError("piezotip: no memory for the MuJoCo callbacks' table")
    table.quick = <Quick*>(<char*>table + sizeof(Table))
    table.address = <uintptr_t*>(table.quick + n)
    table.fast = <char*>(table.address + n)
    for i in range(n):
        table.address[i] = <uintptr_t>addresses[i]
        table.fast[i] = 1 if fast[i] else 0
        _fill_quick(&table.quick[i], quick[i] if isinstance(quick[i], ReadoutPass) else None, keep)
    table.n = n
    return table


def set_tables(list passive_addresses, list sensor_addresses, list sensor_fast, list sensor_quick=None):
    """The MjData whose hooks each callback runs (mjData* addresses), and for the sensor's,
    which have a fast path (bools in the same order) and which a readout pass (compiled:
    cosim._readout.ReadoutPass; or None) whose fast path is its tick, taken here: a step that
    samples nothing without the GIL (its ``quick_state()``), the others through its tick in C."""
    global _passive_table, _sensor_table
    keep = []
    quick = [None] * len(sensor_addresses) if sensor_quick is None else sensor_quick
    cdef Table* passive_table = _table(passive_addresses, [False] * len(passive_addresses), [None] * len(passive_addresses), keep)
    cdef Table* sensor_table = _table(sensor_addresses, sensor_fast, quick, keep)
    _passive_table, _sensor_table = passive_table, sensor_table
    _kept.append(keep)
    del _kept[:-2]
