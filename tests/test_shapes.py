"""The object shapes' registry (scenarios/shapes.py): every registered shape builds its own geom in
the house scene, a shape registered elsewhere (a test's capsule) is accepted and built end to end,
and a bad registration or an unknown shape is refused by name (issue 45, "objects, not switches")."""

from __future__ import annotations

import ast
import math

import mujoco
import numpy as np
import pytest

from piezotip import scenarios
from piezotip.cosim import scene
from piezotip.cosim.assembly import build_scene
from piezotip.cosim.loop import CoSimulation
from piezotip.cosim.scene import object_shape
from piezotip.scenarios import shapes
from piezotip.scenarios.config import OBJECT_SHAPES, ObjectConfig
from piezotip.scenarios.shapes import EGG_ASPECT, GEOM_TYPES, get_shape, register_shape, shape_names, unregister_shape

BUILT_IN = ("box", "cylinder", "sphere", "egg")


def _capsule(size_m: float) -> tuple[tuple[float, float, float], float]:
    """An upright capsule: size_m across, its cylinder as long as it is wide (2 diameters tall)."""
    r = 0.5 * size_m
    return (r, r, 0.0), 2.0 * r


@pytest.fixture
def capsule():
    """Shape "capsule" registered for the test only."""
    register_shape("capsule", geom_type="capsule", description="an upright capsule, size_m across")(_capsule)
    try:
        yield get_shape("capsule")
    finally:
        unregister_shape("capsule")


def _object_geom(model: mujoco.MjModel):
    return model.geom("object_geom")


# -- the registry and the config --------------------------------------------------------------


def test_the_config_shapes_are_the_registry_s_in_registration_order():
    assert shape_names() == OBJECT_SHAPES == BUILT_IN


def test_every_allowed_geom_type_is_a_mujoco_solid():
    members = mujoco.mjtGeom.__members__
    assert all(f"mjGEOM_{name.upper()}" in members for name in GEOM_TYPES)
    assert not {"plane", "hfield", "mesh", "sdf"} & set(GEOM_TYPES)


def test_the_built_in_shapes_keep_their_numbers():
    """The scene's numbers from before the registry: box r r r rest r, cylinder r 1.2r rest 1.2r,
    sphere r rest r, egg (r, 57/43 r, r) rest r, with r half the width between the fingers."""
    size_m = 0.044
    r = 0.5 * size_m
    expected = {
        "box": (mujoco.mjtGeom.mjGEOM_BOX, (r, r, r), r),
        "cylinder": (mujoco.mjtGeom.mjGEOM_CYLINDER, (r, 1.2 * r, 0.0), 1.2 * r),
        "sphere": (mujoco.mjtGeom.mjGEOM_SPHERE, (r, 0.0, 0.0), r),
        "egg": (mujoco.mjtGeom.mjGEOM_ELLIPSOID, (r, EGG_ASPECT * r, r), r),
    }
    assert EGG_ASPECT == 57.0 / 43.0 and scene.EGG_ASPECT is EGG_ASPECT
    for name, (geom_type, size, rest) in expected.items():
        built = object_shape(ObjectConfig(shape=name, size_m=size_m))
        assert (built.geom_type, built.size, built.rest_height_m) == (geom_type, size, rest), name  # bit for bit
        assert get_shape(name).description


@pytest.mark.parametrize("name", BUILT_IN)
def test_every_registered_shape_builds_its_geom_in_the_house_scene(name):
    config = scenarios.get("grasp", {"object.shape": name})
    registered = get_shape(name).geom(config.object.size_m)
    model = build_scene(config)
    geom = _object_geom(model)
    assert geom.type[0] == getattr(mujoco.mjtGeom, f"mjGEOM_{registered.geom_type.upper()}")
    np.testing.assert_allclose(geom.size, registered.size, rtol=0, atol=1e-12)
    np.testing.assert_allclose(model.body("object").pos, [0.0, 0.0, registered.rest_height_m], rtol=0, atol=1e-12)


def test_the_registry_covers_every_shape_the_config_accepts():
    assert set(shape_names()) == set(OBJECT_SHAPES)
    for name in shape_names():
        ObjectConfig(shape=name)  # accepted, and built above


def test_an_unknown_shape_is_refused_listing_the_registered_ones():
    with pytest.raises(ValueError, match=r"^object\.shape must be one of box, cylinder, sphere, egg; got 'cube'$"):
        ObjectConfig(shape="cube")
    with pytest.raises(ValueError, match=r"object\.shape must be one of box, cylinder, sphere, egg; got 'capsule'"):
        scenarios.get("grasp", {"object.shape": "capsule"})
    with pytest.raises(ValueError, match=r"unknown shape 'cube'; registered shapes: box, cylinder, sphere, egg"):
        get_shape("cube")


# -- a shape registered in one place ------------------------------------------------------------


def test_a_registered_capsule_is_accepted_and_builds_a_capsule_end_to_end(capsule):
    assert shape_names() == (*BUILT_IN, "capsule")
    config = scenarios.get("grasp", {"object.shape": "capsule", "object.size_m": 0.03}, preset="fast")
    r = 0.015
    built = object_shape(config.object)
    assert (built.geom_type, built.size, built.rest_height_m) == (mujoco.mjtGeom.mjGEOM_CAPSULE, (r, r, 0.0), 2 * r)
    sim = CoSimulation(config)
    geom = _object_geom(sim.model)
    assert geom.type[0] == mujoco.mjtGeom.mjGEOM_CAPSULE
    np.testing.assert_allclose(geom.size, [r, r, 0.0], rtol=0, atol=1e-12)
    result = sim.run(max_steps=60)
    assert result.error is None and result.steps == 60
    # The capsule stood on the table where its registration put it (no fall, no launch).
    z = sim.data.xpos[sim.model.body("object").id][2]
    assert z == pytest.approx(2 * r, abs=1e-3)


def test_a_temporary_shape_leaves_no_trace(capsule):
    unregister_shape("capsule")
    try:
        assert shape_names() == BUILT_IN
        with pytest.raises(ValueError, match=r"object\.shape must be one of box, cylinder, sphere, egg; got 'capsule'"):
            ObjectConfig(shape="capsule")
    finally:
        register_shape("capsule", geom_type="capsule", description="again, for the fixture to remove")(_capsule)


def test_a_gym_object_draw_takes_any_registered_shape(capsule):
    from piezotip.gym_learn import ObjectDraw

    ObjectDraw(shapes=("capsule", "egg")).validate(100.0, 9.81)
    with pytest.raises(ValueError, match=r"ObjectDraw\.shapes must be some of"):
        ObjectDraw(shapes=("cube",)).validate(100.0, 9.81)


# -- bad registrations ---------------------------------------------------------------------------


def _fine(size_m):
    return (0.5 * size_m, 0.5 * size_m, 0.5 * size_m), 0.5 * size_m


@pytest.mark.parametrize(
    ("name", "geom_type", "builder", "message"),
    [
        ("slab", "plane", _fine, r"shape 'slab': geom type must be one of sphere, capsule, ellipsoid, cylinder, box; got 'plane'"),
        ("blob", "mesh", _fine, r"shape 'blob': geom type must be one of .*; got 'mesh'"),
        ("cube", "cube", _fine, r"shape 'cube': geom type must be one of .*; got 'cube'"),
        ("box", "box", _fine, r"shape 'box' is registered already"),
        ("egg", "ellipsoid", _fine, r"shape 'egg' is registered already"),
        ("flat", "box", lambda s: ((s, s, 0.0), s), r"shape 'flat' \(box\) must have three finite half-sizes, the first 3 positive"),
        ("hollow", "sphere", lambda s: ((-s, 0.0, 0.0), s), r"shape 'hollow' \(sphere\) must have three finite half-sizes"),
        ("wild", "ellipsoid", lambda s: ((s, math.nan, s), s), r"shape 'wild' \(ellipsoid\) must have three finite half-sizes"),
        ("huge", "capsule", lambda s: ((s, math.inf, 0.0), s), r"shape 'huge' \(capsule\) must have three finite half-sizes"),
        ("pair", "cylinder", lambda s: ((s, s), s), r"shape 'pair' \(cylinder\) must have three finite half-sizes"),
        ("sunk", "box", lambda s: ((s, s, s), 0.0), r"shape 'sunk' must rest with its centre above the table"),
        ("lost", "box", lambda s: ((s, s, s), math.nan), r"shape 'lost' must rest with its centre above the table"),
        ("mute", "box", lambda s: None, r"shape 'mute''s builder must return \(three half-sizes, rest height\)"),
        ("two words", "box", _fine, r"a shape's name must be an identifier, got 'two words'"),
        ("", "box", _fine, r"a shape's name must be an identifier, got ''"),
    ],
)
def test_a_bad_registration_is_refused_by_name(name, geom_type, builder, message):
    before = dict(shapes._SHAPES)
    with pytest.raises(ValueError, match=message):
        register_shape(name, geom_type=geom_type, description="bad")(builder)
    assert shapes._SHAPES == before


def test_unregistering_an_unknown_shape_is_refused():
    with pytest.raises(ValueError, match=r"shape 'capsule' is not registered; registered shapes: box, cylinder, sphere, egg"):
        unregister_shape("capsule")


def test_the_registry_reaches_into_no_engine():
    """cosim/shapes.py (the registry's home; scenarios/shapes.py re-exports it) imports only the
    standard library: a config is checked without MuJoCo or the rest of cosim/ (cosim/config.py
    imports it, not the other way round)."""
    from piezotip.cosim import shapes as home

    assert shapes._SHAPES is home._SHAPES and shapes.register_shape is home.register_shape
    tree = ast.parse(open(home.__file__, encoding="utf-8").read())
    imported = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            imported |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom):
            assert node.level == 0, "no relative imports"
            imported.add(node.module)
    assert imported <= {"__future__", "math", "collections.abc", "dataclasses"}, imported
