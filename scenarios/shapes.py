"""The object shapes' registry, re-exported: it lives in :mod:`piezotip.cosim.shapes`, beside the
scene that builds the shapes' geoms (register a shape with either name: they are the same registry)."""

from piezotip.cosim.shapes import (  # noqa: F401
    _SHAPES,
    EGG_ASPECT,
    GEOM_TYPES,
    Builder,
    Shape,
    ShapeGeom,
    get_shape,
    register_shape,
    shape_names,
    unregister_shape,
)

__all__ = ["EGG_ASPECT", "GEOM_TYPES", "Shape", "ShapeGeom", "get_shape", "register_shape", "shape_names", "unregister_shape"]
