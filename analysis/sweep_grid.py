"""A sweep's points: the command line's ``--grid key=v1,v2,...`` texts parsed, their product
listed as :class:`Point` (each a list of ``key=value`` overrides of one scenario), and every
point's config checked before any run."""

from __future__ import annotations

import itertools
import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field


@dataclass(frozen=True)
class Point:
    """One run of a sweep.

    Attributes
    ----------
    values : the point's coordinates, column name -> value (the grid's keys, or labels such as
        the experiment's object and controller).
    overrides : the run's ``key=value`` overrides, in the order applied.
    """

    values: Mapping[str, object]
    overrides: tuple[str, ...]
    label: str = field(default="")

    def key(self, scenario: str, preset: str | None) -> str:
        """What identifies the run (resume): scenario, preset and every override, in order."""
        return json.dumps([scenario, preset, list(self.overrides)])


def split_values(text: str) -> list[str]:
    """``"0.1,0.4,[1, 2]"`` -> ``["0.1", "0.4", "[1, 2]"]``: commas inside brackets or quotes stay."""
    items, depth, quote, current = [], 0, "", []
    for ch in text:
        if quote:
            quote = "" if ch == quote else quote
        elif ch in "'\"":
            quote = ch
        elif ch in "([{":
            depth += 1
        elif ch in ")]}":
            depth -= 1
        elif ch == "," and depth == 0:
            items.append("".join(current).strip())
            current = []
            continue
        current.append(ch)
    items.append("".join(current).strip())
    if depth != 0 or quote:
        raise ValueError(f"--grid values {text!r}: unbalanced brackets or quotes")
    if any(not item for item in items):
        raise ValueError(f"--grid values {text!r}: an empty value")
    return items


def parse_grid(specs: Sequence[str]) -> dict[str, list[str]]:
    """``["object.mass_kg=0.1,0.4", ...]`` -> ``{"object.mass_kg": ["0.1", "0.4"], ...}``."""
    grid: dict[str, list[str]] = {}
    for spec in specs:
        key, sep, values = spec.partition("=")
        key = key.strip()
        if not sep or not key or not values.strip():
            raise ValueError(f"--grid takes key=v1,v2,..., got {spec!r}")
        if key in grid:
            raise ValueError(f"--grid {key!r} given twice")
        grid[key] = split_values(values)
    if not grid:
        raise ValueError("a sweep needs at least one --grid key=v1,v2,...")
    return grid


def grid_points(grid: Mapping[str, Sequence[object]], base_overrides: Sequence[str] = ()) -> list[Point]:
    """Every combination of the grid's values (the last key varies fastest); ``base_overrides``
    (the user's ``--set``) apply first, the point's own values after them."""
    from piezotip.scenarios import override_strings
    from piezotip.scenarios.config import parse_value

    keys = list(grid)
    points = []
    for combo in itertools.product(*(grid[k] for k in keys)):
        values, own = {}, []
        for key, value in zip(keys, combo, strict=True):
            # Text is the command line's (``0.1``, ``[1, 2]``): used as typed, read as --set reads it.
            values[key] = parse_value(value) if isinstance(value, str) else value
            own += [f"{key}={value}"] if isinstance(value, str) else override_strings({key: value})
        points.append(Point(values, (*base_overrides, *own), label=", ".join(own)))
    return points


def check_points(scenario: str, points: Sequence[Point], preset: str | None) -> None:
    """Every point's config validated before any run (a bad value stops the sweep at once)."""
    from piezotip import scenarios

    for point in points:
        scenarios.get(scenario, list(point.overrides), preset)
