# cython: boundscheck=False, wraparound=False, initializedcheck=False
# (compiled, an index is not checked where it is read: every one is checked once, in __init__ and bind.)
"""Every attached fingertip's readout in one call a period, written into ``data.sensordata``.

A kernel (:mod:`piezotip.sensor.compiled`): this module runs as Python and, where built,
compiled (``_readout.pxd`` types it).  :class:`ReadoutPass` is what the fingertips' sensor hook
(:class:`cosim.attach.FingertipLoop`, inside MuJoCo's ``mj_step``) runs: once a period, for
each fingertip in order, its pad's pressures (a touch pad's from its ``touch`` sensor, read in
C; a gel pad's from its strips), its channel's reading and estimate (one C call of its
:class:`sensor._channel.ChannelCore` where the channel's per-step path is its core's), the
coverage's true mean pressure and whether the model still holds there, and the fingertip's five
sensor values; at every step, those values copied into ``sensordata`` (MuJoCo zeroes ``user``
sensors each step).  In Python a fingertip's period cost about a microsecond of loop glue
around the channel's own call, which on a skin of many fingertips was most of the readout.
"""

from __future__ import annotations

import math
from array import array
from operator import attrgetter

from piezotip.sensor import _estimator as se
from piezotip.sensor import _kernel_helpers as kh
from piezotip.sensor._channel import ChannelCore
from piezotip.sensor.estimator import Estimate

#: The sensor values a fingertip writes, in :data:`cosim.attach.SENSOR_FIELDS`' order.
VALUES_PER_TIP = 5
#: What the pass reads of an estimate: its slots (compiled) or its attributes.
_ESTIMATE = ("pressure_pa", "uncertainty_pa", "status")
_ESTIMATE_AT, _ESTIMATE_GET = kh.slot_offsets(Estimate, 3, _ESTIMATE), attrgetter(*_ESTIMATE)


#: The pass's clock array's entries (ReadoutPass._clock): the last step's time, the next
#: sample's, the period and half a step, s.
_LAST, _NEXT, _PERIOD, _HALF = 0, 1, 2, 3


class ReadoutPass:
    """One period's readout of every fingertip of a model (the module docstring).

    Parameters
    ----------
    samples : each fingertip's ``channel.sample`` (its :class:`sensor.channel.SensorChannel`'s
        reading and estimate in one call; a :class:`ChannelCore`'s bound method is called in C).
    readers : each fingertip's per-period read of a gel pad (``(profile,), (cells,)``: the
        element strips' pressures and the coverage cells', Pa), or None for a touch pad.
    touch_adr : each touch pad's ``touch`` sensor address in ``sensordata`` (-1 for a gel pad).
    areas_m2 : each touch pad's area, m^2 (its zone's force over it presses the element).
    fractions : each fingertip's coverage cells' shares of the coverage's length.
    sensor_adr : the fingertips' sensors' addresses in ``sensordata``, :data:`VALUES_PER_TIP` a
        fingertip, in order.
    first : the values written before the first period (one per address).
    gel_valid_pa : the gel's largest valid pressure, Pa (a strip past it: outside the model).
    backstop_pa : the coverage pressure that puts the element on its backstop, Pa (inf: none).
    status_codes : each estimate status's code; ``outside_code``: the code of a reading past
        where the model holds.
    """

    __slots__ = (
        "_areas",
        "_backstop",
        "_clock",
        "_clock_adr",
        "_code_at",
        "_codes",
        "_cores",
        "_fractions",
        "_gel_valid",
        "_history",
        "_n",
        "_outside",
        "_pasts",
        "_readers",
        "_records",
        "_samples",
        "_sensor_adr",
        "_sensordata",
        "_size",
        "_stage",
        "_touch_adr",
        "_touch_history",
        "_truths",
        "_values",
        "periods",
    )

    def __init__(
        self, samples, readers, touch_adr, areas_m2, fractions, sensor_adr, first, gel_valid_pa, backstop_pa, status_codes, outside_code
    ) -> None:
        n = len(samples)
        if not (len(readers) == len(touch_adr) == len(areas_m2) == len(fractions) == n):
            raise ValueError("one reader, touch address, area and coverage shares per fingertip")
        if len(sensor_adr) != VALUES_PER_TIP * n or len(first) != len(sensor_adr):
            raise ValueError(f"{VALUES_PER_TIP} sensor addresses and first values per fingertip")
        for k in range(n):
            if (readers[k] is None) == (touch_adr[k] < 0):
                raise ValueError(f"fingertip {k}: a reader (gel pad) or a touch sensor address (touch pad), one of them")
        self._n = n
        self._samples = list(samples)
        # A channel whose per-step path is its core's: the core, called in C (else None).
        self._cores = [s.__self__ if type(getattr(s, "__self__", None)) is ChannelCore else None for s in samples]
        self._readers = list(readers)
        self._touch_adr = array("l", map(int, touch_adr))
        self._areas = array("d", map(float, areas_m2))
        self._fractions = [list(map(float, f)) for f in fractions]
        self._sensor_adr = array("l", map(int, sensor_adr))
        self._values = array("d", map(float, first))
        self._gel_valid, self._backstop = float(gel_valid_pa), float(backstop_pa)
        self._codes, self._outside = dict(status_codes), int(outside_code)
        # Each status's code by the index a core's estimate carries (sensor._estimator.STATUSES).
        self._code_at = array("d", [float(self._codes.get(name, -1)) for name in se.STATUSES])
        self._sensordata, self._size = None, 0  # (bind)
        # The touch sensors' history buffers, where MuJoCo computes them once a period (bind_history).
        self._history, self._touch_history = None, array("l", [-1] * n)
        # The last period's reading and estimate by fingertip: a channel's own records, or None
        # where its core keeps them as values (made when asked: readings, estimates).
        self._records = [None] * n
        self.periods = 0  # periods sampled
        self._truths = array("d", [math.nan] * n)
        self._pasts = array("b", [False] * n)
        # The per-step clock (set_clock): none yet.  Its times, s: the last step's, the next
        # sample's, the period and half a step, in one array that MuJoCo's C sensor dispatcher
        # reads and writes too (quick_state: its one owner is this pass).
        self._clock_adr, self._stage = -1, -1
        self._clock = array("d", [math.nan] * 4)

    def set_clock(self, clock_adr: int, stage: int, period_s: float, timestep_s: float, start_s: float) -> None:
        """Sample once a period of ``period_s`` s from ``start_s`` s (the first at ``start_s`` +
        ``period_s``), at MuJoCo's sensor ``stage``, the time read from a ``clock`` sensor at
        ``clock_adr`` in ``sensordata`` (:meth:`tick`); ``timestep_s`` the model's step, s."""
        self._clock_adr, self._stage = int(clock_adr), int(stage)
        clock = self._clock  # (written in place: the C dispatcher holds it)
        clock[_PERIOD], clock[_HALF] = float(period_s), 0.5 * float(timestep_s)
        clock[_LAST] = float(start_s)
        clock[_NEXT] = clock[_LAST] + clock[_PERIOD]

    def tick(self, stage: int) -> int:
        """MuJoCo's sensor callback at ``stage``: at the pass's stage, the time from the clock
        sensor; a period on since the last sample (within half a step): :meth:`sample`; the
        values into ``sensordata`` (MuJoCo zeroes ``user`` sensors at every step).  1: sampled,
        0: written or another stage, -1: the time went back (a reset, nothing done)."""
        if stage != self._stage:
            return 0
        if not 0 <= self._clock_adr < self._size:
            raise RuntimeError("tick: the readout pass has no clock in its sensordata (set_clock, bind)")
        t = self._sensordata[self._clock_adr]
        clock = self._clock
        half = clock[_HALF]
        if t < clock[_LAST] - half:
            return -1
        clock[_LAST] = t
        sampled = 0
        if t >= clock[_NEXT] - half:
            self.sample(clock[_PERIOD])
            clock[_NEXT] = t + clock[_PERIOD]
            sampled = 1
        elif t >= clock[_NEXT] - 3.0 * half and self._history is not None:
            self._touch_due(t)
        self.write()
        return sampled

    def _touch_due(self, t: float) -> None:
        """The step before a sample, at ``t`` s: the touch sensors computed at its acceleration
        stage whatever their interval's phase (a reset, a bind mid-period): MuJoCo computes an
        interval sensor at a step where its buffer's last tick plus the interval is <= the time
        (engine_sensor.c, ``compute_or_read_sensor``), and then advances that tick by the
        interval, to t - half a step: the next compute falls on the next period's step before
        its sample (:meth:`bind_history`)."""
        history, due = self._history, t - self._clock[_PERIOD] - self._clock[_HALF]
        for k in range(self._n):
            if self._touch_history[k] >= 0:
                history[self._touch_history[k]] = due

    def sample_now(self, t: float) -> None:
        """A period's end at ``t`` s in piezotip's own loop: :meth:`sample` and :meth:`write` now
        (the next step's callback, at this same time, only writes)."""
        clock = self._clock
        clock[_LAST] = t
        self.sample(clock[_PERIOD])
        clock[_NEXT] = t + clock[_PERIOD]
        self.write()

    def quick_state(self) -> tuple | None:
        """What MuJoCo's C sensor dispatcher (cosim/_mjcallbacks.pyx) needs to take a step that
        samples nothing without the GIL, as :meth:`tick` would: (sensordata, clock address,
        stage, the clock's times, the sensors' addresses, their values, the touch sensors'
        history addresses, the history or None), the pass's own buffers (it writes the clock's
        last time, sensordata and the history as :meth:`tick` does, and calls :meth:`tick` for a
        step that samples or goes back).  None before :meth:`bind` and :meth:`set_clock`."""
        if self._sensordata is None or not 0 <= self._clock_adr < self._size:
            return None
        return (
            self._sensordata,
            self._clock_adr,
            self._stage,
            self._clock,
            self._sensor_adr,
            self._values,
            self._touch_history,
            self._history,
        )

    def bind(self, sensordata) -> None:
        """Read and write ``sensordata`` (an MjData's, float64, contiguous) from now on."""
        size = len(sensordata)
        for i in range(len(self._sensor_adr)):
            if not 0 <= self._sensor_adr[i] < size:
                raise ValueError(f"a fingertip's sensor address lies outside sensordata ({size} values)")
        for i in range(self._n):
            if self._touch_adr[i] >= size:
                raise ValueError(f"a touch pad's sensor address lies outside sensordata ({size} values)")
        self._sensordata, self._size = sensordata, size

    def bind_history(self, history, touch_history_adr) -> None:
        """The touch sensors MuJoCo computes once a period (a sensor ``interval`` of the period,
        one history sample): ``history`` the MjData's (float64, contiguous), each touch pad's
        sensor's buffer address in it (its first slot the last tick's time), -1 where MuJoCo
        computes it at every step.  The sample reads the touch the step before it left (the
        position stage reads the last step's acceleration-stage sensors): :meth:`tick` makes
        MuJoCo compute them at that step (:meth:`_touch_due`); between samples they hold."""
        if len(touch_history_adr) != self._n:
            raise ValueError("one touch history address per fingertip (-1: none)")
        size = len(history)
        for k in range(self._n):
            adr = int(touch_history_adr[k])
            if adr >= size or (adr >= 0 and self._touch_adr[k] < 0):
                raise ValueError(f"fingertip {k}: a touch history address outside the history, or on a gel pad")
        self._touch_history = array("l", map(int, touch_history_adr))
        self._history = None
        for k in range(self._n):
            if self._touch_history[k] >= 0:
                self._history = history

    def sample(self, period_s: float) -> None:
        """Every fingertip's pressures, reading and estimate after ``period_s`` s, and its
        sensor values (written into ``sensordata`` by :meth:`write`)."""
        sensordata, fractions_of, values = self._sensordata, self._fractions, self._values
        gel_valid, backstop = self._gel_valid, self._backstop
        for k in range(self._n):
            fractions = fractions_of[k]
            adr = self._touch_adr[k]
            if adr >= 0:  # a touch pad: its zone's force over its area, uniform (one cell)
                p = float(sensordata[adr]) / self._areas[k]
                cells = None
                peak = p
            else:
                (profile,), (cells,) = self._readers[k]()
                peak = profile[0]
                for q in profile:  # max(profile): the first largest, as Python's max keeps it
                    if q > peak:
                        peak = q
            # The coverage's mean pressure (one cell: fsum of one value is that value).
            n_cells = 1 if cells is None else len(cells)
            if n_cells != len(fractions):
                raise ValueError(f"fingertip {k}: {n_cells} coverage cells read for {len(fractions)} shares")
            if cells is None:
                share = fractions[0]
                truth = p * share
            elif n_cells == 1:
                truth = cells[0] * fractions[0]
            else:
                truth = math.fsum([cells[j] * fractions[j] for j in range(n_cells)])
            core = self._cores[k]
            if core is not None:
                c = core  # (a C call, compiled)
                if cells is None:
                    mode, pressure, sigma, status = c.advance_one(p, period_s)
                else:
                    mode, pressure, sigma, status = c.advance(cells, period_s)
                code = self._code_at[status]
            else:
                reading, estimate = self._samples[k]([p] if cells is None else cells, period_s)
                self._records[k] = (reading, estimate)
                pressure, sigma, name = kh.fields(estimate, Estimate, _ESTIMATE_AT, 3, _ESTIMATE_GET)
                mode = reading.mode
                code = float(self._codes.get(name, -1))
            # Past where the model holds (a strip over the element past the gel's valid strain,
            # the element on its backstop), whatever the readout said: the simulator knows.
            past = truth > backstop or peak > gel_valid
            self._truths[k], self._pasts[k] = truth, past
            i = VALUES_PER_TIP * k
            values[i] = pressure
            values[i + 1] = sigma
            values[i + 2] = float(self._outside) if past else code
            values[i + 3] = float(mode)
            values[i + 4] = truth
        self.periods += 1

    @property
    def truths(self) -> list:
        """The last period's true mean pressure over each fingertip's coverage, Pa (NaN before the first)."""
        return [self._truths[k] for k in range(self._n)]

    @property
    def pasts(self) -> list:
        """Whether each fingertip's last period lay past where the model holds."""
        return [bool(self._pasts[k]) for k in range(self._n)]

    @property
    def readings(self) -> list:
        """The last period's readings, by fingertip (None before the first period)."""
        if not self.periods:
            return [None] * self._n
        return [self._cores[k].last_reading() if self._cores[k] is not None else self._records[k][0] for k in range(self._n)]

    @property
    def estimates(self) -> list:
        """The last period's estimates, by fingertip (None before the first period)."""
        if not self.periods:
            return [None] * self._n
        return [self._cores[k].last_estimate() if self._cores[k] is not None else self._records[k][1] for k in range(self._n)]

    def write(self) -> None:
        """The last values into ``sensordata`` (at every step: MuJoCo zeroes ``user`` sensors)."""
        sensordata, adr, values = self._sensordata, self._sensor_adr, self._values
        for i in range(len(adr)):
            sensordata[adr[i]] = values[i]

    def values(self) -> list:
        """The sensor values now, in the fingertips' order (:data:`VALUES_PER_TIP` each)."""
        return [float(v) for v in self._values]
