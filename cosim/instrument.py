"""The fingertip and its channels a scenario's config makes: the nominal design or the physical
unit its calibration measured, and one sensor channel per pad.

The one factory of the house loop (:mod:`cosim.loop`), of :func:`cosim.attach.attach`'s
fingertips and of the build checks (:mod:`cosim.build_checks`), below all three.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from piezotip.cosim.config import ScenarioConfig
from piezotip.sensor import Fingertip
from piezotip.sensor.calibration import SensorUnit
from piezotip.sensor.channel import SensorChannel
from piezotip.sensor.configured import nominal_fingertip, physical_unit
from piezotip.sensor.unit_channel import UnitChannel

__all__ = ["make_channels", "make_fingertip", "make_unit"]


def make_fingertip(config: ScenarioConfig) -> Fingertip:
    """The scenario's Fingertip as the readout and the controller know it: the nominal design
    (below), plus what calibration measured when the physical unit is not that design
    (``sensor.variation``, ``sensor.temperature_c``: :func:`make_unit`)."""
    unit = make_unit(config)
    return unit.model if unit is not None else _nominal_fingertip(config)


def make_unit(config: ScenarioConfig) -> SensorUnit | None:
    """The physical unit the simulation runs and its calibration (piezotip.sensor.calibration),
    or None when the unit is the nominal design itself (``sensor.variation=none`` at 25 C):
    :func:`piezotip.sensor.configured.physical_unit` of the scenario's sensor."""
    return physical_unit(config.sensor)


def make_channels(
    config: ScenarioConfig, fingertip: Fingertip, unit: SensorUnit | None, edges_m: Mapping[str, np.ndarray]
) -> dict[str, SensorChannel]:
    """One sensor channel per pad of ``edges_m`` (pad name -> its coverage cells' edges along the
    element, m), in its order: the unit's own (:class:`UnitChannel`) when ``unit`` is not the
    nominal design, driven from the start (steady, settled) in the controller's most sensitive
    mode, each with its own noise from ``sensor.seed`` (the pads' seeds drawn in order).  The
    one factory of the house loop and of :func:`cosim.attach.attach`'s fingertips."""
    s = config.sensor
    options = {
        "dynamics": s.dynamics,
        "mode": min(config.controller.modes),
        "noise": s.noise,
        "exact": s.exact_gel or s.gel_layer == "dynamic",  # tables need k_e > 0
        "carrier_samples_per_cycle": s.carrier_samples_per_cycle,
    }
    kind, units = (SensorChannel, ()) if unit is None else (UnitChannel, (unit,))
    rng = np.random.default_rng(s.seed)
    return {
        pad: kind(fingertip, *units, edges_m=edges, rng=np.random.default_rng(rng.integers(2**63)), **options)
        for pad, edges in edges_m.items()
    }


def _nominal_fingertip(config: ScenarioConfig) -> Fingertip:
    """The nominal design: Table I element (or the configured Q), gel, coverage, modes."""
    return nominal_fingertip(config.sensor)
