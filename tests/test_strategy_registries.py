"""The sensor's dynamics and gel layers are objects in one registry each (issue 45, item 4)."""

from __future__ import annotations

import copy
import pickle

import pytest

from piezotip.sensor import Fingertip
from piezotip.sensor.channel import SensorChannel
from piezotip.sensor.gel import GEL_LAYERS, LAYERS, GelLayer, GelModel, gel_layer
from piezotip.sensor.resonator import DYNAMICS, Dynamics


def test_the_registries_are_keyed_by_the_names_they_hold():
    assert list(DYNAMICS) == ["steady", "envelope", "carrier"]
    assert all(isinstance(d, Dynamics) and d.name == name for name, d in DYNAMICS.items())
    assert LAYERS == tuple(GEL_LAYERS) == ("winkler", "dynamic")
    assert all(isinstance(law, GelLayer) and law.name == name for name, law in GEL_LAYERS.items())


@pytest.mark.parametrize("obj", [*DYNAMICS.values(), *GEL_LAYERS.values()], ids=repr)
def test_a_pickled_or_copied_strategy_is_the_registered_one(obj):
    assert pickle.loads(pickle.dumps(obj)) is obj
    assert copy.deepcopy(obj) is obj


def test_unknown_names_are_named_with_the_valid_ones():
    with pytest.raises(ValueError, match="valid: steady, envelope, carrier"):
        SensorChannel(Fingertip(), dynamics="bogus")
    with pytest.raises(ValueError, match="valid: winkler, dynamic"):
        GelModel(layer="bogus")
    with pytest.raises(ValueError, match="valid: winkler, dynamic"):
        gel_layer("bogus")


@pytest.mark.parametrize("name", list(DYNAMICS))
def test_a_channel_keeps_the_name_and_takes_the_fast_path_its_dynamics_allow(name):
    ch = SensorChannel(Fingertip(), dynamics=name, noise=False)
    assert ch.dynamics == name and ch._resonator is DYNAMICS[name]
    assert bool(ch._samplers) == DYNAMICS[name].sampled
    assert (ch._carrier is not None) == (name == "carrier")
    ch.select_mode(2)
    reading = ch.update([500.0], 0.005)
    assert reading.settled == DYNAMICS[name].steady_reading  # a ring-up has not settled after one sample


@pytest.mark.parametrize("layer", LAYERS)
def test_a_gel_model_keeps_its_layer_name_and_its_law(layer):
    gel = GelModel(layer=layer)
    assert gel.layer == layer and gel.law is GEL_LAYERS[layer]
    assert gel.law.signed_stiffness == (layer == "dynamic")
