"""piezotip's MuJoCo side: the gripper model, the pad mechanics and (later) the step loop.

This package imports ``mujoco`` and :mod:`sensor`; :mod:`sensor` never imports it.
"""

from .pads import (
    DEFAULT_PAD_SEGMENTS,
    MODELS_DIR,
    PAD_NAMES,
    PadBridge,
    PadGeometry,
    PadReading,
    build_model,
    scene_names,
    scene_path,
)

__all__ = [
    "DEFAULT_PAD_SEGMENTS",
    "MODELS_DIR",
    "PAD_NAMES",
    "PadBridge",
    "PadGeometry",
    "PadReading",
    "build_model",
    "scene_names",
    "scene_path",
]
