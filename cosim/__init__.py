"""piezotip's MuJoCo side: the gripper model, the pad mechanics and (later) the step loop.

This package imports ``mujoco`` and :mod:`sensor`; :mod:`sensor` never imports it.
"""

from .pad_bridge import PadBridge, PadReading
from .pad_geometry import DEFAULT_PAD_SEGMENTS, PAD_NAMES, PadGeometry
from .pad_model import MODELS_DIR, build_model, scene_names, scene_path

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
