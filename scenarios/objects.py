"""The objects the project grasps, each defined once: the scenario library and the grasp
experiments both take them from here (the scene file holds only a placeholder that
cosim.assembly.build_scene replaces).

Masses and sizes are those of the everyday objects named; friction is against the pads'
silicone film (dry contacts: 0.3 for glass, about 1 for cardboard and painted metal, 1.2 for
rubber); crush limits are per-finger squeeze forces between flat plates, with their source.
"""

from __future__ import annotations

from .config import ObjectConfig

OBJECTS: dict[str, ObjectConfig] = {
    # An empty paper box, the lightest object the gripper is rated for.
    "tissue-box-1g": ObjectConfig(shape="box", mass_kg=0.001, size_m=0.03, friction=0.6),
    # A folded-paper sphere that dents under a tenth of a newton: the most fragile case.
    "paper-ball-2g": ObjectConfig(shape="sphere", mass_kg=0.002, size_m=0.03, friction=0.5, crush_force_n=0.1),
    # An empty paperboard cube (the light end of the range, 1-5 g).
    "cube-3g": ObjectConfig(shape="box", mass_kg=0.003, size_m=0.02, friction=0.8),
    # A ripe raspberry crushes at 1-2 N between flat plates; 1.5 N here.
    "raspberry-4g": ObjectConfig(shape="sphere", mass_kg=0.004, size_m=0.02, friction=0.9, crush_force_n=1.5),
    # A rubber ball: the grippiest surface of the set.
    "rubber-ball-50g": ObjectConfig(shape="sphere", mass_kg=0.05, size_m=0.05, friction=1.2),
    # A hen's egg lying on its side; shells fail at 30-50 N across the equator, 25 N keeps a
    # margin for the concentrated load of a small pad.
    "egg-60g": ObjectConfig(shape="egg", mass_kg=0.06, size_m=0.044, friction=0.6, crush_force_n=25.0),
    # The default job's box.
    "box-100g": ObjectConfig(shape="box", mass_kg=0.1, size_m=0.04, friction=1.0),
    # A small glass jar: glass on silicone is the slipperiest common contact.
    "glass-jar-300g": ObjectConfig(shape="cylinder", mass_kg=0.3, size_m=0.06, friction=0.3),
    # A full drinks can, roughly.
    "can-500g": ObjectConfig(shape="cylinder", mass_kg=0.5, size_m=0.06, friction=1.0),
    "block-2kg": ObjectConfig(shape="box", mass_kg=2.0, size_m=0.06, friction=1.0),
    # A dense block: the heaviest load the gripper is rated for.
    "block-10kg": ObjectConfig(shape="box", mass_kg=10.0, size_m=0.08, friction=1.0),
    # The same block oiled: holding it needs m g / (2 mu) = 164 N per finger, more than the
    # fingers' 100 N, so no controller can lift it.
    "oily-block-10kg": ObjectConfig(shape="box", mass_kg=10.0, size_m=0.08, friction=0.3),
}


def get_object(name: str) -> ObjectConfig:
    """The catalogue's object ``name``; an unknown name lists the valid ones."""
    if name not in OBJECTS:
        raise ValueError(f"unknown object {name!r}; valid objects: {', '.join(OBJECTS)}")
    return OBJECTS[name]


def object_overrides(name: str) -> list[str]:
    """``--set`` assignments that put object ``name`` into any scenario."""
    obj = get_object(name)
    return [f"object.{key}={getattr(obj, key)!r}" for key in ("shape", "mass_kg", "size_m", "friction", "crush_force_n")]
