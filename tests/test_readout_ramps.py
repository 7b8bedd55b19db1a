"""A reading taken while the load changes under it is "settling", not "ok" (issue 29, item 5):
:data:`sensor.inference.RAMP_SUSPECT_CHI2`, in the reference and its compiled twin alike, and the
3-sigma coverage of "ok" readings over whole grasps, load changes included (reports/coverage.py).
A load that creeps (a ramp whose own span holds the window) is read, within its sigma."""

import math
import random

import numpy as np
import pytest

from piezotip.reports import coverage
from piezotip.sensor import inference
from piezotip.sensor.compiled import source_module

TAU0_S = 0.66  # Table I's unloaded envelope time constant, s
SIGMA = 1e-3  # one reading's noise, V_1 units
DT_S = 0.005


def ramp_load(t: float) -> complex:
    """A modal load mu(t) growing e-fold per second from 2 (a grip growing as steadily)."""
    return 1.0 + 2.0 * math.exp(t) - 0.5j


def trusted_readings(cls, mu_of_t, seconds: float, seed: int = 7) -> tuple[list[bool], list[float]]:
    """Feed ``cls`` the noisy envelope of tau0 a' = 1 - mu(t) a (physics.md section 6), started
    settled at mu(0): whether each reading is trusted, and each trusted one's error against the
    steady envelope of the load at its time, | |a_ss| - |1 / mu(t)| |, in its stated sigma
    (the reading's noise times its gain, at least GAIN_FLOOR, as the channel reports it)."""
    rng = random.Random(seed)
    inf = cls(TAU0_S, SIGMA)
    a = 1.0 / mu_of_t(0.0)
    inf.seed(a, 0.0, DT_S)
    n = round(seconds / DT_S)
    sub = 20  # the envelope integrated at 20 substeps a reading
    flags, errors = [], []
    for k in range(1, n + 1):
        for j in range(sub):
            t = (k - 1 + j / sub) * DT_S
            a += (1.0 - mu_of_t(t) * a) / TAU0_S * (DT_S / sub)
        a_ss, gain, ok = inf.step(k * DT_S, a + complex(rng.gauss(0.0, SIGMA), rng.gauss(0.0, SIGMA)))
        flags.append(bool(ok) and gain <= inference.MAX_GAIN)
        if flags[-1]:
            errors.append(abs(abs(a_ss) - abs(1.0 / mu_of_t(k * DT_S))) / (SIGMA * max(gain, inference.GAIN_FLOOR)))
    return flags, errors


def trusted_share(cls, mu_of_t, seconds: float, seed: int = 7) -> tuple[float, float]:
    """The share of :func:`trusted_readings` trusted over the last half (the first half lets a
    window fill), and the number of readings."""
    flags, _ = trusted_readings(cls, mu_of_t, seconds, seed)
    tail = flags[len(flags) // 2 :]
    return sum(tail) / len(tail), len(flags)


@pytest.mark.parametrize("cls", [inference.PySteadyInference, inference.SteadyInference])
def test_a_held_load_reads_trusted_and_a_ramping_one_settling(cls):
    held, _ = trusted_share(cls, lambda t: 3.0 - 1.0j, 2.0)
    ramp, _ = trusted_share(cls, ramp_load, 2.0)
    assert held >= 0.97  # the rule's false alarms: 0.25 % by design, the change test's 1 % besides
    assert ramp < 0.5  # 0.36: the rest are readings whose window is too short to show the ramp


@pytest.mark.parametrize("cls", [inference.PySteadyInference, inference.SteadyInference])
@pytest.mark.parametrize("rate_per_s", [0.1, -0.1, -0.3])
def test_a_creeping_load_reads_trusted_within_its_sigma(cls, rate_per_s):
    """A load that creeps, e-fold in 3 to 10 s (as MuJoCo's soft dry friction lets a friction
    drive's contact creep toward its drive's force), up or down: the window fits within the
    ramp's own span (RAMP_WINDOW_FRACTION), where the linear-in-time model holds, and the
    readings are trusted; read "settling" whenever the ramp was significant, 4-18 % of them
    were (robosuite's Panda held a box at the balanced preset with its fingertips blind in 195
    of 200 periods).  Every trusted one holds the truth within 3 sigma."""
    mu = (
        (lambda t: 1.0 + 2.0 * math.exp(rate_per_s * t) - 0.5j)
        if rate_per_s > 0
        else (lambda t: 1.0 + (20.0 - 5j) * math.exp(rate_per_s * t))
    )
    flags, errors = trusted_readings(cls, mu, 4.0)
    tail = flags[len(flags) // 4 :]
    assert sum(tail) / len(tail) >= (0.95 if abs(rate_per_s) < 0.2 else 0.6)
    assert max(errors) <= 3.0


def test_a_ramps_onset_reads_settling_until_the_window_lies_within_the_ramp():
    """A held load that starts to ramp at 1 s: the readings whose window still reaches back past
    the ramp's own span (the onset in it) are settling, then trusted; 97 % of the trusted
    readings hold the truth within 3 sigma, as many as before the rule (the fast-ramp readings
    trusted are those whose window is too short to show the ramp)."""
    flags, errors = trusted_readings(inference.SteadyInference, lambda t: 3.0 - 1j + (0.0 if t < 1.0 else 2.0 * (t - 1.0)), 3.0)
    onset = round(1.0 / DT_S)
    assert all(flags[onset - 40 : onset])  # held: trusted
    assert not all(flags[onset : onset + 40])  # the onset is read settling
    assert sum(flags[-100:]) / 100 > 0.5  # within the ramp: mostly trusted
    assert sum(e <= 3.0 for e in errors) / len(errors) >= 0.97


def test_the_rule_is_what_makes_a_ramping_reading_settling(monkeypatch):
    """Without RAMP_SUSPECT_CHI2 (set out of reach, in the inference's source run as Python:
    compiled, it is a C constant) the same ramp reads mostly trusted: the test above fails
    against the readout before the rule."""
    kernel = source_module("piezotip.sensor._inference")
    monkeypatch.setattr(kernel, "RAMP_SUSPECT_CHI2", math.inf)
    ramp, _ = trusted_share(kernel.SteadyInference, ramp_load, 2.0)
    assert ramp > 0.95


def _synthetic(n: int, ok_every: int, miss_at: tuple[int, ...], sigmas_off: float) -> dict[str, np.ndarray]:
    from piezotip.cosim.rows import STATUS_CODES

    truth = np.full(n, 100.0)
    est = truth.copy()
    est[list(miss_at)] += sigmas_off * 2.0
    status = np.where(np.arange(n) % ok_every == 0, STATUS_CODES.index("ok"), STATUS_CODES.index("settling"))
    data = {"time_s": np.arange(n) * DT_S, "phase": np.full(n, 4)}
    for side in ("left", "right"):
        data |= {
            f"{side}_status": status,
            f"{side}_estimate_pa": est,
            f"{side}_uncertainty_pa": np.full(n, 2.0),
            f"{side}_coverage_pressure_pa": truth,
            f"{side}_mode": np.ones(n),
        }
    return data


def test_estimate_coverage_counts_ok_readings_only_and_finds_the_worst_miss():
    data = _synthetic(100, ok_every=2, miss_at=(10, 11, 40), sigmas_off=12.0)  # 11 is not "ok"
    report = coverage.estimate_coverage({"run": data})
    assert report["readings"] == 200 and report["ok"] == 100
    assert report["misses"] == 4 and report["gross"] == 4  # readings 10 and 40, both sides
    assert report["share"] == pytest.approx(96 / 100)
    assert report["worst"]["sigmas"] == pytest.approx(12.0) and report["worst"]["time_s"] in (10 * DT_S, 40 * DT_S)
    assert report["by_phase"]["hold"]["ok"] == 100


@pytest.mark.slow
def test_hold_out_grasps_hold_the_truth_within_3_sigma_99_percent_of_ok_readings():
    """Sixteen objects no test names, at three presets and a soft PZT, twice each with their own
    readout noise: at least 99 % of the "ok" readings hold the coverage pressure within 3 sigma,
    load changes included (99.15 % before RAMP_SUSPECT_CHI2, 99.5 % with it)."""
    report = coverage.holdout_coverage(workers=2)
    assert report["ok"] > 20000
    assert report["share"] >= coverage.TARGET, coverage.format_report(report)
    assert "fault" not in report["outcomes"].values(), report["outcomes"]


def _first_flag_s(rate_n_s: float, area_m2: float, dt_s: float, noise: bool, seed: int = 0) -> float:
    """When the channel's own readout (envelope dynamics, mode 1, settled unloaded) first reports
    "settling" under a uniform force rising at ``rate_n_s`` (N/s) over ``area_m2`` from no load, s."""
    from piezotip.sensor import Fingertip
    from piezotip.sensor.channel import SensorChannel

    channel = SensorChannel(Fingertip(), dynamics="envelope", mode=1, noise=noise, rng=np.random.default_rng(seed))
    for _ in range(round(1.0 / dt_s)):
        channel.estimate(channel.update([0.0], dt_s))
    for k in range(1, round(0.5 / dt_s)):
        if channel.estimate(channel.update([rate_n_s * k * dt_s / area_m2], dt_s)).status == "settling":
            return k * dt_s
    return math.inf


@pytest.mark.parametrize("dt_s", [0.005, 0.002])
@pytest.mark.parametrize("rate_n_s", [0.1, 0.4, 1.6, 6.4])
def test_the_change_tests_latency_on_a_ramp_from_no_load(rate_n_s, dt_s):
    """A uniform force ramping from no load over the house's 20 x 20 mm pad: the channel's readout
    flags it "settling" noise-free within a reading before :func:`sensor.inference.change_detection_s`
    says, and with noise within a reading after it at the latest (sooner at the median, by 1-8 ms); over a 64-fold
    range of rates (so the -2/5 power of the rate) and two reading periods."""
    from piezotip.sensor import Fingertip

    tip, area = Fingertip(), 4e-4
    mu_rate = abs(tip.load_factor_slope_per_pa(0.0, 1)) * rate_n_s / area
    predicted = inference.change_detection_s(mu_rate, tip.envelope_time_constant_s(), tip.sigma(1), dt_s)
    quiet = _first_flag_s(rate_n_s, area, dt_s, noise=False)
    assert predicted - dt_s <= quiet <= predicted + 1e-9
    noisy = [_first_flag_s(rate_n_s, area, dt_s, noise=True, seed=s) for s in range(9)]
    assert max(noisy) <= predicted + dt_s  # noise flags it no later than a reading past it
    assert np.median(noisy) >= predicted - 4 * dt_s


def test_the_change_tests_latency_is_infinite_without_a_ramp_and_refuses_bad_input():
    assert inference.change_detection_s(0.0, TAU0_S, SIGMA, DT_S) == math.inf
    for bad in ({"tau0_s": 0.0}, {"sigma": math.nan}, {"reading_period_s": -1.0}, {"mu_rate_per_s": math.nan}):
        args = {"mu_rate_per_s": 1.0, "tau0_s": TAU0_S, "sigma": SIGMA, "reading_period_s": DT_S, **bad}
        with pytest.raises(ValueError, match=next(iter(bad))):
            inference.change_detection_s(**args)
