"""Scenario configuration: nested frozen dataclasses with dotted-path overrides.

A scenario's whole configuration is one :class:`ScenarioConfig`.  Any value can be changed
by a dotted key (``object.mass_kg=0.4``, ``controller.modes=[1]``); the value is parsed as
a Python literal (numbers, lists, tuples, booleans, ``None``) or else taken as a string,
then checked against the field's type.  An unknown key gets a short error naming it, the keys
it may have meant ("did you mean ...?") and where the valid ones are listed; a value of the
wrong type or range gets an error naming the key and the value.

Every value is bounded before it is parsed (:data:`MAX_VALUE_CHARS` characters, nested at most
:data:`MAX_VALUE_DEPTH` deep; no mappings or sets), and every field's range is the one the
model is built for, checked in its dataclass's ``validate`` (ranges that depend on other fields,
such as the quality factor's on the control period, in :meth:`ScenarioConfig.validate`): a bad
value is a ValueError naming it before anything is built, never a KeyError or a run that cannot
finish deep inside.
"""

from __future__ import annotations

import ast
import dataclasses
import difflib
import re
import typing

# The config classes live beside what builds them (sensor/config.py, cosim/control/config.py,
# cosim/config.py; their checks in sensor/checks.py); this module keeps the dotted-key overrides
# and re-exports every one of them, so ``piezotip.scenarios.config.ScenarioConfig`` is the one there.
from piezotip.cosim.build_checks import check_buildable
from piezotip.cosim.config import (  # noqa: F401
    FRICTION_RANGE,
    INTEGRATORS,
    MAX_CONTROL_PERIOD_S,
    MAX_EXTRA_LOAD_N,
    MAX_RECORDED_STEPS,
    MAX_TIMESTEP_S,
    MAX_WIDTH_SIGMA_M,
    MIN_TIMESTEP_S,
    OBJECT_SHAPES,
    PAD_CONTACTS,
    RATED_MASS_KG,
    DisturbConfig,
    GripperConfig,
    ObjectConfig,
    PerceptionConfig,
    PhysicsConfig,
    ScenarioConfig,
    controller_registration,
)
from piezotip.cosim.control.config import (  # noqa: F401
    MAX_PERSIST_S,
    ControllerConfig,
    GentleConfig,
    MotionConfig,
    MultimodeConfig,
    ScriptedConfig,
)
from piezotip.sensor.checks import (  # noqa: F401
    MAX_SEED,
    _CheckedOnConstruction,
    _coerce,
    _is_number,
    _modes,
    _names_once,
    _one_of,
    _positive,
    _seed,
    _short,
)
from piezotip.sensor.config import GEL_LAYERS, LOAD_SPREADS, MIN_COVERAGE_MM, MIN_QUALITY_FACTOR, SENSOR_DYNAMICS, SensorConfig  # noqa: F401

#: A ``--set`` or ``--grid`` value's longest text, characters (checked before it is parsed).
MAX_VALUE_CHARS = 10_000
#: ...and its deepest nesting of brackets (a config value is at most a list of numbers or texts).
MAX_VALUE_DEPTH = 4
#: ...and of its parsed expression (a list of negative numbers is 3 deep: list, minus, number).
_MAX_EXPRESSION_DEPTH = 3 * MAX_VALUE_DEPTH


# ---------------------------------------------------------------------------------------
# Dotted-path overrides.
# ---------------------------------------------------------------------------------------


def valid_keys(config) -> list[str]:
    """Every dotted key of ``config`` that ``--set`` accepts."""
    keys = []
    for f in dataclasses.fields(config):
        value = getattr(config, f.name)
        if dataclasses.is_dataclass(value):
            keys.extend(f"{f.name}.{k}" for k in valid_keys(value))
        else:
            keys.append(f.name)
    return keys


def parse_value(text: str, key: str | None = None):
    """A ``--set`` value: a Python literal if it parses as one, else the string itself.

    Bounded before it is parsed: at most MAX_VALUE_CHARS characters and MAX_VALUE_DEPTH
    nested brackets; a mapping or a set (no field takes one) is refused.  Each is a ValueError
    naming ``key`` (or the value).  Text that is no literal (``envelope``, ``10**400``,
    ``1+1``) is the string itself, which the field's type then refuses or takes.
    """
    what = f"{key}: " if key else ""
    if len(text) > MAX_VALUE_CHARS:
        raise ValueError(f"{what}a value of {len(text)} characters ({_short(text, 30)}), more than the {MAX_VALUE_CHARS} a value may have")
    depth = _bracket_depth(text)
    if depth > MAX_VALUE_DEPTH:
        raise ValueError(f"{what}{_short(text, 40)} nests {depth} brackets deep, more than the {MAX_VALUE_DEPTH} a value may")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except (SyntaxError, ValueError, MemoryError, RecursionError):  # not Python (or null bytes, or too deep for the parser)
        return text
    if _expression_depth(tree.body) > _MAX_EXPRESSION_DEPTH:
        raise ValueError(f"{what}{_short(text, 40)} is an expression nested too deep for a value")
    if any(isinstance(node, (ast.Dict, ast.Set, ast.DictComp, ast.SetComp)) for node in ast.walk(tree)):
        raise ValueError(f"{what}{_short(text, 40)} is a mapping or a set; a value is a number, text, True/False, None or a list of them")
    try:
        return ast.literal_eval(tree)
    except (ValueError, SyntaxError, TypeError, MemoryError, RecursionError):
        return text


_QUOTED = re.compile(r"'(?:[^'\\]|\\.)*'|\"(?:[^\"\\]|\\.)*\"")


def _bracket_depth(text: str) -> int:
    """The deepest nesting of (), [] and {} in ``text`` outside quoted strings."""
    depth = deepest = 0
    for char in _QUOTED.sub("", text):
        if char in "([{":
            depth += 1
            deepest = max(deepest, depth)
        elif char in ")]}":
            depth = max(depth - 1, 0)
    return deepest


def _expression_depth(node: ast.AST) -> int:
    """The depth of ``node``'s tree, counted without recursion and no further than past the limit."""
    deepest, stack = 0, [(node, 1)]
    while stack:
        node, depth = stack.pop()
        deepest = max(deepest, depth)
        if deepest > _MAX_EXPRESSION_DEPTH:
            break
        stack.extend((child, depth + 1) for child in ast.iter_child_nodes(node))
    return deepest


class _Draft:
    """A config section while a batch of overrides is applied: its class and its field values (a
    section's own a _Draft too).  The overrides set values here, through states a section would
    refuse (physics.timestep_s before physics.control_period_s, gripper.mjcf before
    gripper.fingertips); :meth:`build` makes each section once, checking it then."""

    __slots__ = ("cls", "values")

    def __init__(self, config) -> None:
        self.cls = type(config)
        self.values = {f.name: _draft_of(getattr(config, f.name)) for f in dataclasses.fields(config) if f.init}

    def build(self):
        """The config these values make (each section checked as it is made)."""
        return self.cls(**{name: value.build() if isinstance(value, _Draft) else value for name, value in self.values.items()})


def _draft_of(value):
    return _Draft(value) if dataclasses.is_dataclass(value) and not isinstance(value, type) else value


def _apply(draft: _Draft, key: str, value, full_key: str) -> None:
    """Set the dotted ``key`` of ``draft`` to ``value`` (already parsed); a KeyError for a key it
    does not have.  ``controller.kind`` chooses the controller and with it the section's class:
    the new kind's (:func:`piezotip.controllers.configure`), keeping what the old config was given."""
    head, _, rest = key.partition(".")
    if head not in draft.values or (rest and not isinstance(draft.values[head], _Draft)):
        raise KeyError(key)
    if rest:
        _apply(draft.values[head], rest, value, full_key)
        return
    if isinstance(draft.values[head], _Draft):
        raise KeyError(key)
    hint = typing.get_type_hints(draft.cls)[head]
    if head == "kind" and issubclass(draft.cls, ControllerConfig):
        from piezotip.cosim.control import registry as controllers

        kind = _coerce(full_key, hint, value)
        controller_registration(kind)  # an unknown kind's error names the key
        configured = _Draft(controllers.configure(kind, like=draft.build()))  # the kind comes first: its section is whole
        draft.cls, draft.values = configured.cls, configured.values
        return
    draft.values[head] = _coerce(full_key, hint, value)


def apply_override(config, key: str, value, full_key: str | None = None):
    """A copy of ``config`` with the dotted ``key`` set to ``value`` (already parsed), its sections
    checked as they are made.

    ``controller.kind`` chooses the controller and with it the config's class: the new kind's
    (:func:`piezotip.controllers.configure`), keeping what the old config was given."""
    draft = _Draft(config)
    _apply(draft, key, value, full_key or key)
    return draft.build()


def _shaped(config: ScenarioConfig, draft: _Draft) -> ScenarioConfig:
    """``config`` with the controller section ``draft`` has chosen (its kind's defaults): the keys
    it has, for an unknown key's message, whatever values the batch has given so far."""
    controller = draft.values.get("controller")
    if not isinstance(controller, _Draft) or (controller.cls, controller.values.get("kind")) == (
        type(config.controller),
        config.controller.kind,
    ):
        return config
    from piezotip.cosim.control import registry as controllers

    return dataclasses.replace(config, controller=controllers.configure(controller.values["kind"]))


#: The key that chooses the controller, and so which ``controller.*`` keys there are.
CONTROLLER_KIND_KEY = "controller.kind"


def with_overrides(config: ScenarioConfig, assignments: list[str]) -> ScenarioConfig:
    """Apply ``key=value`` strings, then validate the result and check that the engine can build
    it (:func:`piezotip.cosim.build_checks.check_buildable`).

    In order, except that ``controller.kind`` comes first: it chooses the controller, whose
    config class has the keys the other ``controller.*`` assignments set (so the order they are
    given in does not matter)."""
    pairs = []
    for assignment in assignments:
        key, sep, text = assignment.partition("=")
        key = key.strip()
        if not sep or not key:
            raise ValueError(f"--set takes key=value, got {_short(assignment)}")
        pairs.append((key, text))
    pairs.sort(key=lambda pair: pair[0] != CONTROLLER_KIND_KEY)  # stable: the kinds in their order, then the rest
    draft = _Draft(config)  # the values, set one at a time; each section made (and checked) once, at the end
    for key, text in pairs:
        try:
            _apply(draft, key, parse_value(text.strip(), key), key)
        except KeyError:
            raise ValueError(unknown_key_message(_shaped(config, draft), key)) from None
    return check_buildable(draft.build().validate())  # values, then whether the engine builds it


#: An unknown key's error lists the keys of its part (``object.*``, ...) when there are at most
#: this many: a list a reader scans at a glance.  A longer one (a controller's 30-odd) is left
#: to its dataclass's docstring, which the error names: one line of every key (1,629 characters
#: for a mistyped controller key) is read by no one.
MAX_LISTED_KEYS = 12
#: How close a valid key's last part must come to the unknown one's to be suggested (difflib's
#: ratio: 0.6 takes "mas" for "mass_kg"), and how far behind the best a second may be.
CLOSE_KEY_RATIO, CLOSE_KEY_SPREAD = 0.6, 0.1


def close_keys(key: str, keys: list[str], n: int = 3) -> list[str]:
    """Up to ``n`` of ``keys`` that ``key`` may have meant, best first: those whose last part is
    closest to its last part (a typo in the name, or the right name under the wrong part:
    ``sensor.mass_kg`` is ``object.mass_kg``), those in the key's own part first."""
    leaf = key.rpartition(".")[2]
    by_leaf: dict[str, list[str]] = {}
    for k in keys:
        by_leaf.setdefault(k.rpartition(".")[2], []).append(k)
    scored = [(difflib.SequenceMatcher(None, leaf, name).ratio(), name) for name in by_leaf]
    best = max((score for score, _ in scored), default=0.0)
    names = [name for score, name in sorted(scored, key=lambda sn: -sn[0]) if score >= max(CLOSE_KEY_RATIO, best - CLOSE_KEY_SPREAD)]
    head = key.partition(".")[0] + "."
    found = sorted((k for name in names for k in by_leaf[name]), key=lambda k: not k.startswith(head))  # stable: by score within
    return found[:n]


def unknown_key_message(config: ScenarioConfig, key: str) -> str:
    """Why ``key`` is not one of ``config``'s, in one short line: the keys it may have meant
    (:func:`close_keys`), the keys of its part when they are few (:data:`MAX_LISTED_KEYS`), and
    the dataclass whose docstring lists them all with their units and ranges.  For a
    ``controller.*`` key: the chosen controller's keys, and which registered controllers have it."""
    head, _, name = key.partition(".")
    suggestions = close_keys(key, valid_keys(config))
    meant = f" (did you mean {' or '.join(suggestions)}?)" if suggestions else ""

    def listed(what: str, keys: list[str], cls: type) -> str:
        # the keys themselves when few, else how many and where they are documented (the class's own module)
        doc = f"{cls.__name__}'s docstring in {cls.__module__}"
        if len(keys) <= MAX_LISTED_KEYS:
            return f"; {what}: {', '.join(keys)} (their units and ranges: {doc})"
        return f"; {what} ({len(keys)}), their units and ranges: {doc}"

    if head == "controller" and name and "." not in name:
        from piezotip.cosim.control import registry as controllers

        c = config.controller
        owners = [kind for kind in controllers.names() if name in {f.name for f in dataclasses.fields(controllers.get(kind).config)}]
        elsewhere = f" (the {', '.join(owners)} controller{'s have' if len(owners) > 1 else ' has'} it)" if owners else ""
        own = [f"controller.{k}" for k in valid_keys(c)]
        kind = type(c).__name__
        return f"unknown key {_short(key)} for the {c.kind} controller ({kind}){elsewhere}{meant}{listed('its valid keys', own, type(c))}"
    part = getattr(config, head, None) if head in {f.name for f in dataclasses.fields(config)} else None
    if dataclasses.is_dataclass(part):
        own = [f"{head}.{k}" for k in valid_keys(part)]
        return f"unknown key {_short(key)}{meant}{listed(f'the {head} keys', own, type(part))}"
    fields = dataclasses.fields(config)
    plain = [f.name for f in fields if not dataclasses.is_dataclass(getattr(config, f.name))]
    parts = [f"{f.name}.*" for f in fields if dataclasses.is_dataclass(getattr(config, f.name))]
    return (
        f"unknown key {_short(key)}{meant}; a key is one of {', '.join(plain)} or in {', '.join(parts)} "
        f"(every key with its unit and range: the docstrings of {type(config).__name__} and its parts, in {type(config).__module__})"
    )
