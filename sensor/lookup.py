"""The table lookups of the per-step path: ``np.interp`` for one Python float.

A sample of the co-simulation does a handful of table lookups (one per pressure cell, two in
the inverse), each on a Python float: numpy's per-call overhead on a 0-d array costs ten times
the interpolation itself (tests/test_channel_perf_equivalence.py checks these functions equal
``np.interp`` to the last bit; ``run_sim.py bench`` times them in the "sensor" and "readout"
stages).  Tables are plain lists of floats with ``xp`` strictly increasing.  (The same lookup
on an evenly spaced grid, for the pads' gel law, is :class:`cosim.pad_kernels.UniformPairTable`.)

Both are in ``sensor/_kernel_helpers.py``, where the compiled kernels find them too (their C,
on arrays of C doubles, is in ``_kernel_helpers.pxd``: :mod:`sensor.compiled`).
"""

from __future__ import annotations

from ._kernel_helpers import interp, interp_pair

__all__ = ["interp", "interp_pair"]
