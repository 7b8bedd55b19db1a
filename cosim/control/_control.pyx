# cython: language_level=3
"""The controller's per-reading parts, compiled: :class:`cosim.control.selector.PyModeSelector`,
:class:`cosim.control.selector.PyTouchDetector` and the per-step records' makers
(:func:`cosim.control.interface.py_make_pad_signal`, ``py_make_observation``,
``py_make_command``) in C.

The same decisions, the same reasons and the same floats, reading for reading
(tests/test_compiled_twins.py): the state lives in typed fields, the arithmetic is the
reference's in its order (``1 + h`` as ``1.0 + h``, Python's ``max(0.0, s)`` as
``s if s > 0.0 else 0.0``), Python's float division (``cdivision`` off: a zero sigma raises as
in Python), and the reasons are the same :class:`Why` objects and f-strings.  Copies (a
CoSimulation is deep-copied whole) use Cython's pickling of the fields.  The records are the
same frozen slots dataclass instances, every slot written in C in the fields' order.
"""

from libc.math cimport isfinite

from _twin_helpers cimport new_record, put_slot, slot_offsets

from piezotip.cosim.control.interface import Command, Observation, PadSignal, Why


cdef object _new = object.__new__


cdef inline object _why(str template, tuple args):
    """``Why(template, *args)`` without the call of its Python ``__init__`` (a third of an update)."""
    w = _new(Why)
    w.template = template
    w.args = args
    return w


# Each record's slot offsets, in its fields' order (the makers below fill every one).
cdef Py_ssize_t[2] _PAD_SIGNAL_AT
cdef Py_ssize_t[7] _OBSERVATION_AT
cdef Py_ssize_t[6] _COMMAND_AT
slot_offsets(PadSignal, _PAD_SIGNAL_AT, 2)
slot_offsets(Observation, _OBSERVATION_AT, 7)
slot_offsets(Command, _COMMAND_AT, 6)


def make_pad_signal(reading, estimate):
    """The compiled :func:`cosim.control.interface.py_make_pad_signal` (see there)."""
    s = new_record(PadSignal)
    put_slot(s, _PAD_SIGNAL_AT[0], reading)
    put_slot(s, _PAD_SIGNAL_AT[1], estimate)
    return s


def make_observation(time_s, pads, lift_pos_m, opening_m, lift_force_n, grip_force_n, lift_vel_m_s=0.0):
    """The compiled :func:`cosim.control.interface.py_make_observation` (see there)."""
    o = new_record(Observation)
    put_slot(o, _OBSERVATION_AT[0], time_s)
    put_slot(o, _OBSERVATION_AT[1], pads)
    put_slot(o, _OBSERVATION_AT[2], lift_pos_m)
    put_slot(o, _OBSERVATION_AT[3], opening_m)
    put_slot(o, _OBSERVATION_AT[4], lift_force_n)
    put_slot(o, _OBSERVATION_AT[5], grip_force_n)
    put_slot(o, _OBSERVATION_AT[6], lift_vel_m_s)
    return o


def make_command(lift_m, opening_m, grip_force_limit_n, modes, phase, reason):
    """The compiled :func:`cosim.control.interface.py_make_command` (see there)."""
    c = new_record(Command)
    put_slot(c, _COMMAND_AT[0], lift_m)
    put_slot(c, _COMMAND_AT[1], opening_m)
    put_slot(c, _COMMAND_AT[2], grip_force_limit_n)
    put_slot(c, _COMMAND_AT[3], modes)
    put_slot(c, _COMMAND_AT[4], phase)
    put_slot(c, _COMMAND_AT[5], reason)
    return c


def _reference():
    # Imported when first needed: cosim/control/selector.py imports this module at its end.
    from piezotip.cosim.control import selector

    return selector


cdef class ModeSelector:
    """The compiled :class:`cosim.control.selector.PyModeSelector` (see there)."""

    cdef public tuple modes, bands
    cdef public object fingertip
    cdef public dict p_min_pa, p_max_pa, switch_pa
    cdef public double hysteresis, estimate_pa, uncertainty_pa
    cdef public int persist, mode
    cdef public bint blind, trusted
    cdef public str status
    cdef readonly dict _neighbours
    cdef readonly int _saturated, _above_switch, _under_switch

    def __init__(self, fingertip, modes, hysteresis=0.25, persist=3):
        reference = _reference().PyModeSelector(fingertip, modes, hysteresis, persist)  # its set-up and checks
        self.modes, self.bands, self.fingertip = reference.modes, reference.bands, reference.fingertip
        self.p_min_pa, self.p_max_pa, self.switch_pa = reference.p_min_pa, reference.p_max_pa, reference.switch_pa
        self._neighbours = reference._neighbours
        self.hysteresis, self.persist, self.mode = reference.hysteresis, reference.persist, reference.mode
        self._saturated = self._above_switch = self._under_switch = 0
        self.blind, self.trusted = reference.blind, reference.trusted
        self.estimate_pa, self.uncertainty_pa, self.status = reference.estimate_pa, reference.uncertainty_pa, reference.status

    def update(self, estimate):
        """Take one readout estimate; return (mode to drive next, why) (see the reference)."""
        cdef str status = estimate.status
        cdef object up, down
        cdef double up_pa, down_pa, p, h, pressure
        cdef bint above, under
        if status == "settling":
            self.trusted = False
            return self.mode, _why("mode {}: settling, holding {:.3g} Pa", (self.mode, self.estimate_pa))
        self.trusted = True
        self.blind = False
        if status == "ok" or status == "below_detection":
            pressure = estimate.pressure_pa
            if isfinite(pressure):
                self.estimate_pa, self.uncertainty_pa, self.status = pressure, estimate.uncertainty_pa, status
        up, down, up_pa, down_pa = self._neighbours[self.mode]
        p = self.estimate_pa
        self._saturated = self._saturated + 1 if status == "saturated" else 0
        h = self.hysteresis
        above = up is not None and (status == "saturated" or (status == "ok" and p > up_pa * (1.0 + h)))
        under = down is not None and (status == "below_detection" or (status == "ok" and p < down_pa * (1.0 - h)))
        self._above_switch = self._above_switch + 1 if above else 0
        self._under_switch = self._under_switch + 1 if under else 0
        if up is None and self._saturated >= self.persist:
            self.blind = True
            why = _why("mode {}: saturated and no higher mode allowed (blind above {:.3g} Pa)", (self.mode, self.p_max_pa[self.mode]))
            return self.mode, why
        if self._above_switch >= self.persist:
            if status == "saturated":
                return self._switch(up, f"mode {self.mode} saturated (P > {self.p_max_pa[self.mode]:.3g} Pa)")
            return self._switch(up, f"P {p:.3g} Pa above switch {up_pa:.3g} Pa x {1.0 + h:g}")
        if self._under_switch >= self.persist:
            if status == "below_detection":
                return self._switch(down, f"mode {self.mode} below detection (P < {self.p_min_pa[self.mode]:.3g} Pa)")
            return self._switch(down, f"P {p:.3g} Pa below switch {down_pa:.3g} Pa x {1.0 - h:g}")
        return self.mode, _why("mode {}: {}, P {:.3g} Pa", (self.mode, status, self.estimate_pa))

    cdef tuple _switch(self, int mode, str why):
        cdef int old = self.mode
        self.mode = mode
        self._saturated = self._above_switch = self._under_switch = 0
        self.trusted = False
        return mode, f"switch {old} -> {mode}: {why}"

    @property
    def empty(self):
        """The fingertip reads no load: below detection in its lowest allowed mode."""
        return self.trusted and self.status == "below_detection" and self.mode == self.modes[0]


cdef class TouchDetector:
    """The compiled :class:`cosim.control.selector.PyTouchDetector` (see there)."""

    cdef public double sigma, drift_sigma, alarm_sigma, single_sigma, baseline, score
    cdef public bint touched
    cdef readonly double _sum
    cdef readonly Py_ssize_t _count

    def __init__(self, double sigma, double drift_sigma=0.5, double alarm_sigma=8.0, double single_sigma=6.0):
        self.sigma = sigma
        self.drift_sigma, self.alarm_sigma, self.single_sigma = drift_sigma, alarm_sigma, single_sigma
        self.baseline = float("nan")
        self._sum = 0.0
        self._count = 0
        self.score = 0.0
        self.touched = False

    def learn(self, double v1):
        """Add an unloaded reading to the baseline."""
        self._sum += v1
        self._count += 1
        self.baseline = self._sum / <double>self._count

    def rearm(self):
        """Forget an alarm (the baseline stays): the next significant drop alarms again."""
        self.score, self.touched = 0.0, False

    def update(self, double v1):
        """Take a reading; True once the drop is significant (latched)."""
        cdef double drop, s
        if not self.touched:
            drop = (self.baseline - v1) / self.sigma
            s = self.score + drop - self.drift_sigma
            self.score = s if s > 0.0 else 0.0
            self.touched = self.score > self.alarm_sigma or drop > self.single_sigma
        return self.touched
