"""Whether the engine can build a scenario: what its values alone do not tell.

The config classes (cosim/config.py and the sections it holds) check values only.  Building needs
more: the gripper's file (``gripper.mjcf``) must load and have the parts its keys name
(:func:`piezotip.cosim.gripper_mount.check_gripper`), and the fingertip must build (a varied
unit calibrated) and, for a controller that reads it, give each allowed mode a band and a switch
pressure up to the next (cosim.control.selector).  :func:`check_buildable` checks them, each a
ValueError naming the keys, once per gripper file and sensor configuration (cached): the
overrides run it (:func:`piezotip.scenarios.config.with_overrides`, so every named scenario,
the command line and the sweeps refuse such a config before anything runs), and so does
:class:`piezotip.cosim.loop.CoSimulation` for a config made otherwise.
"""

from __future__ import annotations

import dataclasses
import itertools
from typing import TYPE_CHECKING

from piezotip.cosim.config import controller_registration
from piezotip.sensor.checks import _short

if TYPE_CHECKING:
    from piezotip.cosim.config import ScenarioConfig


def check_buildable(config: ScenarioConfig) -> ScenarioConfig:
    """Check that the engine can build ``config`` (validated): its gripper file, then its
    fingertip against its controller.  Return it, so it chains; a ValueError naming the keys."""
    from piezotip.cosim.gripper_mount import check_gripper

    check_gripper(config.gripper)  # the file loads, and names what these keys name (a ValueError naming the key)
    _check_fingertip(config, controller_registration(config.controller.kind).senses)
    return config


#: Per (sensor config but its noise seed, allowed modes, controller kind, whether it senses): None where the fingertip
#: is one the run can build and its modes' ranges suit the controller, else why not (_check_fingertip).
_FINGERTIPS: dict[tuple, str | None] = {}


def _check_fingertip(config: ScenarioConfig, senses: bool) -> None:
    """The fingertip the run builds (cosim.instrument.make_fingertip: a varied unit calibrated), and for
    a controller that reads the fingertips (registered with ``senses``: the multimode ones) each
    allowed mode the most useful somewhere and a switch pressure from each up to the next (the
    edge between their bands): what their mode selector is built for (cosim.control.selector
    switches one allowed mode up as the pressure rises past it).

    Computed once per sensor configuration, with the selector's own ranges (cached on disk, so
    the run then finds them done); a ValueError naming the sensor's keys otherwise."""
    modes = tuple(sorted(config.controller.modes))
    # The readout's noise seed builds no other fingertip (each Gym reset draws a new one): not a key.
    key = (dataclasses.replace(config.sensor, seed=0), modes, config.controller.kind, senses)
    if key not in _FINGERTIPS:
        _FINGERTIPS[key] = _fingertip_problem(config, modes, senses)
    if _FINGERTIPS[key] is not None:
        raise ValueError(_FINGERTIPS[key])


def _fingertip_problem(config: ScenarioConfig, modes: tuple[int, ...], senses: bool) -> str | None:
    from piezotip.cosim.control.selector import allowed_ranges
    from piezotip.cosim.instrument import make_fingertip

    s = config.sensor
    try:
        tip = make_fingertip(config)
    except ValueError as err:
        unit = f"sensor.variation={s.variation}, sensor.unit_seed={s.unit_seed}, sensor.coverage_mm={s.coverage_mm!r}"
        return f"the fingertip ({unit}) cannot be built: {err}"
    if not senses:  # drives no mode selector
        return None
    _, bands, _, _ = allowed_ranges(tip, modes)
    order = [band[0] for band in bands]
    switches = set(itertools.pairwise(order))
    lacking = [m for m in modes if m not in order]
    missing = [pair for pair in itertools.pairwise(modes) if pair not in switches]
    if not lacking and not missing:
        return None
    why = (
        f"mode {lacking[0]} is nowhere the most useful of them"
        if lacking
        else f"there is no switch pressure from mode {missing[0][0]} up to mode {missing[0][1]}"
    )
    unit = "" if s.unit_config().is_nominal else f"sensor.variation={s.variation}, sensor.temperature_c={s.temperature_c!r}, "
    return (
        f"controller.modes {list(modes)}: with sensor.coverage_mm={s.coverage_mm!r}, sensor.quality_factor={s.quality_factor!r}, {unit}"
        f"sensor.gel_layer={s.gel_layer} and sensor.modes={list(s.modes)} {why} (the most useful mode from low to high pressure: "
        f"{_short(', '.join(map(str, order)) or 'none', 60)[1:-1]}), which the {config.controller.kind} controller's mode switching "
        "(one mode up as the pressure rises past their switch pressure) needs: cover the element's tip, or allow fewer modes"
    )


__all__ = ["check_buildable"]
