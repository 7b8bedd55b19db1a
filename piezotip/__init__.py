"""piezotip: co-simulation of a robot fingertip that feels through a multimode piezoelectric sensor.

The Python API (see :mod:`piezotip.api` and the README)::

    import piezotip
    result = piezotip.run("grasp", overrides={"object.mass_kg": 0.4}, preset="fast")
    rows = piezotip.sweep("grasp", {"object.mass_kg": [0.1, 0.4]}, preset="fast")

The packages beneath: :mod:`piezotip.sensor` (the fingertip's physics, numpy/scipy only),
:mod:`piezotip.cosim` (MuJoCo bridge, loop, controllers, recorder), :mod:`piezotip.scenarios`
(configs, presets, objects), :mod:`piezotip.analysis` (reports, referee, bench, sweeps).

``import piezotip`` stays cheap (no MuJoCo, scipy or matplotlib): the API's names load on
first use.
"""

from __future__ import annotations

__version__ = "0.1.0"

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

__all__ = [*_API, "controllers", "__version__"]


#: Submodules loaded on first use (``piezotip.controllers.register``, ...).
_SUBMODULES = ("controllers",)


def __getattr__(name: str):
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
