"""Named scenarios: each a factory returning its whole :class:`ScenarioConfig`.

The command line, the docs and the tests all come from this one registry::

    from piezotip.scenarios import get, names
    cfg = get("grasp", ["object.mass_kg=0.4"])
"""

from __future__ import annotations

from collections.abc import Callable

from .config import ControllerConfig, ObjectConfig, PhysicsConfig, ScenarioConfig, SensorConfig, valid_keys, with_overrides
from .presets import PRESETS, preset_overrides

_REGISTRY: dict[str, Callable[[], ScenarioConfig]] = {}


def register(factory: Callable[[], ScenarioConfig]) -> Callable[[], ScenarioConfig]:
    """Register ``factory`` under the name of the config it returns."""
    name = factory().name
    if name in _REGISTRY:
        raise ValueError(f"scenario {name!r} registered twice")
    _REGISTRY[name] = factory
    return factory


def names() -> list[str]:
    """Registered scenario names, sorted."""
    return sorted(_REGISTRY)


def get(name: str, overrides: list[str] | None = None, preset: str | None = None) -> ScenarioConfig:
    """The named scenario's config: the fidelity ``preset``'s settings, then ``key=value`` overrides."""
    if name not in _REGISTRY:
        raise ValueError(f"unknown scenario {name!r}; valid scenarios: {', '.join(names())}")
    return with_overrides(_REGISTRY[name](), [*preset_overrides(preset), *(overrides or [])])


from . import library  # noqa: E402,F401  (registers the scenarios)
from .objects import OBJECTS, get_object, object_overrides  # noqa: E402

__all__ = [
    "OBJECTS",
    "PRESETS",
    "ControllerConfig",
    "ObjectConfig",
    "PhysicsConfig",
    "ScenarioConfig",
    "SensorConfig",
    "get",
    "get_object",
    "names",
    "object_overrides",
    "register",
    "valid_keys",
]
