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


class _Through:
    """A sampler's or an inverse's calls through Python (not the core's C path): the records
    their own methods make (ModeSampler.sample, ModeInverse.inferred)."""

    def __init__(self, inner) -> None:
        self.inner = inner

    def __getattr__(self, name):
        return getattr(self.inner, name)

    def __call__(self, *args):
        return self.inner(*args)


@pytest.mark.parametrize("dynamics", ["envelope", "steady"])
@pytest.mark.parametrize("noise", [True, False])
def test_advance_gives_sample_s_reading_and_estimate_as_values_and_their_records_when_asked(dynamics, noise):
    """The readout pass's path (ChannelCore.advance: values, the records made only when asked)
    against the records the sampler's and the inverse's own methods make (a twin channel whose
    samplers and inverses are called through Python), through load steps, saturation and a
    mode switch."""
    from piezotip.sensor._estimator import STATUSES

    eager, lazy = (SensorChannel(Fingertip(), dynamics=dynamics, noise=noise, rng=np.random.default_rng(5)) for _ in range(2))
    for table in (eager._core._samplers, eager._core._inverse):
        for mode in table:
            table[mode] = _Through(table[mode])
    seen = set()
    for k in range(600):
        if k == 400:
            eager.select_mode(3)
            lazy.select_mode(3)
        p = (0.0, 1500.0, 2.0e5, 40.0)[(k // 100) % 4]
        reading, estimate = eager._core.sample([p], 0.005)
        mode, pressure, sigma, status = lazy._core.advance([p], 0.005)
        assert _bits((mode, pressure, sigma, STATUSES[status])) == _bits(
            (reading.mode, estimate.pressure_pa, estimate.uncertainty_pa, estimate.status)
        )
        assert _bits(lazy._core.last_reading()) == _bits(reading), k
        assert _bits(lazy._core.last_estimate()) == _bits(estimate), k
        assert _bits(lazy._core._last_estimate) == _bits(eager._core._last_estimate), k
        seen.add(estimate.status)
    assert seen >= ({"ok", "below_detection", "settling"} if dynamics == "envelope" else {"ok", "below_detection", "saturated"})


def test_one_pressure_reads_as_a_list_of_one_cell():
    """A touch pad's path (ChannelCore.advance_one: one pressure, no list) against a list of one
    cell, on twin channels through load steps and a mode switch: the same bits."""
    one, listed = (SensorChannel(Fingertip(), rng=np.random.default_rng(11)) for _ in range(2))
    for k in range(500):
        if k == 300:
            one.select_mode(2)
            listed.select_mode(2)
        p = (0.0, 900.0, 3.0e4, 15.0)[(k // 75) % 4]
        assert _bits(one._core.advance_one(p, 0.005)) == _bits(listed._core.advance([p], 0.005)), k
        assert _bits(one._core.last_reading()) == _bits(listed._core.last_reading()), k


def test_the_noise_drawn_ahead_is_state_a_copy_takes():
    """The lock-in's noise drawn ahead (a block of the generator's draws) reads and writes as the
    list of what is left, the next one last; a core given that list goes on with the same draws."""
    ch = SensorChannel(Fingertip(), rng=np.random.default_rng(7))
    _run(ch, 3)
    left = ch._noise
    assert len(left) == 2048 - 3 and all(isinstance(z, complex) for z in left)
    twin = SensorChannel(Fingertip(), rng=np.random.default_rng(99))
    twin._noise = left
    assert [twin._core.iq_noise() for _ in range(5)] == [ch._core.iq_noise() for _ in range(5)]


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
