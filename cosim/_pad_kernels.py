# cython: boundscheck=False, wraparound=False, initializedcheck=False
# (compiled, an index is not checked where it is read: every one is checked once, when the
# arrays are bound or the tables built, or is one the lookup's own arithmetic keeps in range.)
"""The pads' per-step arithmetic: the gel law's lookup and force on every strip joint, the pads' pressure read.

A kernel (:mod:`piezotip.sensor.compiled`): this module runs as Python and, where built,
compiled (``_pad_kernels.pxd`` types it: the arrays bound once as typed memoryviews, read and
written directly).  The strips' addresses and numbers are held in arrays of C integers and
doubles (:mod:`array`), the gel law in a :class:`UniformPairTable`.
"""

from __future__ import annotations

import math
from array import array
from collections.abc import Sequence

import numpy as np


def _checked_indices(name: str, indices: Sequence[int], size: int) -> None:
    bad = [i for i in indices if not 0 <= i < size]
    if bad:
        raise ValueError(f"{name} indices {bad[:5]} are outside an array of {size}")


class UniformPairTable:
    """Two columns ``fa``, ``fb`` over an evenly spaced ``grid`` (strictly increasing), looked up
    at one Python float: ``(np.interp(x, grid, fa), np.interp(x, grid, fb))`` (the gel law P and
    dP/dq at an indentation).

    The same arithmetic as ``np.interp`` for each column: the interval j with grid[j] <= x <
    grid[j + 1], the slope (f[j+1] - f[j]) / (grid[j+1] - grid[j]) (tabulated once here) and
    f = slope (x - grid[j]) + f[j]; clamped to the end values outside the grid; NaN for NaN.
    One interval search serves both columns, and the grid is uniform, so j comes from one
    multiplication (then corrected by the grid's own values, so a grid that is uniform only to
    rounding still finds the right interval).  On numpy builds that do not fuse the multiply-add,
    the results are bitwise np.interp's (tests/test_channel_perf_equivalence.py checks).  Units
    are the grid's and the columns'.
    """

    __slots__ = ("_args", "_fa", "_fa_slope", "_fb", "_fb_slope", "_grid", "_inv_step", "_last", "_x0", "_xn")

    def __init__(self, grid, fa, fb) -> None:
        self._args = (grid, fa, fb)
        grid, fa, fb = (np.asarray(v, dtype=float) for v in (grid, fa, fb))
        if grid.ndim != 1 or grid.size < 2 or fa.shape != grid.shape or fb.shape != grid.shape or not np.all(np.diff(grid) > 0):
            raise ValueError(f"a table needs a strictly increasing grid of 2 or more points and columns of its shape, got {grid.shape}")
        dx = np.diff(grid)  # (np.diff: f[1:] - f[:-1])
        self._grid = array("d", [*grid.tolist(), math.inf])  # a sentinel past the end: grid[j + 1] always exists
        self._fa, self._fb = array("d", fa.tolist()), array("d", fb.tolist())
        self._fa_slope = array("d", (np.diff(fa) / dx).tolist())
        self._fb_slope = array("d", (np.diff(fb) / dx).tolist())
        self._last = grid.size - 1
        self._x0, self._xn = self._grid[0], self._grid[self._last]
        self._inv_step = self._last / (self._xn - self._x0)

    def at(self, x: float) -> tuple[float, float]:
        """(fa(x), fb(x)), exactly ``np.interp`` of the two columns."""
        if x > self._x0:
            if x < self._xn:
                j = int((x - self._x0) * self._inv_step)  # at most one past the last interval
                while x < self._grid[j]:
                    j -= 1
                while x >= self._grid[j + 1]:
                    j += 1
                dx = x - self._grid[j]
                return self._fa_slope[j] * dx + self._fa[j], self._fb_slope[j] * dx + self._fb[j]
            return self._fa[self._last], self._fb[self._last]
        if x <= self._x0:
            return self._fa[0], self._fb[0]
        return math.nan, math.nan

    def __reduce__(self):
        return type(self), self._args


class GelForces:
    """The gel law on every pad strip joint (:mod:`cosim.pad_kernels`).

    Parameters
    ----------
    table : (grid_m, pressure_pa, tangent_pa_m): the gel law P(q) and dP/dq on a uniform grid
        of indentations q (m), Pa and Pa/m.
    qadr, dof, jnt : per strip, its joint's qpos address, dof address and joint id.
    area_m2 : per strip, its area, m^2.
    qspring_m : per strip, its joint's spring reference, m.
    """

    __slots__ = ("_area", "_args", "_bound", "_dof", "_jnt", "_n", "_qadr", "_qfrc", "_qpos", "_qspring", "_stiffness", "_table")

    def __init__(self, table, qadr, dof, jnt, area_m2, qspring_m) -> None:
        self._args = (table, qadr, dof, jnt, area_m2, qspring_m)
        self._table = UniformPairTable(*table)
        qadr, dof, jnt = ([int(i) for i in v] for v in (qadr, dof, jnt))
        area_m2, qspring_m = [float(a) for a in area_m2], [float(q) for q in qspring_m]
        if not len(qadr) == len(dof) == len(jnt) == len(area_m2) == len(qspring_m):
            raise ValueError("every strip needs a qpos address, a dof, a joint, an area and a spring reference")
        self._n = len(qadr)
        self._qadr, self._dof, self._jnt = array("q", qadr), array("q", dof), array("q", jnt)
        self._area, self._qspring = array("d", area_m2), array("d", qspring_m)
        self._bound = False

    def bind(self, qpos, qfrc_applied, jnt_stiffness) -> None:
        """Work on these arrays from now on (float64, 1-D, contiguous: MuJoCo's ``data.qpos``,
        ``data.qfrc_applied`` and ``model.jnt_stiffness``, or memoryviews of them)."""
        _checked_indices("qpos", self._qadr, len(qpos))
        _checked_indices("dof", self._dof, len(qfrc_applied))
        _checked_indices("joint", self._jnt, len(jnt_stiffness))
        self._qpos, self._qfrc, self._stiffness = memoryview(qpos), memoryview(qfrc_applied), memoryview(jnt_stiffness)
        self._bound = True

    def apply(self) -> None:
        """Write each strip joint's stiffness and applied force for the state in ``qpos``: the
        stiffness A dP/dq (N/m: the tangent, so the discrete integrator treats the law
        implicitly) and the force A dP/dq (q - q0) - A P(q) (N), so that the explicit force on
        the joint is exactly -A P(q)."""
        if not self._bound:
            raise RuntimeError("bind() the arrays first")
        for i in range(self._n):
            q = self._qpos[self._qadr[i]]
            pressure, tangent = self._table.at(q)
            area = self._area[i]
            k = area * tangent
            self._stiffness[self._jnt[i]] = k
            self._qfrc[self._dof[i]] = k * (q - self._qspring[i]) - area * pressure

    def __reduce__(self):  # a copy is unbound: its owner binds it to its own arrays
        return type(self), self._args


class PassiveGelForces:
    """The gel law on every pad strip joint as MuJoCo passive forces, every physics step
    (:class:`cosim.mjhooks.GelPassive` says how; this is its arithmetic, one call for all the
    strips of a model).

    Parameters
    ----------
    table : (grid_m, pressure_pa, tangent_pa_m), as :class:`GelForces`'s.
    qadr, dof, jnt : per strip, its joint's qpos address, dof address and joint id.
    area_m2 : per strip, its area, m^2.
    gel_mass_kg : per strip, its gel's mass, kg (the mass scaling's floor).
    gel_damping_n_s_m : per strip, the gel's own damping, N s/m.
    timestep_s : the model's step h, s.
    omega_h : the strips' ring frequency times the step under an explicit integrator
        (:data:`cosim.mjhooks.EXPLICIT_OMEGA_H`).
    """

    __slots__ = (
        "_area",
        "_args",
        "_armature",
        "_bound",
        "_damping",
        "_dof",
        "_gel_damping",
        "_gel_mass",
        "_h",
        "_h2",
        "_jnt",
        "_k0",
        "_last_q",
        "_n",
        "_p0",
        "_passive",
        "_q0",
        "_qadr",
        "_qpos",
        "_spring",
        "_stiffness",
        "_table",
    )

    def __init__(self, table, qadr, dof, jnt, area_m2, gel_mass_kg, gel_damping_n_s_m, timestep_s: float, omega_h: float) -> None:
        self._args = (table, qadr, dof, jnt, area_m2, gel_mass_kg, gel_damping_n_s_m, timestep_s, omega_h)
        self._table = UniformPairTable(*table)
        qadr, dof, jnt = ([int(i) for i in v] for v in (qadr, dof, jnt))
        area, mass, damping = ([float(a) for a in v] for v in (area_m2, gel_mass_kg, gel_damping_n_s_m))
        if not len(qadr) == len(dof) == len(jnt) == len(area) == len(mass) == len(damping):
            raise ValueError("every strip needs a qpos address, a dof, a joint, an area, a gel mass and a damping")
        if not (math.isfinite(timestep_s) and timestep_s > 0 and math.isfinite(omega_h) and omega_h > 0):
            raise ValueError(f"the step ({timestep_s!r} s) and omega h ({omega_h!r}) must be positive and finite")
        self._n = len(qadr)
        self._qadr, self._dof, self._jnt = array("q", qadr), array("q", dof), array("q", jnt)
        self._area, self._gel_mass, self._gel_damping = array("d", area), array("d", mass), array("d", damping)
        self._h = float(timestep_s)
        self._h2 = (self._h / float(omega_h)) ** 2
        zeros = [0.0] * self._n
        self._q0, self._p0, self._k0, self._last_q = array("d", zeros), array("d", zeros), array("d", zeros), array("d", zeros)
        self._bound = False

    def bind(self, qpos, qfrc_passive, qfrc_spring, jnt_stiffness, dof_armature, dof_damping) -> None:
        """Work on these arrays from now on (float64, 1-D, contiguous: MuJoCo's ``data.qpos``,
        ``data.qfrc_passive``, ``data.qfrc_spring`` and ``model.jnt_stiffness``,
        ``model.dof_armature``, ``model.dof_damping``, or memoryviews of them)."""
        _checked_indices("qpos", self._qadr, len(qpos))
        _checked_indices("dof", self._dof, min(len(qfrc_passive), len(qfrc_spring), len(dof_armature), len(dof_damping)))
        _checked_indices("joint", self._jnt, len(jnt_stiffness))
        self._qpos, self._passive, self._spring = memoryview(qpos), memoryview(qfrc_passive), memoryview(qfrc_spring)
        self._stiffness, self._armature, self._damping = memoryview(jnt_stiffness), memoryview(dof_armature), memoryview(dof_damping)
        self._bound = True

    def _check_bound(self) -> None:
        if not self._bound:
            raise RuntimeError("bind() the arrays first")

    def scale_masses(self, stiffness_n_m) -> None:
        """Each strip's armature max(0, k (h / omega_h)^2 - m_gel) (kg) and damping c_gel + h k
        (N s/m) for the stiffnesses ``stiffness_n_m`` (N/m, one a strip)."""
        self._check_bound()
        for i in range(self._n):
            self._scale(i, float(stiffness_n_m[i]))

    def _scale(self, i: int, k: float) -> None:
        dof = self._dof[i]
        self._armature[dof] = max(k * self._h2 - self._gel_mass[i], 0.0)
        self._damping[dof] = self._gel_damping[i] + self._h * k

    def changed(self) -> bool:
        """Whether any strip's indentation differs from the last call's (NaN differs), the
        indentations now kept for the next."""
        self._check_bound()
        moved = False
        for i in range(self._n):
            q = self._qpos[self._qadr[i]]
            if not q == self._last_q[i]:
                moved = True
            self._last_q[i] = q
        return moved

    def linearize(self) -> None:
        """Hold the law linearized at the indentations now: P(q0), dP/dq (q0) per strip."""
        self._check_bound()
        for i in range(self._n):
            q = self._qpos[self._qadr[i]]
            pressure, tangent = self._table.at(q)
            self._q0[i] = q
            self._p0[i] = self._area[i] * pressure
            self._k0[i] = self._area[i] * tangent

    def stiffness(self, held: bool) -> None:
        """Only each strip joint's stiffness A dP/dq (N/m), at the state now or as held."""
        self._check_bound()
        for i in range(self._n):
            if held:
                self._stiffness[self._jnt[i]] = self._k0[i]
            else:
                self._stiffness[self._jnt[i]] = self._area[i] * self._table.at(self._qpos[self._qadr[i]])[1]

    def apply(self, implicit: bool, held: bool) -> None:
        """Add each strip's gel force to ``qfrc_passive``: -A P(q) (N), or the held
        linearization -A P(q0) - A dP/dq (q0) (q - q0); with ``implicit`` (the discrete
        integrator) the joint's spring force taken out and its stiffness set to the tangent,
        otherwise the strip's mass scaled to it (:meth:`scale_masses`)."""
        self._check_bound()
        for i in range(self._n):
            q = self._qpos[self._qadr[i]]
            if held:
                k = self._k0[i]
                force = -self._p0[i] - k * (q - self._q0[i])
            else:
                pressure, tangent = self._table.at(q)
                k = self._area[i] * tangent
                force = -(self._area[i] * pressure)
            dof = self._dof[i]
            if implicit:
                self._passive[dof] += force - self._spring[dof]
                self._stiffness[self._jnt[i]] = k
            else:
                self._passive[dof] += force
                self._scale(i, k)

    def __reduce__(self):  # a copy is unbound: its owner binds it to its own arrays
        return type(self), self._args


class PadPressures:
    """The pads' pressure read (:mod:`cosim.pad_kernels`).

    Parameters
    ----------
    table : (grid_m, pressure_pa, tangent_pa_m), as :class:`GelForces`'s.
    qadr : the qpos addresses of the strips read, pad after pad, ``per_pad`` each.
    per_pad : strips read per pad.
    element : positions among a pad's strips read of its element strips, root to tip.
    weights : per coverage cell, (position among a pad's strips read, weight) pairs: the cell's
        pressure is the weighted sum of those strips' pressures.
    """

    __slots__ = (
        "_args",
        "_bound",
        "_cell_start",
        "_element",
        "_per_pad",
        "_qadr",
        "_qpos",
        "_table",
        "_term_at",
        "_term_weight",
        "_values",
    )

    def __init__(self, table, qadr, per_pad: int, element, weights) -> None:
        self._args = (table, qadr, per_pad, element, weights)
        self._table = UniformPairTable(*table)
        qadr, element = [int(i) for i in qadr], [int(i) for i in element]
        rows = [[(int(i), float(w)) for i, w in row] for row in weights]
        self._per_pad = int(per_pad)
        if self._per_pad < 1 or len(qadr) % self._per_pad:
            raise ValueError(f"{len(qadr)} strips read do not make pads of {self._per_pad}")
        _checked_indices("element", element, self._per_pad)
        _checked_indices("weight", [i for row in rows for i, _ in row], self._per_pad)
        if not all(rows):
            raise ValueError("every coverage cell needs at least one weighted strip")
        self._qadr, self._element = array("q", qadr), array("q", element)
        # The cells' terms, flattened: cell c sums terms _cell_start[c] to _cell_start[c + 1] - 1.
        starts, at, weight = [0], [], []
        for row in rows:
            at += [i for i, _ in row]
            weight += [w for _, w in row]
            starts.append(len(at))
        self._cell_start, self._term_at, self._term_weight = array("q", starts), array("q", at), array("d", weight)
        self._values = array("d", [0.0] * len(qadr))  # each strip's pressure, this read's
        self._bound = False

    def bind(self, qpos) -> None:
        """Read this array from now on (``data.qpos``, float64, 1-D, contiguous, or a memoryview of it)."""
        _checked_indices("qpos", self._qadr, len(qpos))
        self._qpos = memoryview(qpos)
        self._bound = True

    def read(self) -> tuple[list[list[float]], list[list[float]]]:
        """Per pad: the compressive pressure max(P(q), 0) of its element strips, root to tip (Pa;
        the gel rests unbonded on the element), and of each coverage cell the weighted sum of
        its strips' pressures, in order from 0.0 (what ``sum`` of the products gives)."""
        if not self._bound:
            raise RuntimeError("bind() the array first")
        values = self._values
        for i in range(len(self._qadr)):
            values[i] = max(self._table.at(self._qpos[self._qadr[i]])[0], 0.0)
        profiles, covered = [], []
        for pad in range(len(self._qadr) // self._per_pad):
            start = pad * self._per_pad
            profiles.append([values[start + self._element[j]] for j in range(len(self._element))])
            cells = []
            for c in range(len(self._cell_start) - 1):
                total = 0.0
                for j in range(self._cell_start[c], self._cell_start[c + 1]):
                    total += self._term_weight[j] * values[start + self._term_at[j]]
                cells.append(total)
            covered.append(cells)
        return profiles, covered

    def __reduce__(self):
        return type(self), self._args
