"""Fidelity presets: every knob that trades speed for accuracy, set together and named.

A preset is a list of ``--set`` assignments applied before the user's own (so any knob stays
overridable).  The control period (the controller's and lock-in's 5 ms) is the same in every
preset: it is a design choice of the robot, not a fidelity knob.

=========  ==========  ==========  ==========  ============  =============  =========  ==========
preset     timestep    integrator  gel law     pad segments  sensor         gel        gel tables
=========  ==========  ==========  ==========  ============  =============  =========  ==========
fast       5/3 ms      discrete    per period  1 (uniform)   steady state   one freq   tables
balanced   1 ms        discrete    per period  1 (uniform)   envelope       per mode   tables
accurate   0.5 ms      discrete    per step    5             envelope       per mode   exact
reference  0.25 ms     discrete    per step    9             carrier, 16/c  per mode   exact
=========  ==========  ==========  ==========  ============  =============  =========  ==========

"gel law per period": the pads' Gent law is linearized once per 5 ms control period and its
tangent applied by MuJoCo at every physics step (no Python between steps); "per step" evaluates
it before every physics step.

The gel's layer model is a knob too (``sensor.gel_layer``), set to ``winkler`` in every
preset: the one-dimensional ``dynamic`` layer (the column's M k cot(k h)) predicts every mode
saturated below 1 kPa, against the prototype's measured 10 kPa in mode 3 (README, "The gel's
two layer models"), so it is not the more faithful model here; ``--set
sensor.gel_layer=dynamic`` runs it.

``discrete`` is the only integrator that integrates the gel's stiff law stably at these steps
(models/README.md); the others are refused before a run starts, with the largest timestep
they would need.  The benchmark (``run_sim.py bench``) measures each preset's cost and its
errors against ``reference``, and the reference's own convergence: the reference refined as a
whole (:func:`reference_refined`: its timestep, pad strip width and carrier sampling interval
halved once and twice) gives the observed order and the Richardson-extrapolated value of each
compared quantity, hence the reference's own uncertainty (reports/fidelity.py).
"""

from __future__ import annotations

#: The fast preset's physics step: three per 5 ms control period.  Measured on the cost and
#: error curve (``bench`` with this step set to 1.25, 5/3 and 2.5 ms): the pressure-estimate
#: error against the reference stays 1.6e-3 (set by the steady sensor and the one-frequency
#: gel, not by the step) and all 60 runs of ``experiment grasp-range`` end as they do at
#: 1.25 ms, at 55x real time instead of 46x.  At 2.5 ms (the fingers' 660 rad/s servo at
#: omega dt = 1.65) the servo's jitter begins to reach the fingertip as false touches (two in
#: those 60 runs), so the coarser step is not taken.
FAST_TIMESTEP_S = 0.005 / 3

#: The reference's three resolutions (refined together by :func:`reference_refined`).
REFERENCE_TIMESTEP_S = 0.00025
REFERENCE_PAD_SEGMENTS = 9
REFERENCE_CARRIER_SAMPLES = 16

PRESETS: dict[str, tuple[str, ...]] = {
    "fast": (
        f"physics.timestep_s={FAST_TIMESTEP_S!r}",
        "physics.integrator=discrete",
        "physics.gel_update=control",
        "physics.pad_segments=1",
        "sensor.dynamics=steady",
        "sensor.gel_frequency_dependent=False",
        "sensor.exact_gel=False",
        "sensor.gel_layer=winkler",
    ),
    "balanced": (
        "physics.timestep_s=0.001",
        "physics.integrator=discrete",
        "physics.gel_update=control",
        "physics.pad_segments=1",
        "sensor.dynamics=envelope",
        "sensor.gel_frequency_dependent=True",
        "sensor.exact_gel=False",
        "sensor.gel_layer=winkler",
    ),
    "accurate": (
        "physics.timestep_s=0.0005",
        "physics.integrator=discrete",
        "physics.gel_update=substep",
        "physics.pad_segments=5",
        "sensor.dynamics=envelope",
        "sensor.gel_frequency_dependent=True",
        "sensor.exact_gel=True",
        "sensor.gel_layer=winkler",
    ),
    "reference": (
        f"physics.timestep_s={REFERENCE_TIMESTEP_S!r}",
        "physics.integrator=discrete",
        "physics.gel_update=substep",
        f"physics.pad_segments={REFERENCE_PAD_SEGMENTS}",
        "sensor.dynamics=carrier",
        f"sensor.carrier_samples_per_cycle={REFERENCE_CARRIER_SAMPLES}",
        "sensor.gel_frequency_dependent=True",
        "sensor.exact_gel=True",
        "sensor.gel_layer=winkler",
    ),
}

#: The reference's resolution knobs, each a step that :func:`reference_refined` halves.
RESOLUTION_KNOBS = ("timestep", "pad_segments", "carrier_samples")


def reference_refined(halvings: int, knobs: tuple[str, ...] = RESOLUTION_KNOBS) -> tuple[str, ...]:
    """The reference with the steps of ``knobs`` halved ``halvings`` times (0: the reference).

    Every step shrinks by exactly 2**halvings, so that three rungs (0, 1, 2) give an observed
    order and a Richardson extrapolation with one refinement ratio: the physics timestep, the
    pad strips' width (9 -> 18 -> 36 strips over the element) and the carrier's sampling
    interval (16 -> 32 -> 64 samples per cycle).  ``knobs`` (a subset of
    :data:`RESOLUTION_KNOBS`) refines one knob alone, to tell them apart.
    """
    if not isinstance(halvings, int) or halvings < 0:
        raise ValueError(f"halvings must be a whole number >= 0, got {halvings!r}")
    unknown = set(knobs) - set(RESOLUTION_KNOBS)
    if unknown:
        raise ValueError(f"unknown resolution knobs {sorted(unknown)}; valid: {', '.join(RESOLUTION_KNOBS)}")
    factor = 2**halvings
    refined = []
    if "timestep" in knobs:
        refined.append(f"physics.timestep_s={REFERENCE_TIMESTEP_S / factor!r}")
    if "pad_segments" in knobs:
        refined.append(f"physics.pad_segments={REFERENCE_PAD_SEGMENTS * factor}")
    if "carrier_samples" in knobs:
        refined.append(f"sensor.carrier_samples_per_cycle={REFERENCE_CARRIER_SAMPLES * factor}")
    return (*PRESETS["reference"], *refined)


#: The reference with its steps halved: the first rung of its convergence check.
REFERENCE_HALVED: tuple[str, ...] = reference_refined(1)


def preset_overrides(name: str | None) -> list[str]:
    """The ``--set`` assignments of preset ``name`` (none for None); unknown names list the valid ones."""
    if name is None:
        return []
    if name not in PRESETS:
        raise ValueError(f"unknown preset {name!r}; valid presets: {', '.join(PRESETS)}")
    return list(PRESETS[name])
