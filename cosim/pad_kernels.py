"""The pads' per-step arithmetic: the gel law's force on every strip joint, and the pads' pressure read.

Every physics step (or control period) :class:`cosim.pad_bridge.PadBridge` applies the gel's law to
each pad strip joint, and every control period the co-simulation reads the compressive gel
pressure of the strips over each fingertip's element and coverage.  Both are a table lookup
per strip (the gel law P(q) and its tangent dP/dq on a uniform grid of indentations:
:class:`UniformPairTable`) and a little arithmetic:

- :class:`GelForces`: for each strip of area A, indentation q and spring reference q0, the
  joint stiffness A dP/dq (N/m: the tangent, so the discrete integrator treats the law
  implicitly) and the applied force A dP/dq (q - q0) - A P(q) (N), so that the explicit force
  on the joint is exactly -A P(q);
- :class:`PadPressures`: per pad, the compressive pressure max(P(q), 0) (Pa; the gel rests
  unbonded on the element) of its element strips, root to tip, and of each coverage cell, the
  strips' pressures weighted (:func:`cosim.loop.coverage_weights`).

Both work on live arrays bound once (``bind``: ``data.qpos``, ``data.qfrc_applied``,
``model.jnt_stiffness``), not on MuJoCo objects.  They are a kernel: one source,
``cosim/_pad_kernels.py``, compiled where built (:mod:`piezotip.sensor.compiled`;
:data:`PAD_KERNELS_COMPILED` says); :class:`PyGelForces`, :class:`PyPadPressures`,
:class:`PyPassiveGelForces` and :class:`PyUniformPairTable` are the same source run as Python.

:class:`PassiveGelForces` is the gel law of :func:`piezotip.attach`'s fingertips inside a plain
``mj_step`` (:class:`cosim.mjhooks.GelPassive`): the force added to ``qfrc_passive`` and, per
integrator, the joint stiffness or the strip's scaled mass and damping, every strip in one call.
"""

from __future__ import annotations

from piezotip.sensor.compiled import is_compiled, source_module

from . import _pad_kernels
from ._pad_kernels import GelForces, PadPressures, PassiveGelForces, UniformPairTable

__all__ = ["PAD_KERNELS_COMPILED", "GelForces", "PadPressures", "PassiveGelForces", "UniformPairTable"]

#: Whether :class:`GelForces`, :class:`PadPressures` and :class:`UniformPairTable` run compiled
#: (cosim/_pad_kernels.py built).
PAD_KERNELS_COMPILED = is_compiled(_pad_kernels)


def __getattr__(name: str):
    if name in (
        "PyGelForces",
        "PyPadPressures",
        "PyPassiveGelForces",
        "PyUniformPairTable",
    ):  # the kernel's source run as Python, loaded when asked for
        return getattr(source_module(_pad_kernels.__name__), name[2:])
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
