"""Fidelity presets: every knob that trades speed for accuracy, set together and named.

A preset is a list of ``--set`` assignments applied before the user's own (so any knob stays
overridable).  The control period (the controller's and lock-in's 5 ms) is the same in every
preset: it is a design choice of the robot, not a fidelity knob.

=========  ==========  ==========  ==========  ============  =============  =========  ==========
preset     timestep    integrator  gel law     pad segments  sensor         gel        gel tables
=========  ==========  ==========  ==========  ============  =============  =========  ==========
fast       1.25 ms     discrete    per period  1 (uniform)   steady state   one freq   tables
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
errors against ``reference``, and shows ``reference`` converged by halving its steps.
"""

from __future__ import annotations

PRESETS: dict[str, tuple[str, ...]] = {
    "fast": (
        "physics.timestep_s=0.00125",
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
        "physics.timestep_s=0.00025",
        "physics.integrator=discrete",
        "physics.gel_update=substep",
        "physics.pad_segments=9",
        "sensor.dynamics=carrier",
        "sensor.carrier_samples_per_cycle=16",
        "sensor.gel_frequency_dependent=True",
        "sensor.exact_gel=True",
        "sensor.gel_layer=winkler",
    ),
}

#: The reference with its steps halved: the convergence check.
REFERENCE_HALVED: tuple[str, ...] = (
    *PRESETS["reference"],
    "physics.timestep_s=0.000125",
    "physics.pad_segments=17",
    "sensor.carrier_samples_per_cycle=32",
)


def preset_overrides(name: str | None) -> list[str]:
    """The ``--set`` assignments of preset ``name`` (none for None); unknown names list the valid ones."""
    if name is None:
        return []
    if name not in PRESETS:
        raise ValueError(f"unknown preset {name!r}; valid presets: {', '.join(PRESETS)}")
    return list(PRESETS[name])
