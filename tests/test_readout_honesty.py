"""The readout is honest: where it says "ok", the true pressure lies in estimate +- 3 uncertainty.

The contract of :meth:`sensor.channel.SensorChannel.estimate` (module docstring there), measured
at channel level on synthetic pressure traces:

* coverage: of the "ok" samples, the share whose true pressure (the one held over the sample's
  period) lies within estimate +- 3 uncertainty_pa, and the count of gross misses (> 10
  uncertainties), for each dynamics and for Table I's damping and Q = 70;
* after the load is removed the estimate reads "below_detection" within the inference's
  settling time, and on the way it is never "ok" with the true pressure (0) outside its interval;
* a held load reads "ok" within a bounded time and stays "ok".

A slow resonator cannot show a load change at once: with Table I's damping (tau0 = 0.66 s) a
step or the start of a ramp moves the envelope by a fraction of the readout noise per reading
for several readings.  No readout can be honest about those readings, so the coverage is also
stated beyond the physical detection horizon: the readings after a change (a kink of the
pressure trace) until they carry HORIZON_SNR sigma of evidence of it, computed by an oracle
that knows the change and compares the noise-free envelope with the one the old trend would
have given.  The thresholds below are the measured values with some margin.
"""

from __future__ import annotations

import copy
import functools
import math

import numpy as np
import pytest

import piezotip.sensor.channel as sensor_channel
from piezotip.sensor import ElementParams, Fingertip, GelModel, SensorElement
from piezotip.sensor.channel import SensorChannel
from piezotip.sensor.compiled import source_module
from piezotip.sensor.inference import SteadyInference
from piezotip.sensor.resonator import _steady

DT = 0.005
#: The oracle's detection horizon: a change counts as visible once the noise-free readings since
#: it differ from the old trend's by this many sigma (root sum of squares).
HORIZON_SNR = 5.0
#: The repro's load, Pa (mode 2, Table I's damping).
REPRO_PA = 1400.0


@functools.cache
def fingertip(quality_factor: float | None) -> Fingertip:
    """The grasp scenarios' fingertip (cosim.loop.make_fingertip with the default sensor config)."""
    element = SensorElement(ElementParams())
    if quality_factor is not None:
        element = element.with_quality_factor(quality_factor)
    gel = GelModel(frequency_dependent=True, reference_freq_hz=element.natural_frequency_hz(1), layer="winkler")
    return Fingertip(element=element, gel=gel, coverage=(6.5e-3, 7.5e-3), modes=(1, 2, 3, 4))


def level(tip: Fingertip, mode: int, fraction: float) -> float:
    """A pressure inside ``mode``'s range: ``fraction`` of the way from 3 P_min to P_max / 2 in log."""
    lo, hi = 3.0 * tip.detection_limit(mode), 0.5 * tip.upper_limit(mode)
    return float(math.exp(math.log(lo) + fraction * math.log(hi / lo)))


def trace(tip: Fingertip, mode: int) -> tuple[list[float], list[int]]:
    """Pressures per step and the kinks (steps where the pressure's slope changes).

    Holds, steps up and down (to exactly 0 too), linear ramps at a 100 N/s grip rate over a
    4 cm^2 pad (2.5e5 Pa/s) and 100 times slower, and a geometric ramp across the range.
    """
    out: list[float] = []
    kinks: list[int] = []

    def hold(p: float, seconds: float) -> None:
        if out and p != out[-1]:
            kinks.append(len(out))
        out.extend([p] * round(seconds / DT))

    def ramp(p1: float, rate_pa_s: float | None = None, seconds: float | None = None, geometric: bool = False) -> None:
        p0 = out[-1]
        n = max(1, min(round(1.5 / DT), round((seconds if seconds else abs(p1 - p0) / rate_pa_s) / DT)))
        kinks.append(len(out))
        steps = np.geomspace(p0, p1, n + 1)[1:] if geometric else np.linspace(p0, p1, n + 1)[1:]
        out.extend(steps.tolist())
        kinks.append(len(out))

    lo, mid, hi = level(tip, mode, 0.15), level(tip, mode, 0.5), level(tip, mode, 0.9)
    hold(0.0, 0.5)
    hold(mid, 1.0)  # a step up from unloaded
    ramp(hi, rate_pa_s=2.5e5)  # the grip's ramp
    hold(hi, 0.8)
    ramp(mid, rate_pa_s=2.5e3)  # a slow ramp down
    hold(mid, 0.6)
    hold(0.0, 0.8)  # the load removed
    hold(lo, 0.6)  # a light touch
    ramp(hi, seconds=1.0, geometric=True)  # a geometric ramp across the range
    hold(hi, 0.6)
    hold(lo, 0.8)  # a step down
    hold(0.0, 0.6)
    return out, kinks


def run(tip: Fingertip, dynamics: str, mode: int, pressures: list[float], kinks: list[int], seed: int):
    """Feed ``pressures`` to a channel (started in another mode: a ring-up first); per step
    (true pressure, estimate) and whether the step lies within the detection horizon of a kink."""
    ch = SensorChannel(tip, dynamics=dynamics, mode=1 if mode != 1 else 2, rng=np.random.default_rng(seed))
    twin = SensorChannel(tip, dynamics=dynamics, mode=ch.mode, noise=False)
    ch.select_mode(mode)
    twin.select_mode(mode)
    sigma = ch.inverse(mode).sigma
    pending: dict[int, list] = {}  # step -> [(kink, counterfactual envelope)]
    evidence: dict[int, float] = {}
    within = np.zeros(len(pressures), bool)
    rows = []
    kink_set = set(kinks)
    for k, p in enumerate(pressures):
        if k in kink_set and k >= 2:
            # The oracle: the old trend continued, on a noise-free copy of the channel.
            cf = copy.deepcopy(twin)
            slope = pressures[k - 1] - pressures[k - 2]
            for j in range(k, min(len(pressures), k + 200)):
                pending.setdefault(j, []).append((k, cf.update_trusted([max(0.0, pressures[k - 1] + slope * (j - k + 1))], DT).iq))
        true = twin.update_trusted([p], DT).iq
        rows.append((p, ch.estimate(ch.update_trusted([p], DT))))
        for kink, a_cf in pending.pop(k, []):
            evidence[kink] = evidence.get(kink, 0.0) + abs(true - a_cf) ** 2 / sigma**2
            within[k] |= evidence[kink] < HORIZON_SNR**2
    return rows, within


def coverage(rows, within) -> dict:
    """Counts of "ok" samples, misses (> 3 uncertainties) and gross misses (> 10), overall and
    beyond the detection horizon."""
    out = dict(ok=0, miss=0, gross=0, ok_beyond=0, miss_beyond=0, gross_beyond=0, settling=0, n=len(rows))
    for (p, e), w in zip(rows, within, strict=True):
        out["settling"] += e.status == "settling"
        if e.status != "ok":
            continue
        z = abs(e.pressure_pa - p) / e.uncertainty_pa
        out["ok"] += 1
        out["miss"] += z > 3.0
        out["gross"] += z > 10.0
        if not w:
            out["ok_beyond"] += 1
            out["miss_beyond"] += z > 3.0
            out["gross_beyond"] += z > 10.0
    return out


# Thresholds; measured on these traces (all four modes, seed = mode) in the comments.
# Steady dynamics (the reading is the steady one; the plain inverse, sigma / |dV/dP|): 3 sigma of
# a Gaussian is 99.73 %; the magnitude-only inverse linearized in P has slightly heavier tails
# (measured 99.6 % with Table I's damping, 99.7 % with Q = 70, no gross miss): >= 99.5 %.
# Q = 70 (envelope, carrier): the readings follow the load within a reading or two, so the
# target holds everywhere: >= 99.7 % covered (measured 99.97-99.98 %), no gross miss.
# Table I's damping (envelope, carrier): overall, the horizon's readings included, >= 97 %
# (measured 97.9-98.0 %; 19-20 gross misses, in the first readings after a change); beyond the
# detection horizon >= 99 % (measured 99.6 %) and at most 3 gross misses (measured 2: the
# readout's change test needs a reading or two more than the oracle).
CASES = [
    ("steady", None, 0.995, 0.995, 0, 0),
    ("steady", 70.0, 0.995, 0.995, 0, 0),
    ("envelope", None, 0.97, 0.99, None, 3),
    ("envelope", 70.0, 0.997, 0.997, 0, 0),
    ("carrier", None, 0.97, 0.99, None, 3),
    ("carrier", 70.0, 0.997, 0.997, 0, 0),
]


@pytest.mark.parametrize(("dynamics", "quality_factor", "min_cov", "min_cov_beyond", "max_gross", "max_gross_beyond"), CASES)
def test_ok_intervals_cover_the_true_pressure(dynamics, quality_factor, min_cov, min_cov_beyond, max_gross, max_gross_beyond):
    tip = fingertip(quality_factor)
    total = None
    for mode in tip.modes:
        pressures, kinks = trace(tip, mode)
        c = coverage(*run(tip, dynamics, mode, pressures, kinks, seed=mode))
        total = c if total is None else {key: total[key] + c[key] for key in c}
    assert total["ok"] > 0.4 * total["n"], total  # not "settling" everywhere
    cov = 1.0 - total["miss"] / total["ok"]
    cov_beyond = 1.0 - total["miss_beyond"] / total["ok_beyond"]
    assert cov >= min_cov, (cov, total)
    assert cov_beyond >= min_cov_beyond, (cov_beyond, total)
    if max_gross is not None:
        assert total["gross"] <= max_gross, total
    assert total["gross_beyond"] <= max_gross_beyond, total


def repro(quality_factor: float | None, mode: int, load_pa: float, seed: int, hold_steps: int = 400):
    """The bug report's scenario: a switch, a held load, then the load removed.  Returns the
    estimates after the removal and the number of readings within its detection horizon (the
    oracle, as in :func:`run`)."""
    tip = fingertip(quality_factor)
    ch = SensorChannel(tip, mode=1 if mode != 1 else 2, rng=np.random.default_rng(seed))
    twin = SensorChannel(tip, mode=ch.mode, noise=False)
    ch.select_mode(mode)
    twin.select_mode(mode)
    for _ in range(hold_steps):
        ch.estimate(ch.update([load_pa], DT))
        twin.update([load_pa], DT)
    held = copy.deepcopy(twin)
    evidence, horizon = 0.0, 0
    for _ in range(200):
        evidence += abs(twin.update([0.0], DT).iq - held.update([load_pa], DT).iq) ** 2 / ch.inverse(mode).sigma ** 2
        horizon += evidence < HORIZON_SNR**2
    return [ch.estimate(ch.update([0.0], DT)) for _ in range(200)], horizon


#: After the load is removed, "below_detection" within this time, s (the inference's settling
#: time, SteadyInference: measured 0.17-0.37 s with Table I's damping, 20 ms with Q = 70).
UNLOAD_SETTLING_S = {None: 0.45, 70.0: 0.05}


def test_the_bug_report_reads_below_detection_after_the_load_is_removed():
    """Table I's damping, mode 2, 1400 Pa removed: the old readout said "ok", 1388 -> 488 Pa
    +- 3-4 Pa for a second; now it is "settling" and then "below_detection"."""
    after, _ = repro(None, 2, REPRO_PA, seed=1)
    first = next(k for k, e in enumerate(after) if e.status == "below_detection")
    assert (first + 1) * DT <= UNLOAD_SETTLING_S[None]
    for e in after:
        assert not (e.status == "ok" and abs(e.pressure_pa) > 3.0 * e.uncertainty_pa), e
    # Once below detection, it does not claim a load again.
    assert all(e.status != "ok" or e.pressure_pa <= 3.0 * e.uncertainty_pa for e in after[first:])


@pytest.mark.parametrize("quality_factor", [None, 70.0])
@pytest.mark.parametrize("mode", [1, 2, 3, 4])
def test_unload_reads_below_detection_within_the_settling_time(quality_factor, mode):
    tip = fingertip(quality_factor)
    for fraction in (0.3, 0.9):
        after, horizon = repro(quality_factor, mode, level(tip, mode, fraction), seed=mode, hold_steps=300)
        first = next((k for k, e in enumerate(after) if e.status == "below_detection"), None)
        assert first is not None and (first + 1) * DT <= UNLOAD_SETTLING_S[quality_factor], (fraction, first)
        # The first readings after the removal can be indistinguishable from noise (the physical
        # detection horizon, 1 to 4 readings here; the readout's change test may need one more);
        # after them, never "ok" on the old load.
        wrong = [k for k, e in enumerate(after) if e.status == "ok" and abs(e.pressure_pa) > 3.0 * e.uncertainty_pa]
        assert all(k <= horizon for k in wrong), (fraction, wrong, horizon)


#: A held load reads "ok" within this time after a step from unloaded, s (measured up to 0.31 s
#: with Table I's damping, near unloaded where the envelope is slowest; 25 ms with Q = 70) ...
OK_WITHIN_S = {None: 0.4, 70.0: 0.05}
#: ... and is "ok" at least this share of the time from 1 s after the step on (measured 0.99).
HELD_OK_SHARE = 0.97


@pytest.mark.parametrize("quality_factor", [None, 70.0])
def test_held_load_reads_ok_within_bounded_time(quality_factor):
    tip = fingertip(quality_factor)
    for mode in tip.modes:
        for fraction in (0.1, 0.5, 0.9):
            p = level(tip, mode, fraction)
            ch = SensorChannel(tip, mode=mode, rng=np.random.default_rng(mode))
            for _ in range(100):
                ch.estimate(ch.update([0.0], DT))
            estimates = [ch.estimate(ch.update([p], DT)) for _ in range(600)]
            first = next(k for k, e in enumerate(estimates) if e.status == "ok")
            assert (first + 1) * DT <= OK_WITHIN_S[quality_factor], (mode, p, first)
            held = estimates[200:]
            assert sum(e.status == "ok" for e in held) >= HELD_OK_SHARE * len(held), (mode, p)
            assert all(abs(e.pressure_pa - p) <= 3.0 * e.uncertainty_pa for e in held if e.status == "ok"), (mode, p)


@pytest.mark.parametrize("quality_factor", [None, 70.0])
def test_inferred_steady_reading_scatters_as_its_stated_gain(quality_factor):
    """The inference's own uncertainty (before GAIN_FLOOR) is not overstated nor understated:
    the inferred |a_ss| scatters by 0.6 to 1.2 of gain x sigma on held loads."""
    tip = fingertip(quality_factor)
    z = []
    for mode, fraction in ((1, 0.1), (2, 0.5), (4, 0.9)):
        p = level(tip, mode, fraction)
        ch = SensorChannel(tip, mode=mode, rng=np.random.default_rng(mode))
        inference = SteadyInference(ch._tau0, ch.inverse(mode).sigma)
        for _ in range(400):
            ch.update([p], DT)
        inference.seed(ch.update([p], DT).iq, ch._clock_s, DT)  # started on the held reading
        for _ in range(1500):
            r = ch.update([p], DT)
            a_ss, gain, _trusted = inference.step(ch._clock_s, r.iq)
            true = _steady(ch._fast[mode][0], ch._c_f, r.kappa, r.gamma)
            if math.isfinite(gain):
                z.append((abs(a_ss) - abs(true)) / (gain * ch.inverse(mode).sigma))
    assert 0.6 <= float(np.std(z)) <= 1.2


def test_a_sliding_latch_would_fail_the_contract(monkeypatch):
    """The test above can fail: with the change test off (the window slides over a change like
    the old latch did) the bug report's estimate stays "ok" on the removed load.  (On the
    inference's source run as Python, whose constants are its module's globals: compiled, they
    are C constants, read once, when it is imported.)"""
    kernel = source_module("piezotip.sensor._inference")  # the inference's source run as Python
    monkeypatch.setattr(sensor_channel, "SteadyInference", kernel.SteadyInference)
    monkeypatch.setattr(kernel, "CHANGE_STAT", math.inf)
    monkeypatch.setattr(kernel, "SUSPECT_STAT", math.inf)
    monkeypatch.setattr(kernel, "_SUSPECT_STAT_LONGEST", math.inf)
    after, _ = repro(None, 2, REPRO_PA, seed=1)
    assert any(e.status == "ok" and abs(e.pressure_pa) > 10.0 * e.uncertainty_pa for e in after)
