"""piezotip's sensor physics: the bimorph element, the gel and the readout (numpy/scipy only)."""

from .element import ElementParams, SensorElement
from .fingertip import Fingertip
from .gel import GelModel, GelParams
from .modes import Boundary, ModeShape, characteristic_root, mode_shape
from .readout import NoiseParams, PressureEstimate
from .stress import Mounting

__all__ = [
    "Boundary",
    "ElementParams",
    "Fingertip",
    "GelModel",
    "GelParams",
    "ModeShape",
    "Mounting",
    "NoiseParams",
    "PressureEstimate",
    "SensorElement",
    "characteristic_root",
    "mode_shape",
]
