"""The controller registry: ``controller.kind`` names a registered controller (the user's
documentation, and the public name, is :mod:`piezotip.controllers`, which re-exports this module).

It lives below the controllers, so the built-in ones (``.multimode``, ``.gentle``, ``.scripted``)
register themselves with a downward import.  A kind is one of:

- a name registered with :func:`register` (the built-ins, a script's own, and each entry point of
  the ``piezotip.controllers`` group, loaded with the built-ins);
- ``MODULE:CLASS``, a class imported in whichever process asks (a sweep's workers too): a
  registered class, or a subclass of one, whose registration it takes.

Its imports at import time are the standard library's and the configs' (cosim/control/config.py):
the controllers themselves load the first time the registry is asked (:func:`_load_builtins`).
"""

from __future__ import annotations

import dataclasses
import importlib
import warnings
from dataclasses import dataclass

from piezotip.cosim.control.config import ControllerConfig

#: Characters a controller's name may not hold: it is given as ``--set controller.kind=NAME``
#: and in a ``--grid`` (comma-separated values); ':' marks a ``MODULE:CLASS`` kind.
_FORBIDDEN = frozenset(" \t\n=,\"'[](){}:")

#: The entry-point group whose entry points (``name = "module:Class"``) are registered as controllers.
ENTRY_POINT_GROUP = "piezotip.controllers"


@dataclass(frozen=True)
class Registration:
    """A registered controller.

    Attributes
    ----------
    name : its ``controller.kind``.
    controller : the class; the loop builds it with ``from_scenario(config, robot, fingertip)``.
    config : its config class (ControllerConfig or a subclass), made with ``kind=name``.
    experiment : whether ``run_sim.py experiment grasp-range`` runs it (with every mode, on every
        object) and holds it to the experiment's pass rule: a success exactly where the gripper
        can carry the object.
    senses : whether it reads the fingertips: it then drives the mode selector (a scenario's
        validation checks that each allowed mode is the most useful somewhere, with a switch
        pressure up to the next) and runs the element's self-test when built.  One that does not
        is the cheap one to build where only the simulation is wanted (the Gymnasium environment).
    """

    name: str
    controller: type
    config: type[ControllerConfig]
    experiment: bool = False
    senses: bool = False


#: The built-in controllers' package (this module's): their modules register as it is imported.
_PACKAGE = __name__.rpartition(".")[0]

_REGISTRY: dict[str, Registration] = {}
_builtins_loaded = False


def _load_builtins() -> None:
    """Register the built-in controllers (their modules register themselves), once, first; then
    each entry point of the ``piezotip.controllers`` group (one that fails is skipped with a warning)."""
    global _builtins_loaded
    if _builtins_loaded:
        return
    _builtins_loaded = True  # before the imports: the entry points' own register() calls come back here
    importlib.import_module(_PACKAGE)  # lazily: the package imports this module

    _load_entry_points()


def _load_entry_points() -> None:
    """Register each entry point of :data:`ENTRY_POINT_GROUP` under its name, with the
    registration of its class or of the registered controller it subclasses (:func:`_inherited`)."""
    from importlib.metadata import entry_points

    try:
        found = list(entry_points(group=ENTRY_POINT_GROUP))
    except Exception as err:  # a broken installed distribution's metadata
        warnings.warn(f"{ENTRY_POINT_GROUP} entry points not loaded: {type(err).__name__}: {err}", stacklevel=3)
        return
    for ep in found:
        try:
            if not ep.name or _FORBIDDEN & set(ep.name):
                raise ValueError("a controller's name must be non-empty text without spaces, quotes, brackets, '=', ',' or ':'")
            if not ep.attr:
                raise ValueError("an entry point names a controller class as module:Class")
            cls = _import_class(ep.module, ep.attr, f"entry point {ep.name!r}")
            registration = _inherited(cls, ep.name, f"entry point {ep.name!r} = {ep.value!r}")
            known = _REGISTRY.get(ep.name)
            if known is not None:
                if known.controller is cls:  # the module registered it under this very name itself
                    continue
                raise ValueError(f"controller {ep.name!r} registered twice (by {known.controller.__qualname__})")
            _REGISTRY[ep.name] = registration
        except Exception as err:
            warnings.warn(
                f"{ENTRY_POINT_GROUP} entry point {ep.name!r} = {ep.value!r} skipped: {type(err).__name__}: {err}",
                stacklevel=3,
            )


def register(name: str, config: type[ControllerConfig] = ControllerConfig, *, experiment: bool = False, senses: bool = False):
    """A class decorator registering a controller as ``controller.kind=name`` (the module docstring).

    ``config`` is its config class (a frozen dataclass, ControllerConfig or a subclass);
    ``experiment`` and ``senses`` are :class:`Registration`'s.  A name registered twice, a name
    that cannot be given on the command line, a config class that is no ControllerConfig, or a
    class without ``from_scenario`` and ``step`` is a ValueError or TypeError saying so."""
    if not isinstance(name, str) or not name or _FORBIDDEN & set(name):
        raise ValueError(f"a controller's name must be non-empty text without spaces, quotes, brackets, '=', ',' or ':', got {name!r}")
    if not (isinstance(config, type) and issubclass(config, ControllerConfig) and dataclasses.is_dataclass(config)):
        raise TypeError(f"controller {name!r}: config must be a dataclass subclassing ControllerConfig, got {config!r}")
    if not config.__dataclass_params__.frozen:
        raise TypeError(f"controller {name!r}: its config class {config.__name__} must be a frozen dataclass")

    def decorate(cls: type) -> type:
        if cls.__module__.rpartition(".")[0] != _PACKAGE:
            # the built-ins first: they register as their package is imported, loading nothing
            # (the entry points load once the package is whole, after them)
            _load_builtins()
        missing = [attr for attr in ("from_scenario", "step") if not callable(getattr(cls, attr, None))]
        if missing:
            raise TypeError(
                f"controller {name!r}: {cls.__qualname__} lacks {' and '.join(missing)} (a controller is built with "
                "from_scenario(config, robot, fingertip) and called with step(obs, dt_s): piezotip.controllers)"
            )
        if name in _REGISTRY:
            raise ValueError(f"controller {name!r} registered twice (by {_REGISTRY[name].controller.__qualname__})")
        _REGISTRY[name] = Registration(name, cls, config, bool(experiment), bool(senses))
        return cls

    return decorate


def names() -> tuple[str, ...]:
    """The registered controllers' names, in the order they were registered (the built-ins first,
    then the entry points'; a ``MODULE:CLASS`` kind once it has been resolved)."""
    _load_builtins()
    return tuple(_REGISTRY)


def get(name: str) -> Registration:
    """The :class:`Registration` of controller ``name``; an unknown name lists the valid ones.
    A ``MODULE:CLASS`` name is resolved (:func:`resolve`) and kept under that name."""
    _load_builtins()
    if name not in _REGISTRY:
        if isinstance(name, str) and ":" in name:
            return resolve(name)
        raise ValueError(f"unknown controller {name!r}; valid controllers: {', '.join(_REGISTRY)}")
    return _REGISTRY[name]


def resolve(kind: str) -> Registration:
    """The registration of ``kind`` = ``"MODULE:CLASS"`` (CLASS may be dotted): the class imported
    from MODULE, with its own registration's config, experiment and senses where it was
    registered, else those of the nearest registered controller class it subclasses (its MRO);
    kept in the registry under ``kind``.  A module that does not import, a class it lacks, or a
    class that is no registered controller nor subclasses one is a ValueError naming
    ``controller.kind``."""
    _load_builtins()
    if kind in _REGISTRY:
        return _REGISTRY[kind]
    module, _, qualname = kind.partition(":")
    if not module or not qualname or ":" in qualname:
        raise ValueError(f"controller.kind {kind!r}: a controller class is given as MODULE:CLASS (e.g. mypkg.ctl:Mine)")
    cls = _import_class(module, qualname, f"controller.kind {kind!r}")
    registration = _inherited(cls, kind, f"controller.kind {kind!r}")
    _REGISTRY[kind] = registration
    return registration


def _import_class(module: str, qualname: str, what: str) -> object:
    """``module``'s attribute ``qualname`` (dotted: nested), imported; a ValueError naming ``what``
    (and the module) where it cannot be, without the import's traceback."""
    try:
        imported = importlib.import_module(module)
    except Exception as err:
        raise ValueError(f"{what}: cannot import module {module!r} ({type(err).__name__}: {err})") from None
    value: object = imported
    for part in qualname.split("."):
        try:
            value = getattr(value, part)
        except AttributeError:
            raise ValueError(f"{what}: module {module!r} has no {qualname!r}") from None
    return value


def _inherited(cls: object, name: str, what: str) -> Registration:
    """``cls``'s registration under ``name``: its own where it was registered, else that of the
    nearest registered controller class in its MRO; a ValueError naming ``what`` otherwise."""
    if isinstance(cls, type):
        registered: dict[type, Registration] = {}
        for registration in _REGISTRY.values():
            registered.setdefault(registration.controller, registration)
        for base in cls.__mro__:
            if base in registered:
                own = registered[base]
                return Registration(name, cls, own.config, own.experiment, own.senses)
    valid = ", ".join(kind for kind in _REGISTRY if ":" not in kind)
    shown = f"{cls.__module__}.{cls.__qualname__}" if isinstance(cls, type) else repr(cls)
    raise ValueError(f"{what}: {shown} must be a registered controller or subclass one (registered: {valid})")


def configure(name: str, like: ControllerConfig | None = None) -> ControllerConfig:
    """Controller ``name``'s config (its class's defaults, ``kind=name``), given what ``like`` was:
    each field the two classes share whose value in ``like`` is not its class's default (set by a
    scenario or an override) is carried over; the others are the new class's defaults."""
    registration = get(name)
    carried = {}
    if like is not None:
        shared = {f.name for f in dataclasses.fields(registration.config)} - {"kind"}
        for f in dataclasses.fields(like):
            if f.name in shared and getattr(like, f.name) != _default(f):
                carried[f.name] = getattr(like, f.name)
    return registration.config(kind=name, **carried)


def _default(f: dataclasses.Field):
    """A dataclass field's default value (``dataclasses.MISSING`` where it has none)."""
    if f.default_factory is not dataclasses.MISSING:
        return f.default_factory()
    return f.default


__all__ = ["ENTRY_POINT_GROUP", "Registration", "configure", "get", "names", "register", "resolve"]
