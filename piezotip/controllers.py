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

A controller registered in a script exists in that process only.  To name one in any process
(the installed ``piezotip`` command, a sweep's worker processes), give its class as
``controller.kind=MODULE:CLASS`` (``--set controller.kind=mypkg.ctl:Mine``; CLASS may be dotted):
each process imports MODULE and takes CLASS's registration, where its module registered it, or
else that of the registered controller it subclasses (``class Mine(GentleGrasp)`` takes the
gentle one's config, experiment and senses), under the kind ``"mypkg.ctl:Mine"``, which the run
records.  A module that does not import, a class it lacks, or a class that is no registered
controller nor subclasses one is a ValueError naming ``controller.kind``.

An installed package registers its controllers by name with an entry point of the
``piezotip.controllers`` group, in its ``pyproject.toml``::

    [project.entry-points."piezotip.controllers"]
    mine = "mypkg.ctl:Mine"

after which ``controller.kind=mine`` works everywhere it is installed: the entry points load with
the built-ins (after them), each registered under its name by the rule of ``MODULE:CLASS`` above;
one that fails to load is skipped with a warning naming it.

The registry itself lives below the controllers, in :mod:`piezotip.cosim.control.registry`; this
module is its public name and re-exports it.
"""

from __future__ import annotations

# The same objects (and the registry's own state, reached here as before it moved: tests patch _REGISTRY).
from piezotip.cosim.control.registry import (  # noqa: F401
    _FORBIDDEN,
    _REGISTRY,
    ENTRY_POINT_GROUP,
    Registration,
    _default,
    _load_builtins,
    configure,
    get,
    names,
    register,
    resolve,
)

__all__ = ["ENTRY_POINT_GROUP", "Registration", "configure", "get", "names", "register", "resolve"]
