"""The object shapes: a registry of builders, each turning an object's size into its MuJoCo geom.

A shape is registered once, here, and is then everything the rest of the package knows of it:
``object.shape`` accepts exactly the registered names (:class:`cosim.config.ObjectConfig`,
whose ``OBJECT_SHAPES`` lists them in registration order) and :func:`cosim.scene.object_shape`
builds the object's geom from the registration, so a shape cannot be accepted without building
its own geom, nor built as another.  This module imports nothing from MuJoCo or the engine (a
config is checked without them): a geom type is named by MuJoCo's name for it (``"box"`` for
``mujoco.mjtGeom.mjGEOM_BOX``), checked against :data:`GEOM_TYPES` when the shape is registered.

To add a shape, register its builder: a function of ``size_m`` (the object's width between the
fingers, m) returning its geom's three half-sizes (m; MuJoCo's ``size``, the entries the geom
type does not use 0) and the height of its centre resting on the table (m)::

    @register_shape("capsule", geom_type="capsule", description="a capsule lying across the fingers")
    def _capsule(size_m: float) -> tuple[tuple[float, float, float], float]:
        r = 0.5 * size_m
        return (r, r, 0.0), r

A registration with a geom type not in :data:`GEOM_TYPES`, a name already taken, or a builder
whose sizes or rest height are not finite and positive for a positive size is refused with a
``ValueError`` naming it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

#: The MuJoCo geom types an object may be (``mujoco.mjtGeom.mjGEOM_<NAME>``): the primitive solids.
#: A plane or a height field is no object on a table, and a mesh or an SDF needs an asset.
GEOM_TYPES = ("sphere", "capsule", "ellipsoid", "cylinder", "box")
#: How many of MuJoCo's three ``size`` entries each geom type uses (the rest are ignored).
_SIZES_USED = {"sphere": 1, "capsule": 2, "ellipsoid": 3, "cylinder": 2, "box": 3}
#: Sizes a builder is tried at when it is registered, m: the gripper's objects (12-85 mm) and beyond.
_PROBE_SIZES_M = (0.001, 0.04, 1.0)
#: Egg proportions: the long axis (along y, the egg lies on its side) over the short one.
EGG_ASPECT = 57.0 / 43.0

Builder = Callable[[float], tuple[tuple[float, float, float], float]]


@dataclass(frozen=True)
class ShapeGeom:
    """What a shape builds for one size: its geom type (MuJoCo's name), half-sizes (m) and the
    height of its centre at rest on the table (m)."""

    geom_type: str
    size: tuple[float, float, float]
    rest_height_m: float


@dataclass(frozen=True)
class Shape:
    """A registered shape: its name (``object.shape``), MuJoCo geom type, one-line description
    and the builder of its half-sizes and rest height from ``size_m`` (see the module)."""

    name: str
    geom_type: str
    description: str
    builder: Builder

    def geom(self, size_m: float) -> ShapeGeom:
        """The geom for an object ``size_m`` wide between the fingers (m); ValueError if the
        builder's sizes or rest height are not finite and positive there."""
        built = self.builder(float(size_m))
        try:
            size, rest = built
            size = tuple(float(s) for s in size)
            rest = float(rest)
        except (TypeError, ValueError):
            raise ValueError(
                f"shape {self.name!r}'s builder must return (three half-sizes, rest height), got {built!r} for size_m={size_m!r}"
            ) from None
        used = _SIZES_USED[self.geom_type]
        if (
            len(size) != 3
            or not all(math.isfinite(s) and s > 0.0 for s in size[:used])
            or not all(math.isfinite(s) and s >= 0.0 for s in size[used:])
        ):
            raise ValueError(
                f"shape {self.name!r} ({self.geom_type}) must have three finite half-sizes, the first {used} positive, "
                f"got {size!r} for size_m={size_m!r}"
            )
        if not (math.isfinite(rest) and rest > 0.0):
            raise ValueError(f"shape {self.name!r} must rest with its centre above the table, got {rest!r} m for size_m={size_m!r}")
        return ShapeGeom(self.geom_type, (size[0], size[1], size[2]), rest)


_SHAPES: dict[str, Shape] = {}


def register_shape(name: str, *, geom_type: str, description: str) -> Callable[[Builder], Builder]:
    """Decorator: register the builder it decorates as shape ``name`` (see the module).

    ValueError if ``name`` is taken or not a name, ``geom_type`` is not one of :data:`GEOM_TYPES`,
    or the builder's sizes are not finite and positive for positive sizes."""

    def register(builder: Builder) -> Builder:
        if not isinstance(name, str) or not name.isidentifier():
            raise ValueError(f"a shape's name must be an identifier, got {name!r}")
        if name in _SHAPES:
            raise ValueError(f"shape {name!r} is registered already")
        if geom_type not in GEOM_TYPES:
            raise ValueError(f"shape {name!r}: geom type must be one of {', '.join(GEOM_TYPES)}; got {geom_type!r}")
        shape = Shape(name, geom_type, str(description), builder)
        for size_m in _PROBE_SIZES_M:
            shape.geom(size_m)
        _SHAPES[name] = shape
        return builder

    return register


def unregister_shape(name: str) -> Shape:
    """Remove shape ``name`` from the registry (a test's temporary shape) and return it."""
    if name not in _SHAPES:
        raise ValueError(f"shape {name!r} is not registered; registered shapes: {', '.join(_SHAPES)}")
    return _SHAPES.pop(name)


def shape_names() -> tuple[str, ...]:
    """The registered shapes' names, in registration order."""
    return tuple(_SHAPES)


def get_shape(name: str) -> Shape:
    """The registered shape ``name``; ValueError listing the registered ones otherwise."""
    shape = _SHAPES.get(name) if isinstance(name, str) else None
    if shape is None:
        raise ValueError(f"unknown shape {name!r}; registered shapes: {', '.join(_SHAPES)}")
    return shape


# -- The built-in shapes (their numbers are the scene's since before the registry) ----------------


@register_shape("box", geom_type="box", description="a cube, size_m along each edge")
def _box(size_m: float) -> tuple[tuple[float, float, float], float]:
    r = 0.5 * size_m
    return (r, r, r), r


@register_shape("cylinder", geom_type="cylinder", description="an upright cylinder, size_m across and 1.2 diameters tall")
def _cylinder(size_m: float) -> tuple[tuple[float, float, float], float]:
    r = 0.5 * size_m
    return (r, 1.2 * r, 0.0), 1.2 * r


@register_shape("sphere", geom_type="sphere", description="a sphere, size_m across")
def _sphere(size_m: float) -> tuple[tuple[float, float, float], float]:
    r = 0.5 * size_m
    return (r, 0.0, 0.0), r


@register_shape(
    "egg",
    geom_type="ellipsoid",
    description="an egg: an ellipsoid on its side, size_m between the fingers, its long axis (57/43 of that) along the pads",
)
def _egg(size_m: float) -> tuple[tuple[float, float, float], float]:
    r = 0.5 * size_m
    return (r, EGG_ASPECT * r, r), r


__all__ = ["EGG_ASPECT", "GEOM_TYPES", "Shape", "ShapeGeom", "get_shape", "register_shape", "shape_names", "unregister_shape"]
