"""piezotip's sensor physics: the bimorph element, the gel and the readout (numpy/scipy only)."""

from .element import ElementParams, SensorElement
from .modes import Boundary, ModeShape, characteristic_root, mode_shape

__all__ = ["Boundary", "ElementParams", "ModeShape", "SensorElement", "characteristic_root", "mode_shape"]
