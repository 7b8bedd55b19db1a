"""Named scenarios: each a factory returning its whole :class:`ScenarioConfig`.

The command line, the docs and the tests all come from this one registry::

    from piezotip.scenarios import get, names
    cfg = get("grasp", ["object.mass_kg=0.4"])
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

from .config import ControllerConfig, ObjectConfig, PhysicsConfig, ScenarioConfig, SensorConfig, parse_value, valid_keys, with_overrides
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


def get(name: str, overrides: Sequence[str] | Mapping[str, object] | None = None, preset: str | None = None) -> ScenarioConfig:
    """The named scenario's config: the fidelity ``preset``'s settings, then the overrides.

    ``overrides`` is either ``key=value`` strings as the command line's ``--set`` takes them, or
    a mapping ``{"object.mass_kg": 0.4}`` of Python values (see :func:`override_strings`).
    """
    if name not in _REGISTRY:
        raise ValueError(f"unknown scenario {name!r}; valid scenarios: {', '.join(names())}")
    return with_overrides(_REGISTRY[name](), [*preset_overrides(preset), *override_strings(overrides)])


def override_strings(overrides: Sequence[str] | Mapping[str, object] | None) -> list[str]:
    """``overrides`` as ``key=value`` strings, the one form every run is keyed and recorded by.

    A mapping's values are written as Python literals (numpy scalars as Python numbers), so a
    script's ``{"object.mass_kg": 0.4}`` and the command line's ``--set object.mass_kg=0.4`` give
    the same config, the same default output folder and the same recorded overrides.
    """
    if overrides is None:
        return []
    if isinstance(overrides, str):
        raise ValueError(f"overrides must be a list of key=value strings or a mapping, got the string {overrides!r}")
    if isinstance(overrides, Mapping):
        return [f"{key}={_literal(value)}" for key, value in overrides.items()]
    return [str(item) for item in overrides]


def _literal(value) -> str:
    """The text ``parse_value`` reads back as ``value``."""
    if hasattr(value, "item") and callable(value.item):  # numpy scalars
        value = value.item()
    if isinstance(value, str):
        # Plain when it reads back as itself (``envelope``), quoted when it would not (``"1"``,
        # ``"{1: 2}"``, which parse_value refuses as a mapping; ``" x"``, whose spaces the
        # ``key=value`` reader strips; a text too long for a value is refused when the override
        # is applied, naming its key).
        try:
            plain = value == value.strip() and parse_value(value) == value
        except ValueError:
            plain = False
        return value if plain else repr(value)
    if isinstance(value, (list, tuple)):
        return repr(type(value)(_plain(v) for v in value))
    return repr(value)


def _plain(value):
    return value.item() if hasattr(value, "item") and callable(value.item) else value


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
    "override_strings",
    "register",
    "valid_keys",
]
