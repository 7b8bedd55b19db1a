"""The one table lookup of the readout's per-step path: ``np.interp`` for one Python float.

A sample of the co-simulation does a handful of table lookups (one per pressure cell, two in
the inverse), each on a Python float: numpy's per-call overhead on a 0-d array costs ten times
the interpolation itself (tests/test_channel_perf_equivalence.py checks these functions equal
``np.interp`` to the last bit; ``run_sim.py bench`` times them in the "sensor" and "readout"
stages).  Tables are plain lists of floats with ``xp`` strictly increasing.
"""

from __future__ import annotations

import math
from bisect import bisect_right


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
