"""A pad that carries no load reuses the unloaded resonator's response, and reads as if it did not.

With no modal load (kappa = gamma = 0: every coverage cell at 0 Pa) a sample's steady envelope,
envelope rate, time constant and step decay are the unloaded resonator's, computed once per
sampler (:mod:`sensor.sampler`, :data:`sensor.sampler.SKIP_UNLOADED`).  Checked here:

* whole runs record the same bits with the reuse and without it (the default grasp, the fast
  preset's steady sensor, a multi-cell coverage; the compiled sampler and its source run as Python);
* the reuse happens on exactly the pad-steps whose recorded coverage pressure is 0 Pa;
* a pad loaded after a long unloaded stretch (and after a ring-up from rest while unloaded)
  reads and estimates exactly as without the reuse; so does a zero of either sign.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from piezotip import scenarios
from piezotip.cosim.loop import CoSimulation
from piezotip.sensor import Fingertip, SensorElement, sampler
from piezotip.sensor.channel import SensorChannel
from piezotip.sensor.estimator import foundation_table

#: The sampler classes checked: its source run as Python, and the compiled kernel where it is built.
SAMPLERS = [sampler.PyModeSampler] + ([sampler.ModeSampler] if sampler.SAMPLER_COMPILED else [])


class _Rows:
    """A recorder that keeps the rows (the co-simulation's Recorder interface, in memory)."""

    def __init__(self) -> None:
        self.rows: list[list[float]] = []
        self.columns: list[str] = []

    def append_values(self, values, columns=None, owned: bool = False) -> None:
        self.rows.append(list(values))
        self.columns = list(columns)

    def close(self) -> list:
        return []


def _run(case: tuple[str | None, list[str]], skip: bool, sampler_class, monkeypatch) -> tuple[np.ndarray, list[str], CoSimulation]:
    """A whole run of the grasp at ``case`` = (preset, overrides), the reuse on or off, through
    ``sampler_class``: (the record as an array of bits, its columns, the simulation)."""
    monkeypatch.setattr(sampler, "SKIP_UNLOADED", skip)
    monkeypatch.setattr("piezotip.sensor.channel.ModeSampler", sampler_class)
    preset, overrides = case
    sim = CoSimulation(scenarios.get("grasp", overrides, preset=preset))
    assert all(type(s) is sampler_class for ch in sim.channels.values() for s in ch._samplers.values())
    rows = _Rows()
    result = sim.run(rows)
    assert result.error is None
    return np.asarray(rows.rows, dtype=float).view(np.uint64), rows.columns, sim


def _unloaded_pad_steps(record: np.ndarray, columns: list[str], pads) -> int:
    """Pad-steps whose recorded coverage pressure is exactly 0 Pa (every cell's: the cells'
    weights are positive)."""
    zero = np.float64(0.0).view(np.uint64)
    return sum(int(np.count_nonzero(record[:, columns.index(f"{p.removesuffix('_pad')}_coverage_pressure_pa")] == zero)) for p in pads)


DEFAULT = (None, [])
#: The default grasp (envelope dynamics, one coverage cell), the fast preset (steady dynamics),
#: and three coverage cells over five pad strips.
CASES = {"default": DEFAULT, "fast": ("fast", []), "cells": (None, ["physics.pad_segments=5", "sensor.coverage_mm=[4.0,7.5]"])}


@pytest.mark.parametrize("sampler_class", SAMPLERS)
@pytest.mark.parametrize("case", CASES.values(), ids=CASES.keys())
def test_a_run_records_the_same_bits_with_and_without_the_reuse(case, sampler_class, monkeypatch):
    with_reuse, columns, sim = _run(case, True, sampler_class, monkeypatch)
    without, columns_off, sim_off = _run(case, False, sampler_class, monkeypatch)
    assert columns == columns_off
    assert with_reuse.shape == without.shape
    differ = [c for k, c in enumerate(columns) if not np.array_equal(with_reuse[:, k], without[:, k])]
    assert not differ, f"columns that differ: {differ}"
    # The reuse happened exactly on the unloaded pad-steps, and never with it off.
    reused = sum(ch.unloaded_samples for ch in sim.channels.values())
    assert reused == _unloaded_pad_steps(with_reuse, columns, sim.pads) > 0
    assert sum(ch.unloaded_samples for ch in sim_off.channels.values()) == 0
    if case is CASES["cells"]:
        assert all(ch.n_cells == 3 for ch in sim.channels.values())


def test_the_default_grasp_reuses_the_response_on_its_unloaded_pad_steps(monkeypatch):
    """The share of the default grasp's pad-steps without load (its approach, the moves with the
    pads open, the tail after the release): measured 836 of 3516 (24 %; 1156 of 2792 before the
    gentle touch's slow approach, whose pads carry the gel's micropascals as the fingers slow:
    rho h0 a, a load however small, and are computed)."""
    record, columns, sim = _run(DEFAULT, True, sampler.ModeSampler, monkeypatch)
    reused = sum(ch.unloaded_samples for ch in sim.channels.values())
    pad_steps = record.shape[0] * len(sim.pads)
    assert reused == _unloaded_pad_steps(record, columns, sim.pads)
    assert reused / pad_steps > 0.2


def _channel(sampler_class, skip: bool, monkeypatch, **options) -> SensorChannel:
    monkeypatch.setattr(sampler, "SKIP_UNLOADED", skip)
    monkeypatch.setattr("piezotip.sensor.channel.ModeSampler", sampler_class)
    tip = Fingertip(element=SensorElement(), coverage=(6.5e-3, 7.5e-3))
    return SensorChannel(tip, dynamics="envelope", mode=2, rng=np.random.default_rng(11), **options)


def _exact(reading, estimate, envelope) -> str:
    return repr((dataclasses.astuple(reading), dataclasses.astuple(estimate), envelope))


@pytest.mark.parametrize("sampler_class", SAMPLERS)
def test_a_pad_loaded_after_a_long_unloaded_stretch_reads_as_without_the_reuse(sampler_class, monkeypatch):
    """20 s unloaded (a mode switch in it: a ring-up from rest with no load), then a press, a
    release, a press again: every reading, estimate and envelope the same, bit for bit."""
    loads = [0.0] * 2000 + [0.0] * 2000 + [800.0] * 300 + [0.0] * 600 + [150.0] * 200 + [0.0] * 100
    runs, counts = [], []
    for skip in (True, False):
        ch = _channel(sampler_class, skip, monkeypatch)
        out = []
        for k, p in enumerate(loads):
            if k == 2000:
                ch.select_mode(1)  # the envelope rings up from 0 under no load
            r = ch.update_trusted([p], 0.005)
            out.append(_exact(r, ch.estimate(r), ch.envelope))
        runs.append(out)
        counts.append(ch.unloaded_samples)
    assert runs[0] == runs[1]
    assert counts == [loads.count(0.0), 0]


@pytest.mark.parametrize("sampler_class", SAMPLERS)
@pytest.mark.parametrize("envelope", [True, False])
def test_a_zero_of_either_sign_and_an_underflowing_load_read_as_without_the_reuse(sampler_class, envelope):
    """-0 Pa gives kappa = gamma = -0.0 (the reading records that sign) and reuses the unloaded
    response as +0 Pa does, reading as computed; the least pressure (5e-324 Pa) is a load (its
    kappa does not underflow) and is computed; the sample periods alternate (the reused decay
    is recomputed for each)."""
    tip = Fingertip(element=SensorElement(), coverage=(6.5e-3, 7.5e-3))
    ch = SensorChannel(tip, dynamics="envelope", noise=False)
    omega, sigma, _, weights = ch._fast[1]
    args = (1, omega, sigma, ch._c_f, ch._rho_a_f, foundation_table(tip, 1), weights, envelope)
    reusing, computing = sampler_class(*args, skip_unloaded=True), sampler_class(*args, skip_unloaded=False)
    a_reuse = a_compute = 0.3 - 0.2j
    t = 0.0
    for k, p in enumerate([-0.0, 5e-324, 0.0, 400.0, -0.0, 0.0, 5e-324, 0.0]):
        dt = (0.005, 0.001)[k % 2]
        t += dt
        noise = complex(0.1 * k, -0.05)
        r_reuse, a_reuse = reusing.sample([p], a_reuse, dt, t, noise)
        r_compute, a_compute = computing.sample([p], a_compute, dt, t, noise)
        assert repr((dataclasses.astuple(r_reuse), a_reuse)) == repr((dataclasses.astuple(r_compute), a_compute)), f"sample {k} at {p!r} Pa"
    assert reusing.unloaded_samples == 5 and computing.unloaded_samples == 0
    assert repr(r_reuse.kappa) == "0.0"
    first, _ = sampler_class(*args, skip_unloaded=True).sample([-0.0], 1 + 0j, 0.005, 1.0, None)
    assert repr(first.kappa) == "-0.0"


def test_the_comparison_sees_a_wrong_unloaded_response():
    """The comparisons above can fail: a sampler (run as Python) whose stored unloaded time
    constant is one ulp off reads differently from one that computes it."""
    tip = Fingertip(element=SensorElement(), coverage=(6.5e-3, 7.5e-3))
    ch = SensorChannel(tip, dynamics="envelope", noise=False)
    omega, sigma, _, weights = ch._fast[1]
    args = (1, omega, sigma, ch._c_f, ch._rho_a_f, foundation_table(tip, 1), weights, True)
    wrong, right = sampler.PyModeSampler(*args, skip_unloaded=True), sampler.PyModeSampler(*args, skip_unloaded=False)
    wrong._u_tau = math.nextafter(wrong._u_tau, 0.0)
    r_wrong, a_wrong = wrong.sample([0.0], 0.5 + 0j, 0.005, 1.0, None)
    r_right, a_right = right.sample([0.0], 0.5 + 0j, 0.005, 1.0, None)
    assert wrong.unloaded_samples == 1
    assert repr((dataclasses.astuple(r_wrong), a_wrong)) != repr((dataclasses.astuple(r_right), a_right))
