"""Calibration and the readout of a physical unit (sensor/calibration.py, SensorChannel's unit path).

Independent numbers: eq. 19 (Fingertip.output) for a unit read on its own resonance; the
single-mode response's closed form g / (1 - j delta) for a detuned one; the true resonance of
the drawn unit (which the readout never sees) for the self-calibration sweep; the true pressure
for the estimate's error and its 3-sigma interval; the detuning's stiffness rho A (w_r^2 - w_d^2)
against the gel's dkappa/dP for the drift under load that no re-zero can remove.
"""

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from piezotip.reports.range_report import estimate_errors, unit_range_report
from piezotip.sensor import Fingertip
from piezotip.sensor.calibration import SensorUnit, UnitConfig, detuning, steady_reading, sweep_resonance
from piezotip.sensor.channel import SensorChannel
from piezotip.sensor.unit_channel import UnitChannel
from piezotip.sensor.variation import PZT_YOUNGS_TC_PER_K, PhysicalUnit, draw_unit

TIP = Fingertip(coverage=(6.5e-3, 7.5e-3))
TIP_Q70 = Fingertip(element=TIP.element.with_quality_factor(70), coverage=(6.5e-3, 7.5e-3))


def test_nominal_unit_read_on_resonance_is_eq19():
    p = np.geomspace(1.0, 1e5, 30)
    for m in TIP.modes:
        unloaded = complex(steady_reading(TIP, m, 0.0, TIP.freq_hz(m), 1.0))
        reading = steady_reading(TIP, m, p, TIP.freq_hz(m), unloaded)
        assert_allclose(np.abs(reading), TIP.output(p, m), rtol=1e-12)
        # and its phase is eq. 13's change from the unloaded pi/2
        kappa, gamma = TIP.modal_load(p, m)
        omega, c = TIP.element.natural_angular_frequency(m), TIP.element.params.damping_n_s_per_m2
        assert_allclose(np.angle(reading), math.pi / 2 - np.arctan2(omega * (gamma + c), kappa), rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("delta", [-7.0, -1.0, 0.0, 0.3, 4.0])
@pytest.mark.parametrize("g", [0.9, 1.0, 1.15])
def test_detuning_inverts_the_single_mode_response(delta, g):
    d, gg = detuning(g / (1 - 1j * delta))
    assert_allclose([d, gg], [delta, g], rtol=1e-12, atol=1e-12)


def test_far_detuning_from_the_amplitude():
    # 300 half-bandwidths away the real part is below any noise: |delta| from |z|, the gain kept
    d, g = detuning(1 / (1 - 300j) + 2e-4)  # a noise-sized real error
    assert g == 1.0
    assert_allclose(d, 300, rtol=0.01)  # the noise moves |z| by ~ 2e-4 / 3.3e-3 of its real share


@pytest.mark.parametrize("tip", [TIP, TIP_Q70], ids=["tableI", "Q70"])
@pytest.mark.parametrize("variation, seed", [("typical", 0), ("typical", 5), ("wide", 2)])
def test_self_calibration_finds_the_shifted_resonance(tip, variation, seed):
    unit = PhysicalUnit(tip, draw_unit(variation, seed, 4)).fingertip_at(25.0)
    rng = np.random.default_rng(seed)
    for m in tip.modes:
        true_hz, true_q = unit.freq_hz(m), unit.element.quality_factor(m)
        bandwidth = true_hz / true_q
        # the unit sits many bandwidths from the nominal frequency (Table I: tens to thousands)
        found = sweep_resonance(unit, tip, m, rng)
        # stated: within a thousandth of its bandwidth, Q within 1 %
        assert abs(found.resonance_hz - true_hz) < 1e-3 * bandwidth
        assert_allclose(found.quality_factor, true_q, rtol=1e-2)
        # and its reference is the unit's unloaded response there (1 + 0j once divided by it)
        z = complex(steady_reading(unit, m, 0.0, found.resonance_hz, found.reference_v))
        assert abs(z - 1) < 1e-2


def test_uncalibrated_unit_is_badly_wrong_calibrated_right():
    errors = {}
    for level in ("none", "self", "full"):
        errors[level] = [unit_range_report(SensorUnit(UnitConfig("typical", s, level), TIP))["max_estimate_error"] for s in range(4)]
    # measured (README): no estimate at all without calibration (the reading sits past the
    # model's table: 80 to thousands of bandwidths off resonance), 7 to 45 % after the
    # resonance sweep (the gel's modulus, unmeasured, is amplified where k_e barely moves with
    # P, a few kPa), under 2 % after the bench
    assert all(e > 0.5 for e in errors["none"])
    assert all(e < 0.5 for e in errors["self"])
    assert all(e < 0.02 for e in errors["full"])
    assert max(errors["full"]) < min(errors["self"])


def test_nominal_unit_reproduces_todays_numbers():
    unit = SensorUnit(UnitConfig(), TIP)
    assert unit.model is TIP and not unit.tracking
    report = unit_range_report(unit)
    today = TIP.dynamic_range()
    for key in today:
        if key != "modes":
            assert report[key] == today[key]
    assert [{k: v for k, v in m.items() if k != "drive_freq_hz"} for m in report["modes"]] == today["modes"]
    assert report["max_estimate_error"] < 1e-3  # the tables' interpolation only
    # the channel with the nominal unit is today's channel, reading for reading
    a = SensorChannel(TIP, rng=np.random.default_rng(4))
    b = UnitChannel(TIP, unit, rng=np.random.default_rng(4))
    for k in range(300):
        p = [0.0 if k < 100 else 400.0]
        ra, rb = a.update(p, 0.005), b.update(p, 0.005)
        assert ra == rb
        assert a.estimate(ra) == b.estimate(rb)


@pytest.mark.parametrize("level", ["self", "full"])
def test_varied_units_ok_intervals_hold_the_true_pressure(level):
    # steady readings with noise, pressures across each unit's range, six units
    total = inside = 0
    for seed in range(6):
        unit = SensorUnit(UnitConfig("typical", seed, level), TIP)
        channel = UnitChannel(unit.model, unit, dynamics="steady", rng=np.random.default_rng(seed))
        bands = unit.model.mode_bands()
        for p in np.geomspace(bands[0][1], bands[-1][2], 25):
            mode = next((m for m, lo, hi in bands if p <= hi), bands[-1][0])
            channel.select_mode(mode)
            for _ in range(8):
                est = channel.estimate(channel.update([p], 0.005))
                if est.status == "ok":
                    total += 1
                    inside += abs(est.pressure_pa - p) <= 3 * est.uncertainty_pa
    assert total > 500
    assert inside / total >= 0.99, (inside, total)


def test_rezero_removes_a_temperature_offset_while_unloaded():
    # Table I's damping: one kelvin moves mode 1 by about one and a half half-bandwidths
    config = UnitConfig("typical", 1, "self", 25.0, 0.05)
    results = {}
    for tracking in (True, False):
        unit = SensorUnit(config, TIP)
        unit.tracking = tracking
        channel = UnitChannel(unit.model, unit, dynamics="envelope", rng=np.random.default_rng(2))
        statuses, v1 = [], []
        for k in range(4000):  # 20 s: the unit warms by 1 K, nothing touches it
            reading = channel.update([0.0], 0.005)
            est = channel.estimate(reading)
            if k >= 2000:
                statuses.append(est.status)
                v1.append(reading.v1_true)
        results[tracking] = (reading, est, channel.rezeros, statuses, v1)
    reading, est, rezeros, statuses, v1 = results[True]
    # tracked: re-zeroed every second or so; the unloaded reading stays within 1e-3 of 1 (a
    # third of the detection threshold) and reads no load ("settling" after each re-zero: the
    # inference restarts; measured 46 % of the readings at this 0.05 K/s)
    assert rezeros >= 10
    assert max(abs(np.array(v1) - 1)) < 2e-3
    assert sum(s in ("ok", "saturated") for s in statuses) <= 0.01 * len(statuses)
    assert statuses.count("below_detection") > 0.3 * len(statuses)
    reading, est, _, _, _ = results[False]
    # untracked: the closed form of the detuned unloaded reading, g / (1 - j delta)
    unit = SensorUnit(config, TIP)
    el = unit.physical.fingertip_at(25.0).element
    w_r = el.natural_angular_frequency(1) * unit.physical.resonance_ratio(26.0)
    w_d = 2 * math.pi * unit.drive_hz[1]
    delta = el.params.mass_per_length_kg_m * (w_r**2 - w_d**2) / (w_d * el.params.damping_n_s_per_m2)
    z = complex(unit.reading(1, 0.0, 26.0))
    assert_allclose(detuning(z)[0], delta, rtol=1e-3)  # the reference carries the sweep's ~1e-4 error
    assert delta > 1.0
    # the envelope lags the drift by about tau0 (0.66 s, 0.03 K): within 10 % of the closed form
    assert_allclose(reading.v1_true, abs(z), rtol=0.1)
    assert est.status != "below_detection"  # a false load


def test_drift_under_load_reads_as_load():
    """What a re-zero cannot remove (measured): a resonance that moves while loaded shifts the
    estimate like a gel stiffness: dP/dT = (dV/dkappa dK_d/dT) / (dV/dP), with dK_d/dT =
    rho A w^2 beta, dV/dkappa = -V kappa / h^2 (eq. 19) and dV/dP from eqs. 20, 21, plus the
    drive-to-sense gain's own drift, dV/dT = 2 alpha_p V (eq. 17's Y_p^2)."""
    unit = SensorUnit(UnitConfig("typical", 1, "full"), TIP)
    el = unit.physical.fingertip_at(25.0).element
    mode, p = 2, 2000.0
    from piezotip.sensor.estimator import mode_tables

    inverse = mode_tables(unit.model, mode, False)[1]
    p0 = inverse.pressure(float(abs(unit.reading(mode, p, 25.0))))
    p1 = inverse.pressure(float(abs(unit.reading(mode, p, 25.001))))
    measured = (p1 - p0) / 0.001
    w = el.natural_angular_frequency(mode)
    dk_dt = el.params.mass_per_length_kg_m * w * w * unit.physical.beta_per_k
    model = unit.model
    kappa, gamma = model.modal_load(p, mode)
    omega, c = model.element.natural_angular_frequency(mode), model.element.params.damping_n_s_per_m2
    h2 = kappa**2 + (omega * (gamma + c)) ** 2
    dv_dkappa = -float(model.output(p, mode)) * kappa / h2
    # the unit is not the model (the bench's fit is good to ~1 %), and the slope is local: 5 %
    dv_dt = dv_dkappa * dk_dt + 2 * PZT_YOUNGS_TC_PER_K * float(model.output(p, mode))
    assert_allclose(measured, dv_dt / float(model.output_slope(p, mode)), rtol=0.05)
    assert measured > p  # Table I's Q: a tenth of a kelvin moves mode 2's estimate by more than 10 %


def test_estimate_error_points_span_the_range():
    unit = SensorUnit(UnitConfig("typical", 2, "full"), TIP)
    r = unit_range_report(unit)
    pressures, errors = estimate_errors(unit, r["p_min_pa"], r["p_max_pa"])
    assert pressures[0] == r["p_min_pa"] and pressures[-1] == pytest.approx(r["p_max_pa"])
    assert np.max(errors) == r["max_estimate_error"]


def test_bad_unit_config_is_named():
    for kwargs, text in (
        ({"variation": "huge"}, "huge"),
        ({"unit_seed": -3}, "-3"),
        ({"calibration": "bench"}, "bench"),
        ({"temperature_c": 120.0}, "120"),
    ):
        with pytest.raises(ValueError, match=text):
            UnitConfig(**kwargs)


def test_a_unit_channel_must_be_given_the_units_model():
    unit = SensorUnit(UnitConfig("typical", 3, "self"), TIP)
    with pytest.raises(ValueError, match="unit's model"):
        UnitChannel(TIP, unit)
    channel = UnitChannel(unit.model, unit)
    assert channel.edges_m.tolist() == pytest.approx(list(unit.coverage))  # the unit's own gel coverage
