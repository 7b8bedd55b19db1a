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

from piezotip.sensor import _kernel_helpers as kh
from piezotip.sensor._channel import ChannelCore
from piezotip.sensor.estimator import Estimate

#: The sensor values a fingertip writes, in :data:`cosim.attach.SENSOR_FIELDS`' order.
VALUES_PER_TIP = 5
#: What the pass reads of an estimate: its slots (compiled) or its attributes.
_ESTIMATE = ("pressure_pa", "uncertainty_pa", "status")
_ESTIMATE_AT, _ESTIMATE_GET = kh.slot_offsets(Estimate, 3, _ESTIMATE), attrgetter(*_ESTIMATE)


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
        "_codes",
        "_cores",
        "_fractions",
        "_gel_valid",
        "_n",
        "_outside",
        "_readers",
        "_samples",
        "_sensor_adr",
        "_sensordata",
        "_touch_adr",
        "_values",
        "estimates",
        "pasts",
        "readings",
        "truths",
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
        self._sensordata = None
        # The last period's records, by fingertip (None before the first): what readings() makes
        # its TipReading objects from.
        self.readings = [None] * n
        self.estimates = [None] * n
        self.truths = [math.nan] * n
        self.pasts = [False] * n

    def bind(self, sensordata) -> None:
        """Read and write ``sensordata`` (an MjData's, float64, contiguous) from now on."""
        size = len(sensordata)
        for i in range(len(self._sensor_adr)):
            if not 0 <= self._sensor_adr[i] < size:
                raise ValueError(f"a fingertip's sensor address lies outside sensordata ({size} values)")
        for i in range(self._n):
            if self._touch_adr[i] >= size:
                raise ValueError(f"a touch pad's sensor address lies outside sensordata ({size} values)")
        self._sensordata = sensordata

    def sample(self, period_s: float) -> None:
        """Every fingertip's pressures, reading and estimate after ``period_s`` s, and its
        sensor values (written into ``sensordata`` by :meth:`write`)."""
        sensordata, fractions_of, values = self._sensordata, self._fractions, self._values
        gel_valid, backstop = self._gel_valid, self._backstop
        for k in range(self._n):
            fractions = fractions_of[k]
            adr = self._touch_adr[k]
            if adr >= 0:  # a touch pad: its zone's force over its area, uniform
                p = float(sensordata[adr]) / self._areas[k]
                cells = [p]
                peak = p
            else:
                (profile,), (cells,) = self._readers[k]()
                peak = profile[0]
                for q in profile:  # max(profile): the first largest, as Python's max keeps it
                    if q > peak:
                        peak = q
            # The coverage's mean pressure (one cell: fsum of one value is that value).
            n_cells = len(cells)
            if n_cells != len(fractions):
                raise ValueError(f"fingertip {k}: {n_cells} coverage cells read for {len(fractions)} shares")
            if n_cells == 1:
                truth = cells[0] * fractions[0]
            else:
                truth = math.fsum([cells[j] * fractions[j] for j in range(n_cells)])
            core = self._cores[k]
            if core is not None:
                c = core  # (a C call, compiled)
                reading, estimate = c.sample(cells, period_s)
            else:
                reading, estimate = self._samples[k](cells, period_s)
            # Past where the model holds (a strip over the element past the gel's valid strain,
            # the element on its backstop), whatever the readout said: the simulator knows.
            past = truth > backstop or peak > gel_valid
            self.readings[k], self.estimates[k], self.truths[k], self.pasts[k] = reading, estimate, truth, past
            pressure, sigma, status = kh.fields(estimate, Estimate, _ESTIMATE_AT, 3, _ESTIMATE_GET)
            mode = reading.mode
            i = VALUES_PER_TIP * k
            values[i] = float(pressure)
            values[i + 1] = float(sigma)
            values[i + 2] = float(self._outside if past else self._codes.get(status, -1))
            values[i + 3] = float(mode)
            values[i + 4] = truth

    def write(self) -> None:
        """The last values into ``sensordata`` (at every step: MuJoCo zeroes ``user`` sensors)."""
        sensordata, adr, values = self._sensordata, self._sensor_adr, self._values
        for i in range(len(adr)):
            sensordata[adr[i]] = values[i]

    def values(self) -> list:
        """The sensor values now, in the fingertips' order (:data:`VALUES_PER_TIP` each)."""
        return [float(v) for v in self._values]
