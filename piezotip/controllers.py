"""Grasp controllers, registered by name as scenarios are: ``--set controller.kind=NAME`` picks one.

A controller is a class decorated with :func:`register`, with its own frozen config dataclass
(:class:`~piezotip.scenarios.config.ControllerConfig` or a subclass: ``kind``, ``modes``,
``lift_height_m`` and ``hold_s``, which the loop and the referee read, plus its own fields, each
checked when the config is made)::

    from dataclasses import dataclass
    import piezotip
    from piezotip.scenarios.config import ControllerConfig

    @dataclass(frozen=True)
    class WaitConfig(ControllerConfig):
        wait_s: float = 0.5  # how long to wait, s

    @piezotip.controllers.register("wait", config=WaitConfig)
    class Wait:
        @classmethod
        def from_scenario(cls, config, robot, fingertip):  # ScenarioConfig, RobotLimits, Fingertip
            return cls(config.controller, robot, config.sensor.pads)
        ...  # phase, events, step(obs, dt_s) -> Command, finished (cosim.control.Controller)

    piezotip.run("grasp", overrides={"controller.kind": "wait", "controller.wait_s": 1.0})

The loop builds the scenario's controller with ``from_scenario(config, robot, fingertip)``
(:func:`piezotip.cosim.loop.make_controller`); the other ``controller.*`` keys set fields of the
chosen kind's config class (a key it lacks is an error listing its keys).  The built-in
controllers (``multimode``, ``gentle``, ``scripted``) register themselves in their modules under
``cosim/control/``, loaded the first time the registry is asked (``import piezotip`` stays cheap).
A controller registered in a script exists in that process only: a sweep's worker processes
know the built-in ones.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from piezotip.scenarios.config import ControllerConfig

#: Characters a controller's name may not hold: it is given as ``--set controller.kind=NAME``
#: and in a ``--grid`` (comma-separated values).
_FORBIDDEN = frozenset(" \t\n=,\"'[](){}")


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


_REGISTRY: dict[str, Registration] = {}
_builtins_loaded = False


def _load_builtins() -> None:
    """Register the built-in controllers (their modules register themselves), once, first."""
    global _builtins_loaded
    if _builtins_loaded:
        return
    _builtins_loaded = True  # before the import: the built-ins' own register() calls come back here
    import piezotip.cosim.control  # noqa: F401


def register(name: str, config: type[ControllerConfig] = ControllerConfig, *, experiment: bool = False, senses: bool = False):
    """A class decorator registering a controller as ``controller.kind=name`` (the module docstring).

    ``config`` is its config class (a frozen dataclass, ControllerConfig or a subclass);
    ``experiment`` and ``senses`` are :class:`Registration`'s.  A name registered twice, a name
    that cannot be given on the command line, a config class that is no ControllerConfig, or a
    class without ``from_scenario`` and ``step`` is a ValueError or TypeError saying so."""
    _load_builtins()
    if not isinstance(name, str) or not name or _FORBIDDEN & set(name):
        raise ValueError(f"a controller's name must be non-empty text without spaces, quotes, brackets, '=' or ',', got {name!r}")
    if not (isinstance(config, type) and issubclass(config, ControllerConfig) and dataclasses.is_dataclass(config)):
        raise TypeError(f"controller {name!r}: config must be a dataclass subclassing ControllerConfig, got {config!r}")
    if not config.__dataclass_params__.frozen:
        raise TypeError(f"controller {name!r}: its config class {config.__name__} must be a frozen dataclass")

    def decorate(cls: type) -> type:
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
    """The registered controllers' names, in the order they were registered (the built-ins first)."""
    _load_builtins()
    return tuple(_REGISTRY)


def get(name: str) -> Registration:
    """The :class:`Registration` of controller ``name``; an unknown name lists the valid ones."""
    _load_builtins()
    if name not in _REGISTRY:
        raise ValueError(f"unknown controller {name!r}; valid controllers: {', '.join(_REGISTRY)}")
    return _REGISTRY[name]


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


__all__ = ["Registration", "configure", "get", "names", "register"]
