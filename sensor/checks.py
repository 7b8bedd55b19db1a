"""The value checks every config section shares, run when a section is made.

Pure Python, importing nothing of the project: the config classes of every layer (sensor/config.py,
cosim/control/config.py, cosim/config.py) import it, and the override machinery above them
(scenarios/config.py).  Each check raises a ValueError naming the key and the value.
"""

from __future__ import annotations

import math
import types
import typing

#: Seeds (sensor.seed, sensor.unit_seed): non-negative and signed 64-bit, so that a sweep's
#: columns (sweep.parquet, int64) and the recordings hold them exactly.
MAX_SEED = 2**63 - 1


class _CheckedOnConstruction:
    """A config section whose values are checked when it is made (its ``validate``), so that a
    bad value cannot exist.  A batch of overrides (:func:`piezotip.scenarios.config.with_overrides`)
    is applied to the sections' field values, and each section made once, at the end."""

    def __post_init__(self) -> None:
        self.validate()


def _names_once(key: str, names) -> None:
    """A non-empty list of names, each once; a list written unquoted (``[a, b]``, which reads as
    one name) gets the quoting it needs."""
    if not names:
        raise ValueError(f"{key} must name at least one, got none")
    if len(names) == 1 and names[0].startswith("[") and names[0].endswith("]"):
        quoted = ", ".join(repr(n.strip()) for n in names[0][1:-1].split(","))
        raise ValueError(f"{key}: {_short(names[0])} reads as one name; quote each: {key}=[{quoted}]")
    if any(not n for n in names) or len(set(names)) != len(names):
        raise ValueError(f"{key} must name each once, got {_short(list(names))}")


def _is_number(value) -> bool:
    return not isinstance(value, bool) and isinstance(value, (int, float)) and not math.isnan(value)


def _positive(key: str, value) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
        raise ValueError(f"{key} must be a positive number, got {_short(value)}")


def _one_of(key: str, value, valid) -> None:
    if value not in valid:
        raise ValueError(f"{key} must be one of {', '.join(map(str, valid))}; got {_short(value)}")


def _modes(key: str, modes) -> None:
    """A set of vibration modes: each an integer in 1..30 (the element's modes the model
    computes: sensor.modes), named once."""
    if not modes or any(isinstance(m, bool) or not isinstance(m, int) or not 1 <= m <= 30 for m in modes):
        raise ValueError(f"{key} must be a non-empty list of modes in 1..30, got {_short(list(modes))}")
    if len(set(modes)) != len(modes):
        repeated = sorted({m for m in modes if modes.count(m) > 1})
        raise ValueError(f"{key} must name each mode once, got {len(modes)} with {repeated} repeated")


def _seed(key: str, value) -> None:
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= MAX_SEED:
        raise ValueError(f"{key} must be an integer in 0..2**63-1, got {_short(value)}")


def _short(value, limit: int = 80) -> str:
    """``repr(value)``, its middle left out past ``limit`` characters (error messages stay one
    short line whatever was given)."""
    text = repr(value)
    if len(text) <= limit:
        return text
    return f"{text[: limit // 2]}...{text[-(limit // 4) :]} ({len(text)} characters)"


def _coerce(key: str, hint, value):
    """``value`` converted to the field type ``hint``, or a ValueError naming ``key``."""
    origin = typing.get_origin(hint)
    args = typing.get_args(hint)
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        for arg in args:
            if arg is type(None):
                continue
            try:
                return _coerce(key, arg, value)
            except ValueError:
                continue
        raise ValueError(f"{key}: cannot use {_short(value)} (expected {hint})")
    if origin is tuple:
        given = value
        if isinstance(value, (int, float, str)) and not isinstance(value, bool):
            value = [value]
        if not isinstance(value, (list, tuple)):
            raise ValueError(f"{key}: expected a list, got {_short(value)}")
        item_types = args[:1] if (len(args) == 2 and args[1] is Ellipsis) else args
        if len(item_types) == 1:
            try:
                return tuple(_coerce(key, item_types[0], v) for v in value)
            except ValueError:
                # A list of the wrong items, or a list written as text where a mapping's value
                # is taken as given ({"controller.modes": "[2, 3]"}): say what a list needs.
                name = item_types[0].__name__
                raise ValueError(f"{key}: expected a list of {name} values (e.g. {key}=[1, 2]), got {_short(given)}") from None
        if len(value) != len(item_types):
            raise ValueError(f"{key}: expected {len(item_types)} values, got {_short(value)}")
        return tuple(_coerce(key, t, v) for t, v in zip(item_types, value, strict=True))
    if hint is bool:
        if isinstance(value, bool):
            return value
        if isinstance(value, str) and value.lower() in ("true", "false"):
            return value.lower() == "true"
        raise ValueError(f"{key}: expected true or false, got {_short(value)}")
    if hint is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ValueError(f"{key}: expected an integer, got {_short(value)}")
        return value
    if hint is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ValueError(f"{key}: expected a number, got {_short(value)}")
        try:
            return float(value)
        except OverflowError:  # an integer past 1.8e308
            raise ValueError(f"{key}: {_short(value)} is too large a number (at most 1.8e308)") from None
    if hint is str:
        if not isinstance(value, str):
            raise ValueError(f"{key}: expected text, got {_short(value)}")
        return value
    return value
