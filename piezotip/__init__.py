"""piezotip: co-simulation of a robot fingertip that feels through a multimode piezoelectric sensor.

The Python API (see :mod:`piezotip.api` and the README)::

    import piezotip
    result = piezotip.run("grasp", overrides={"object.mass_kg": 0.4}, preset="fast")
    rows = piezotip.sweep("grasp", {"object.mass_kg": [0.1, 0.4]}, preset="fast")

The packages beneath: :mod:`piezotip.sensor` (the fingertip's physics, numpy/scipy only),
:mod:`piezotip.cosim` (MuJoCo bridge, loop, controllers, recorder), :mod:`piezotip.scenarios`
(configs, presets, objects), :mod:`piezotip.analysis` (runner, referee, sweeps, plots); above the API,
:mod:`piezotip.reports` (bench, fidelity, coverage, creep, figures, ...), which only the command line imports.

``import piezotip`` stays cheap (no MuJoCo, scipy or matplotlib): the API's names load on
first use (the module's ``__getattr__``).  Type checkers and IDEs read the ``TYPE_CHECKING``
block below instead, which imports the same names from where they live, so ``piezotip.run``
and the others have their real signatures there (the package ships ``py.typed``).
"""

from __future__ import annotations

__version__ = "0.1.0"

#: True only for type checkers (mypy, pyright and IDEs treat a name ``TYPE_CHECKING`` as true):
#: a literal, because ``import typing`` would cost ``import piezotip`` about 2 ms.
TYPE_CHECKING = False

_API = {
    "run": "piezotip.api",
    "Result": "piezotip.api",
    "config": "piezotip.api",
    "fingertip": "piezotip.api",
    "dynamic_range": "piezotip.api",
    "scenario_names": "piezotip.api",
    "column_unit": "piezotip.api",
    "sweep": "piezotip.analysis.sweep",
    "GraspEnv": "piezotip.gym_env",  # also gymnasium.make("piezotip/Grasp-v0")
    "MultimodePolicy": "piezotip.gym_env",
    "attach": "piezotip.cosim.attach",  # the fingertip on the user's own MjSpec (docs/attach.md)
}

#: Submodules loaded on first use (``piezotip.controllers.register``, ...).
_SUBMODULES = ("controllers",)

# A literal list, so that type checkers read it (mypy's --no-implicit-reexport, pyright);
# tests/test_packaging.py checks that it names every lazy export, and that the block below
# imports each of them.
__all__ = [
    "GraspEnv",
    "MultimodePolicy",
    "Result",
    "__version__",
    "attach",
    "column_unit",
    "config",
    "controllers",
    "dynamic_range",
    "fingertip",
    "run",
    "scenario_names",
    "sweep",
]

if TYPE_CHECKING:  # what type checkers see: the real objects (never run)
    from piezotip import controllers as controllers
    from piezotip.analysis.sweep import sweep as sweep
    from piezotip.api import Result as Result
    from piezotip.api import column_unit as column_unit
    from piezotip.api import config as config
    from piezotip.api import dynamic_range as dynamic_range
    from piezotip.api import fingertip as fingertip
    from piezotip.api import run as run
    from piezotip.api import scenario_names as scenario_names
    from piezotip.cosim.attach import attach as attach
    from piezotip.gym_env import GraspEnv as GraspEnv
    from piezotip.gym_env import MultimodePolicy as MultimodePolicy
else:  # what runs: each name imported on first use

    def __getattr__(name: str) -> object:
        if name in _SUBMODULES:
            import importlib

            return importlib.import_module(f"piezotip.{name}")
        if name in _API:
            import importlib

            value = getattr(importlib.import_module(_API[name]), name)
            globals()[name] = value
            return value
        raise AttributeError(f"module 'piezotip' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *_API, *_SUBMODULES})


# Gymnasium (issue 12): `piezotip/Grasp-v0` is registered when gymnasium is imported, before or
# after this package, without importing it here (it costs ~130 ms on every command line call).
from .gym_registration import register_when_imported as _register_gym_env  # noqa: E402

_register_gym_env()
