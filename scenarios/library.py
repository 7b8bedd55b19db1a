"""The registered scenarios, each with its whole configuration in one place."""

from __future__ import annotations

from . import register
from .config import ControllerConfig, ObjectConfig, ScenarioConfig


@register
def grasp() -> ScenarioConfig:
    """The default job: grasp a 100 g, 40 mm box, lift it 5 cm, hold it for a second."""
    return ScenarioConfig(
        name="grasp",
        description="grasp a 100 g box, lift 5 cm, hold 1 s (the README's main job)",
        object=ObjectConfig(shape="box", mass_kg=0.1, size_m=0.04, friction=1.0),
    )


@register
def grasp_light() -> ScenarioConfig:
    """A 3 g, 20 mm cube: the grip must stay gentle and touch must be felt early."""
    return ScenarioConfig(
        name="grasp-light",
        description="grasp a 3 g, 20 mm cube",
        object=ObjectConfig(shape="box", mass_kg=0.003, size_m=0.02, friction=0.8),
    )


@register
def grasp_fragile() -> ScenarioConfig:
    """An egg: 60 g, 44 mm across; it cracks above 25 N of grip per finger.

    A hen's egg breaks at 30-50 N between flat plates; 25 N keeps a margin for the
    concentrated load of a small pad.
    """
    return ScenarioConfig(
        name="grasp-fragile",
        description="grasp an egg (60 g, crushes above 25 N per finger)",
        object=ObjectConfig(shape="egg", mass_kg=0.06, size_m=0.044, friction=0.6, crush_force_n=25.0),
    )


@register
def grasp_heavy() -> ScenarioConfig:
    """A 0.5 kg, 60 mm upright cylinder (a full drinks can, roughly)."""
    return ScenarioConfig(
        name="grasp-heavy",
        description="grasp a 0.5 kg cylinder",
        object=ObjectConfig(shape="cylinder", mass_kg=0.5, size_m=0.06, friction=1.0),
    )


@register
def grasp_10kg() -> ScenarioConfig:
    """A 10 kg, 80 mm dense block (tungsten-like): the heaviest load the gripper is rated for."""
    return ScenarioConfig(
        name="grasp-10kg",
        description="grasp a 10 kg dense block",
        duration_s=5.0,
        object=ObjectConfig(shape="box", mass_kg=10.0, size_m=0.08, friction=1.0),
        controller=ControllerConfig(hold_s=1.0),
    )
