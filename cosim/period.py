"""One control period's physics substeps (:class:`PeriodPhysics`).

Every control period the co-simulation advances MuJoCo by ``physics.substeps`` steps: the lift's
and fingers' servo set-points interpolated over the period, the gel law applied to the pad
joints, MuJoCo's sensors computed where the record needs them, and after the period a check
that the state stayed finite (``cosim/_period.py`` says each step's why).  The same kernel runs
the house gripper (one finger servo: :meth:`PeriodPhysics.run`) and a mounted gripper's drive
(any number of finger actuators: :meth:`PeriodPhysics.run_drive`).

It is a kernel: one source, ``cosim/_period.py``, compiled where built
(:mod:`piezotip.sensor.compiled`; :data:`PERIOD_COMPILED` says); :class:`PyPeriodPhysics` is the
same source run as Python.
"""

from __future__ import annotations

from piezotip.sensor.compiled import is_compiled, source_module

from . import _period
from ._period import PeriodPhysics

__all__ = ["PERIOD_COMPILED", "PeriodPhysics"]

#: Whether :class:`PeriodPhysics` runs compiled (cosim/_period.py built).
PERIOD_COMPILED = is_compiled(_period)


def __getattr__(name: str):
    if name == "PyPeriodPhysics":  # the kernel's source run as Python, loaded when asked for
        return source_module(_period.__name__).PeriodPhysics
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
