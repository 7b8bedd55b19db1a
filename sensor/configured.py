"""The fingertip a :class:`~piezotip.sensor.config.SensorConfig` describes: its nominal design, as
the readout and the controller know it, and the physical unit the simulation runs when that unit
is not the design (``sensor.variation``, ``sensor.temperature_c``: piezotip.sensor.calibration).

Below the engine and the controllers, which both build them (cosim.instrument.make_fingertip and
make_unit; the multimode controller's start-up self-test).
"""

from __future__ import annotations

from piezotip.sensor.calibration import SensorUnit, sensor_unit
from piezotip.sensor.config import SensorConfig
from piezotip.sensor.element import ElementParams, SensorElement
from piezotip.sensor.fingertip import Fingertip
from piezotip.sensor.gel import GelModel


def physical_unit(s: SensorConfig) -> SensorUnit | None:
    """The physical unit the simulation runs and its calibration (piezotip.sensor.calibration),
    or None when the unit is the nominal design itself (``sensor.variation=none`` at 25 C)."""
    unit = s.unit_config()
    if unit.is_nominal and unit.level == "none":
        return None
    return sensor_unit(unit, nominal_fingertip(s))


def nominal_fingertip(s: SensorConfig) -> Fingertip:
    """The nominal design: Table I element (or the configured Q), gel, coverage, modes."""
    element = SensorElement(ElementParams())
    if s.quality_factor is not None:
        element = element.with_quality_factor(s.quality_factor)
    gel = GelModel(
        frequency_dependent=s.gel_frequency_dependent, reference_freq_hz=element.natural_frequency_hz(s.modes[0]), layer=s.gel_layer
    )
    coverage = (s.coverage_mm[0] * 1e-3, s.coverage_mm[1] * 1e-3)
    return Fingertip(element=element, gel=gel, coverage=coverage, modes=s.modes)


__all__ = ["nominal_fingertip", "physical_unit"]
