"""The table lookups of the per-step path: ``np.interp`` for one Python float.

A sample of the co-simulation does a handful of table lookups (one per pressure cell, two in
the inverse), each on a Python float: numpy's per-call overhead on a 0-d array costs ten times
the interpolation itself (tests/test_channel_perf_equivalence.py checks these functions equal
``np.interp`` to the last bit; ``run_sim.py bench`` times them in the "sensor" and "readout"
stages).  Tables are plain lists of floats with ``xp`` strictly increasing.
:class:`UniformPairTable` is the same lookup on an evenly spaced grid, the interval found by one
multiplication: the pads' gel law (P and dP/dq at an indentation) in the co-simulation's bridge.
:class:`PyUniformPairTable` is its reference; ``sensor/_lookup.pyx`` its compiled twin, used
where built (:mod:`sensor.compiled`; :data:`UNIFORM_COMPILED` says).
"""

from __future__ import annotations

import math
from bisect import bisect_right

import numpy as np

from .compiled import twin


def interp(x: float, xp: list[float], fp: list[float]) -> float:
    """``np.interp(x, xp, fp)`` for one float: the same interval, the same arithmetic (slope
    (fp[j+1] - fp[j]) / (xp[j+1] - xp[j]) times (x - xp[j]) plus fp[j]), the same clamping at
    the ends; NaN for NaN.  Units are those of ``fp``."""
    if x >= xp[-1]:
        return fp[-1]
    if x >= xp[0]:
        j = bisect_right(xp, x) - 1
        return (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j]) * (x - xp[j]) + fp[j]
    if x < xp[0]:
        return fp[0]
    return math.nan


def interp_pair(x: float, xp: list[float], fa: list[float], fb: list[float]) -> tuple[float, float]:
    """``(interp(x, xp, fa), interp(x, xp, fb))`` with one interval search for both columns
    (bit for bit the same numbers: two columns of one table, looked up together)."""
    if x >= xp[-1]:
        return fa[-1], fb[-1]
    if x >= xp[0]:
        j = bisect_right(xp, x) - 1
        dx, h = x - xp[j], xp[j + 1] - xp[j]
        return (fa[j + 1] - fa[j]) / h * dx + fa[j], (fb[j + 1] - fb[j]) / h * dx + fb[j]
    if x < xp[0]:
        return fa[0], fb[0]
    return math.nan, math.nan


class PyUniformPairTable:
    """Two columns ``fa``, ``fb`` over an evenly spaced ``grid`` (strictly increasing), looked up
    at one Python float: ``(np.interp(x, grid, fa), np.interp(x, grid, fb))``.

    The same arithmetic as ``np.interp`` for each column: the interval j with grid[j] <= x <
    grid[j + 1], the slope (f[j+1] - f[j]) / (grid[j+1] - grid[j]) (tabulated once here) and
    f = slope (x - grid[j]) + f[j]; clamped to the end values outside the grid; NaN for NaN.
    One interval search serves both columns, and the grid is uniform, so j comes from one
    multiplication (then corrected by the grid's own values, so a grid that is uniform only to
    rounding still finds the right interval).  On numpy builds that do not fuse the multiply-add,
    the results are bitwise np.interp's (tests/test_channel_perf_equivalence.py checks).  Units
    are the grid's and the columns'.
    """

    __slots__ = ("_fa", "_fa_slope", "_fb", "_fb_slope", "_grid", "_inv_step", "_x0", "_xn")

    def __init__(self, grid, fa, fb) -> None:
        grid, fa, fb = (np.asarray(v, dtype=float) for v in (grid, fa, fb))
        if grid.ndim != 1 or grid.size < 2 or fa.shape != grid.shape or fb.shape != grid.shape or not np.all(np.diff(grid) > 0):
            raise ValueError(f"a table needs a strictly increasing grid of 2 or more points and columns of its shape, got {grid.shape}")
        dx = grid[1:] - grid[:-1]
        self._grid = [*grid.tolist(), math.inf]  # a sentinel past the end: grid[j + 1] always exists
        self._fa, self._fb = fa.tolist(), fb.tolist()
        self._fa_slope = ((fa[1:] - fa[:-1]) / dx).tolist()
        self._fb_slope = ((fb[1:] - fb[:-1]) / dx).tolist()
        self._x0, self._xn = float(grid[0]), float(grid[-1])
        self._inv_step = (grid.size - 1) / (self._xn - self._x0)

    def at(self, x: float) -> tuple[float, float]:
        """(fa(x), fb(x)), exactly ``np.interp`` of the two columns."""
        if x > self._x0:
            if x < self._xn:
                grid = self._grid
                j = int((x - self._x0) * self._inv_step)  # at most one past the last interval
                while x < grid[j]:
                    j -= 1
                while x >= grid[j + 1]:
                    j += 1
                dx = x - grid[j]
                return self._fa_slope[j] * dx + self._fa[j], self._fb_slope[j] * dx + self._fb[j]
            return self._fa[-1], self._fb[-1]
        if x <= self._x0:
            return self._fa[0], self._fb[0]
        return math.nan, math.nan


#: The pads' lookup: the compiled twin of :class:`PyUniformPairTable` where built, else it.
UniformPairTable, UNIFORM_COMPILED = twin("piezotip.sensor._lookup", "UniformPairTable", PyUniformPairTable)
