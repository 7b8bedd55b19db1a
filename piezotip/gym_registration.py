"""Register the Gymnasium environments ``piezotip/Grasp-v0``, ``piezotip/GraspFlat-v0`` (the
same task with flat, scaled spaces for learning libraries: piezotip/gym_flat.py),
``piezotip/GraspLearn-v0`` (the task shaped for learning: piezotip/gym_learn.py) and
``piezotip/GraspAssist-v0`` (the house controller with a learned grip correction, the same
module) without importing gymnasium.

``import gymnasium`` costs about 130 ms, and the command line imports the ``piezotip`` package
on every command, so ``import piezotip`` must not import it.  :func:`register_when_imported`
(called at the end of ``piezotip/__init__.py``) registers the environments at once when
gymnasium is already imported; otherwise it puts a finder first on ``sys.meta_path`` that, when
gymnasium is imported, lets the normal import run and registers them right after
(a post-import hook).  Both orders work::

    import piezotip, gymnasium; gymnasium.make("piezotip/Grasp-v0")
    import gymnasium, piezotip; gymnasium.make("piezotip/Grasp-v0")

The entry points are strings, so registering imports nothing of the environments' own code
(``piezotip.gym_env``, ``piezotip.gym_flat``, ``piezotip.gym_learn``, MuJoCo) until ``gymnasium.make`` is called.  In a
process that never imports ``piezotip`` (a ``spawn``-ed worker),
``gymnasium.make("piezotip:piezotip/Grasp-v0")`` imports it first.
"""

from __future__ import annotations

import sys

ENV_ID = "piezotip/Grasp-v0"
ENTRY_POINT = "piezotip.gym_env:GraspEnv"
FLAT_ENV_ID = "piezotip/GraspFlat-v0"
FLAT_ENTRY_POINT = "piezotip.gym_flat:GraspFlatEnv"
LEARN_ENV_ID = "piezotip/GraspLearn-v0"
LEARN_ENTRY_POINT = "piezotip.gym_learn:GraspLearnEnv"
ASSIST_ENV_ID = "piezotip/GraspAssist-v0"
ASSIST_ENTRY_POINT = "piezotip.gym_learn:GraspAssistEnv"
#: Every environment this package registers: id -> entry point.
ENVIRONMENTS = {
    ENV_ID: ENTRY_POINT,
    FLAT_ENV_ID: FLAT_ENTRY_POINT,
    LEARN_ENV_ID: LEARN_ENTRY_POINT,
    ASSIST_ENV_ID: ASSIST_ENTRY_POINT,
}


def register_env(gymnasium) -> None:
    """Register :data:`ENVIRONMENTS` with the imported ``gymnasium`` module (once; again is a no-op)."""
    for env_id, entry_point in ENVIRONMENTS.items():
        if env_id not in gymnasium.registry:
            gymnasium.register(id=env_id, entry_point=entry_point)


class _RegisteringLoader:
    """Wraps gymnasium's own loader: runs it, then registers.  Anything else is the loader's."""

    def __init__(self, loader) -> None:
        self._loader = loader

    def create_module(self, spec):
        return self._loader.create_module(spec)

    def exec_module(self, module) -> None:
        self._loader.exec_module(module)
        register_env(module)

    def __getattr__(self, name):  # get_resource_reader, is_package, ... (importlib.resources)
        return getattr(self._loader, name)


class _GymnasiumImportHook:
    """A ``sys.meta_path`` finder that answers only for ``gymnasium``, once: it finds the real
    spec with the finders after it and hands back that spec with a registering loader."""

    def find_spec(self, fullname, path=None, target=None):
        if fullname != "gymnasium":
            return None
        _remove_hook()  # first, so the search below (and any later import) does not come back here
        from importlib.util import find_spec

        spec = find_spec("gymnasium")
        if spec is not None and spec.loader is not None:
            spec.loader = _RegisteringLoader(spec.loader)
        return spec


_HOOK = _GymnasiumImportHook()


def _remove_hook() -> None:
    while _HOOK in sys.meta_path:
        sys.meta_path.remove(_HOOK)


def register_when_imported() -> None:
    """Register now if gymnasium is imported, else when it is (see the module docstring)."""
    gymnasium = sys.modules.get("gymnasium")
    if gymnasium is not None and hasattr(gymnasium, "register"):
        register_env(gymnasium)
    elif _HOOK not in sys.meta_path:
        sys.meta_path.insert(0, _HOOK)
