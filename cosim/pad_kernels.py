"""The pads' per-step arithmetic: the gel law's force on every strip joint, and the pads' pressure read.

Every physics step (or control period) :class:`cosim.pads.PadBridge` applies the gel's law to
each pad strip joint, and every control period the co-simulation reads the compressive gel
pressure of the strips over each fingertip's element and coverage.  Both are a table lookup
per strip (the gel law P(q) and its tangent dP/dq on a uniform grid of indentations:
:class:`sensor.lookup.PyUniformPairTable`) and a little arithmetic:

- :class:`PyGelForces`: for each strip of area A, indentation q and spring reference q0, the
  joint stiffness A dP/dq (N/m: the tangent, so the discrete integrator treats the law
  implicitly) and the applied force A dP/dq (q - q0) - A P(q) (N), so that the explicit force
  on the joint is exactly -A P(q);
- :class:`PyPadPressures`: per pad, the compressive pressure max(P(q), 0) (Pa; the gel rests
  unbonded on the element) of its element strips, root to tip, and of each coverage cell, the
  strips' pressures weighted (:func:`cosim.loop.coverage_weights`).

Both work on live arrays bound once (:meth:`bind`: ``data.qpos``, ``data.qfrc_applied``,
``model.jnt_stiffness``), not on MuJoCo objects.  They are the references, the ones to read;
``cosim/_pad_kernels.pyx`` holds their compiled twins (the same arithmetic in the same order,
bit for bit: tests/test_compiled_twins.py), used where built (:mod:`sensor.compiled`;
:data:`PAD_KERNELS_COMPILED` says).
"""

from __future__ import annotations

from collections.abc import Sequence

from piezotip.sensor.compiled import twin
from piezotip.sensor.lookup import UniformPairTable

__all__ = ["PAD_KERNELS_COMPILED", "GelForces", "PadPressures", "PyGelForces", "PyPadPressures"]


def _checked_indices(name: str, indices: Sequence[int], size: int) -> None:
    bad = [i for i in indices if not 0 <= i < size]
    if bad:
        raise ValueError(f"{name} indices {bad[:5]} are outside an array of {size}")


class PyGelForces:
    """The gel law on every pad strip joint (see the module).

    Parameters
    ----------
    table : (grid_m, pressure_pa, tangent_pa_m): the gel law P(q) and dP/dq on a uniform grid
        of indentations q (m), Pa and Pa/m.
    qadr, dof, jnt : per strip, its joint's qpos address, dof address and joint id.
    area_m2 : per strip, its area, m^2.
    qspring_m : per strip, its joint's spring reference, m.
    """

    __slots__ = ("_args", "_at", "_qfrc", "_qpos", "_stiffness", "_strips")

    def __init__(self, table, qadr, dof, jnt, area_m2, qspring_m) -> None:
        self._args = (table, qadr, dof, jnt, area_m2, qspring_m)
        self._at = UniformPairTable(*table).at
        qadr, dof, jnt = ([int(i) for i in v] for v in (qadr, dof, jnt))
        area_m2, qspring_m = [float(a) for a in area_m2], [float(q) for q in qspring_m]
        if not len(qadr) == len(dof) == len(jnt) == len(area_m2) == len(qspring_m):
            raise ValueError("every strip needs a qpos address, a dof, a joint, an area and a spring reference")
        self._strips = tuple(zip(qadr, dof, jnt, area_m2, qspring_m, strict=True))
        self._qpos = self._qfrc = self._stiffness = None

    def bind(self, qpos, qfrc_applied, jnt_stiffness) -> None:
        """Work on these arrays from now on (float64, 1-D: MuJoCo's ``data.qpos``,
        ``data.qfrc_applied`` and ``model.jnt_stiffness``, or memoryviews of them)."""
        qadr, dof, jnt, _, _ = zip(*self._strips, strict=True) if self._strips else ((), (), (), (), ())
        _checked_indices("qpos", qadr, len(qpos))
        _checked_indices("dof", dof, len(qfrc_applied))
        _checked_indices("joint", jnt, len(jnt_stiffness))
        self._qpos, self._qfrc, self._stiffness = memoryview(qpos), memoryview(qfrc_applied), memoryview(jnt_stiffness)

    def apply(self) -> None:
        """Write each strip joint's stiffness and applied force for the state in ``qpos``."""
        qpos, qfrc, stiffness, at = self._qpos, self._qfrc, self._stiffness, self._at
        if qpos is None:
            raise RuntimeError("bind() the arrays first")
        for qadr, dof, jnt, area, qspring in self._strips:
            q = qpos[qadr]
            pressure, tangent = at(q)
            k = area * tangent
            stiffness[jnt] = k
            qfrc[dof] = k * (q - qspring) - area * pressure

    def __reduce__(self):  # a copy is unbound: its owner binds it to its own arrays
        return type(self), self._args


class PyPadPressures:
    """The pads' pressure read (see the module).

    Parameters
    ----------
    table : (grid_m, pressure_pa, tangent_pa_m), as :class:`PyGelForces`'s.
    qadr : the qpos addresses of the strips read, pad after pad, ``per_pad`` each.
    per_pad : strips read per pad.
    element : positions among a pad's strips read of its element strips, root to tip.
    weights : per coverage cell, (position among a pad's strips read, weight) pairs: the cell's
        pressure is the weighted sum of those strips' pressures.
    """

    __slots__ = ("_args", "_at", "_element", "_per_pad", "_qadr", "_qpos", "_weights")

    def __init__(self, table, qadr, per_pad: int, element, weights) -> None:
        self._args = (table, qadr, per_pad, element, weights)
        self._at = UniformPairTable(*table).at
        self._qadr = [int(i) for i in qadr]
        self._per_pad = int(per_pad)
        self._element = [int(i) for i in element]
        self._weights = [[(int(i), float(w)) for i, w in row] for row in weights]
        if self._per_pad < 1 or len(self._qadr) % self._per_pad:
            raise ValueError(f"{len(self._qadr)} strips read do not make pads of {self._per_pad}")
        _checked_indices("element", self._element, self._per_pad)
        _checked_indices("weight", [i for row in self._weights for i, _ in row], self._per_pad)
        if not all(self._weights):
            raise ValueError("every coverage cell needs at least one weighted strip")
        self._qpos = None

    def bind(self, qpos) -> None:
        """Read this array from now on (``data.qpos``, float64, 1-D, or a memoryview of it)."""
        _checked_indices("qpos", self._qadr, len(qpos))
        self._qpos = memoryview(qpos)

    def read(self) -> tuple[list[list[float]], list[list[float]]]:
        """Per pad: the compressive pressure of its element strips, root to tip, and the mean
        pressure of each coverage cell, Pa (lists of Python floats)."""
        qpos, at = self._qpos, self._at
        if qpos is None:
            raise RuntimeError("bind() the array first")
        values = [max(at(qpos[a])[0], 0.0) for a in self._qadr]
        n, element, weights = self._per_pad, self._element, self._weights
        profiles, covered = [], []
        for start in range(0, len(values), n):
            profiles.append([values[start + i] for i in element])
            covered.append([sum([w * values[start + i] for i, w in row]) for row in weights])
        return profiles, covered

    def __reduce__(self):
        return type(self), self._args


#: The compiled twins of :class:`PyGelForces` and :class:`PyPadPressures` where built, else they.
GelForces, PAD_KERNELS_COMPILED = twin("piezotip.cosim._pad_kernels", "GelForces", PyGelForces)
PadPressures, _ = twin("piezotip.cosim._pad_kernels", "PadPressures", PyPadPressures)
