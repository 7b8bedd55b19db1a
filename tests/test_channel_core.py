"""A channel's per-reading state has one owner, its ChannelCore (sensor/_channel.py), and its copies go on as it does."""

from __future__ import annotations

import copy
import math
import pickle
import struct

import numpy as np
import pytest

from piezotip.sensor import Fingertip
from piezotip.sensor import channel as sensor_channel
from piezotip.sensor.channel import SensorChannel

STATE = (
    "mode",
    "evaluations",
    "envelope",
    "time_in_mode_s",
    "_noise",
    "_clock_s",
    "_dt_s",
    "_inference",
    "_inference_mode",
    "_estimated_at",
    "_last_estimate",
    "_seed_a",
    "_low_since_s",
)


def _bits(value) -> object:
    """``value`` with its floats as their bits (NaN equals NaN, -0.0 differs from 0.0)."""
    if isinstance(value, float):
        return struct.pack("<d", value)
    if isinstance(value, complex):
        return struct.pack("<dd", value.real, value.imag)
    if isinstance(value, tuple):
        return tuple(_bits(v) for v in value)
    if hasattr(value, "__dataclass_fields__"):
        return (type(value).__name__, *(_bits(getattr(value, f)) for f in value.__dataclass_fields__))
    return value


def _run(ch: SensorChannel, n: int, start: int = 0) -> list:
    out = []
    for k in range(start, start + n):
        p = 0.0 if (k // 100) % 2 == 0 else 2000.0 + 10.0 * k
        reading = ch.update_trusted([p], 0.005)
        out.append(_bits((reading, ch.estimate(reading), ch.envelope, ch._clock_s, ch._low_since_s)))
    return out


@pytest.mark.parametrize("dynamics", ["envelope", "steady", "carrier"])
def test_the_state_is_the_core_s_read_and_written_through_the_channel(dynamics):
    ch = SensorChannel(Fingertip(), dynamics=dynamics, rng=np.random.default_rng(1))
    _run(ch, 20)
    assert "envelope" not in vars(ch) and "mode" not in vars(ch)
    for name in STATE:
        assert _bits(getattr(ch, name)) == _bits(getattr(ch._core, name)) or getattr(ch, name) is getattr(ch._core, name)
    ch.envelope, ch._seed_a, ch.time_in_mode_s = 0.5 - 0.25j, 0.9 + 0j, 1.5
    assert (ch._core.envelope, ch._core._seed_a, ch._core.time_in_mode_s) == (0.5 - 0.25j, 0.9 + 0j, 1.5)
    ch.select_mode(2)
    assert (ch._core.mode, ch._core._clock_s, ch._core._inference_mode, ch._core._low_since_s) == (2, 0.0, 2, None)
    assert math.isnan(ch._core._estimated_at) and ch._core._inference is ch._inference


def test_copies_of_a_channel_go_on_as_it_does():
    ch = SensorChannel(Fingertip(), rng=np.random.default_rng(3))
    _run(ch, 250)
    twins = [copy.deepcopy(ch), pickle.loads(pickle.dumps(ch))]
    for twin in twins:
        assert twin._core is not ch._core and twin.update_trusted.__self__ is twin._core
    expected = _run(ch, 300, 250)
    assert all(_run(twin, 300, 250) == expected for twin in twins)


def test_the_first_inference_is_of_the_class_the_channel_names(monkeypatch):
    made, original = [], sensor_channel.SteadyInference

    def counted(tau0, sigma):
        made.append((tau0, sigma))
        return original(tau0, sigma)

    monkeypatch.setattr(sensor_channel, "SteadyInference", counted)
    ch = SensorChannel(Fingertip(), rng=np.random.default_rng(3))
    _run(ch, 3)
    assert made == [(ch._tau0, ch._sigma[ch.mode])]
