"""The registered scenarios, each with its whole configuration in one place.

Objects come from :mod:`scenarios.objects` (one definition each)."""

from __future__ import annotations

from . import register
from .config import DisturbConfig, ScenarioConfig
from .objects import OBJECTS


@register
def grasp() -> ScenarioConfig:
    """The default job: grasp a 100 g, 40 mm box, lift it 5 cm, hold it for a second, put it back."""
    return ScenarioConfig(
        name="grasp",
        description="grasp a 100 g box, lift 5 cm, hold 1 s, put it back (the README's main job)",
        object=OBJECTS["box-100g"],
    )


@register
def grasp_light() -> ScenarioConfig:
    """A 3 g, 20 mm cube: the grip must stay gentle and touch must be felt early."""
    return ScenarioConfig(name="grasp-light", description="grasp a 3 g, 20 mm cube", object=OBJECTS["cube-3g"])


@register
def grasp_fragile() -> ScenarioConfig:
    """An egg: 60 g, 44 mm across; it cracks above 25 N of grip per finger."""
    return ScenarioConfig(name="grasp-fragile", description="grasp an egg (60 g, crushes above 25 N per finger)", object=OBJECTS["egg-60g"])


@register
def grasp_raspberry() -> ScenarioConfig:
    """A ripe raspberry: 4 g, crushed by 1.5 N; a fixed grip floor of 1 N would come close."""
    return ScenarioConfig(
        name="grasp-raspberry", description="grasp a raspberry (4 g, crushes above 1.5 N per finger)", object=OBJECTS["raspberry-4g"]
    )


@register
def grasp_heavy() -> ScenarioConfig:
    """A 0.5 kg, 60 mm upright cylinder (a full drinks can, roughly)."""
    return ScenarioConfig(name="grasp-heavy", description="grasp a 0.5 kg cylinder", object=OBJECTS["can-500g"])


@register
def grasp_slippery() -> ScenarioConfig:
    """A 0.3 kg glass jar at friction 0.3, below the 0.8 the controller assumes."""
    return ScenarioConfig(name="grasp-slippery", description="grasp a 0.3 kg glass jar (friction 0.3)", object=OBJECTS["glass-jar-300g"])


@register
def grasp_10kg() -> ScenarioConfig:
    """A 10 kg, 80 mm dense block: the heaviest load the gripper is rated for."""
    return ScenarioConfig(name="grasp-10kg", description="grasp a 10 kg dense block", object=OBJECTS["block-10kg"])


@register
def grasp_disturb() -> ScenarioConfig:
    """The default job's 100 g box, and at the middle of the hold an extra downward load of its own
    weight comes on over 50 ms (disturb.extra_load_n None: the object's weight; DisturbConfig):
    how fast, and how far, the grip answers a load change."""
    return ScenarioConfig(
        name="grasp-disturb",
        description="grasp the 100 g box; mid-hold its weight again comes on over 50 ms (a load change)",
        object=OBJECTS["box-100g"],
        disturb=DisturbConfig(extra_load_n=None),
    )
