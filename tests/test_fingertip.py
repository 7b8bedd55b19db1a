"""The fingertip (sensor/fingertip.py, physics.md sections 4-5): forward model, limits, range, mode switching, inverse.

Expected numbers are recomputed in the test: sigma from the noise floors, detection limits with
the test's own brentq, resolution from a finite-difference slope of the forward model, switch
pressures from the test's own scan of the per-mode resolution curves.
"""

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from scipy.optimize import brentq

from piezotip.sensor import Fingertip

MODES = (1, 2, 3, 4)
TIP_COVERAGE = (6.5e-3, 7.5e-3)
REL_FLOOR, ABS_FLOOR_V = 1e-3, 1e-3  # NoiseParams defaults, restated (readout.py)


@pytest.fixture(scope="module")
def whole():
    return Fingertip()


@pytest.fixture(scope="module")
def tip_only():
    return Fingertip(coverage=TIP_COVERAGE)


@pytest.fixture(scope="module", params=["whole", "tip"])
def any_tip(request, whole, tip_only):
    return whole if request.param == "whole" else tip_only


def sigma_ref(tip: Fingertip, mode: int) -> float:
    return math.hypot(REL_FLOOR, ABS_FLOOR_V / tip.element.unloaded_voltage(mode))


def fd_slope(tip: Fingertip, p, mode: int, rel: float = 1e-5):
    p = np.asarray(p, float)
    h = rel * p
    return (tip.output(p + h, mode) - tip.output(p - h, mode)) / (2 * h)


def resolution_ref(tip: Fingertip, p, mode: int):
    """3 sigma / |dV/dP| with the slope from a central difference (physics.md section 5)."""
    return 3 * sigma_ref(tip, mode) / np.abs(fd_slope(tip, p, mode))


# ---------------------------------------------------------------------------------------
# Forward model.
# ---------------------------------------------------------------------------------------

P_GRID = np.concatenate([[0.0], np.geomspace(1e-3, 1.3e6, 400)])


@pytest.mark.parametrize("mode", MODES)
def test_output_in_unit_interval_consistent_and_monotone(any_tip, mode):
    v = any_tip.output(P_GRID, mode)
    assert v[0] == 1.0
    assert np.all((v > 0) & (v <= 1))
    assert np.all(np.diff(v) <= 0), "V_1 must not rise with pressure"
    assert np.all(np.diff(v[1:]) < 0)
    k_e, c_e = any_tip.gel.foundation(P_GRID, any_tip.element.natural_frequency_hz(mode))
    expected = any_tip.element.normalized_output(k_e, c_e, mode, any_tip.coverage)
    assert_allclose(v, expected, rtol=1e-14)


@pytest.mark.parametrize("mode", MODES)
def test_output_equals_eq19_from_the_modal_loads(whole, mode):
    # eq. 19 written out: V_1 = w c / sqrt(kappa^2 + w^2 (gamma + c)^2), kappa = b k_e A_x/A_L
    el = whole.element
    w, c, b = el.natural_angular_frequency(mode), el.params.damping_n_s_per_m2, el.params.width_m
    ratio = el.coverage_ratio(mode, whole.coverage)
    k_e, c_e = whole.gel.foundation(P_GRID, w / (2 * math.pi))
    v = w * c / np.sqrt((b * k_e * ratio) ** 2 + w**2 * (b * c_e * ratio + c) ** 2)
    assert_allclose(whole.output(P_GRID, mode), v, rtol=1e-13)


@pytest.mark.parametrize("mode", MODES)
def test_output_slope_matches_central_finite_difference(any_tip, mode):
    p = np.geomspace(1e-1, 1e6, 60)
    # truncation (h/P)^2 * O(1) = 1e-10; rounding eps / |V'(P) h| <= 1e-8 over this range
    assert_allclose(any_tip.output_slope(p, mode), fd_slope(any_tip, p, mode), rtol=1e-5)
    assert np.all(any_tip.output_slope(p, mode) < 0)


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("p", [0.0, 10.0, 1e4])
def test_the_load_factors_slope_matches_a_finite_difference_of_eq10_inverted(any_tip, mode, p):
    """d mu / dP against a central (one-sided at 0) difference of mu = 1 / (eq. 10 over its
    unloaded value), from the modal loads; its imaginary part (the gel's stiffness detuning the
    mode) outweighs its real part near no load, and |mu| = 1 / V_1."""
    from piezotip.sensor.equations import normalized_response

    omega, c = any_tip.element.natural_angular_frequency(mode), any_tip.element.params.damping_n_s_per_m2

    def mu(pressure):
        kappa, gamma = any_tip.modal_load(pressure, mode)
        return 1.0 / normalized_response(float(kappa), float(gamma), omega, c)

    h = 1e-4 * max(p, 1.0)
    fd = (mu(h) - mu(0.0)) / h if p == 0.0 else (mu(p + h) - mu(p - h)) / (2 * h)
    slope = any_tip.load_factor_slope_per_pa(p, mode)
    assert abs(slope - fd) <= 1e-4 * abs(fd)
    assert abs(mu(p)) == pytest.approx(1.0 / float(any_tip.output(p, mode)), rel=1e-12)
    if p == 0.0:
        assert abs(slope.imag) > abs(slope.real)


def test_the_envelope_time_constant_is_table_is_two_rho_a_over_c(whole):
    """tau0 = 2 rho A / c, 0.66 s with Table I's damping (physics.md section 6)."""
    p = whole.element.params
    assert whole.envelope_time_constant_s() == pytest.approx(2 * p.mass_per_length_kg_m / p.damping_n_s_per_m2, rel=1e-15)
    assert whole.envelope_time_constant_s() == pytest.approx(0.66, abs=0.01)


# ---------------------------------------------------------------------------------------
# Noise, detection limit, upper limit.
# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("mode", MODES)
def test_sigma_is_the_two_floors_in_quadrature(whole, mode):
    assert_allclose(whole.sigma(mode), sigma_ref(whole, mode), rtol=1e-15)


@pytest.mark.parametrize("mode", MODES)
def test_detection_limit_moves_output_by_three_sigma(any_tip, mode):
    target = 3 * sigma_ref(any_tip, mode)
    p_min = any_tip.detection_limit(mode)
    root = brentq(lambda lp: 1.0 - float(any_tip.output(math.exp(lp), mode)) - target, math.log(1e-6), math.log(1e6), xtol=1e-14)
    # both bracket a simple root of a smooth monotone function; xtol 1e-12 in log P in the code
    assert_allclose(p_min, math.exp(root), rtol=1e-9)
    assert_allclose(1.0 - float(any_tip.output(p_min, mode)), target, rtol=1e-8)


@pytest.mark.parametrize("mode", MODES)
def test_upper_limit_resolves_ten_percent_and_no_more_above(any_tip, mode):
    p_max = any_tip.upper_limit(mode)
    assert p_max < any_tip.rated_pressure_pa
    # resolution with the test's own slope: equals 10 % of P at P_max (FD error ~1e-10, brentq xtol 1e-12)
    assert_allclose(float(resolution_ref(any_tip, p_max, mode)), 0.1 * p_max, rtol=1e-6)
    assert_allclose(float(any_tip.resolution(p_max, mode)), 0.1 * p_max, rtol=1e-9)
    # and nowhere above it (up to rated) does the mode resolve 10 %
    above = np.geomspace(p_max * 1.001, any_tip.rated_pressure_pa, 200)
    assert np.all(resolution_ref(any_tip, above, mode) > 0.1 * above)
    # but just below it does
    assert float(resolution_ref(any_tip, p_max * 0.999, mode)) < 0.1 * p_max * 0.999


def test_upper_limit_is_capped_at_rated_pressure():
    tip = Fingertip(rated_pressure_pa=1e4)
    # modes 3 and 4 still resolve 10 % at 10 kPa: their upper limit is the rating itself
    for mode in (3, 4):
        assert float(resolution_ref(tip, 1e4, mode)) < 1e3
        assert tip.upper_limit(mode) == 1e4
    assert tip.sensor_limits()[1] == 1e4


# ---------------------------------------------------------------------------------------
# Dynamic range.
# ---------------------------------------------------------------------------------------

DOCUMENTED_KEYS = {
    "p_min_pa",
    "p_max_pa",
    "dynamic_range",
    "modes",
    "switch_pressures_pa",
    "mode_bands",
    "coverage_m",
    "rated_pressure_pa",
    "backstop_pressure_pa",
    "p_max_within_model_pa",
    "dynamic_range_beyond_model",
    "gel_valid_pressure_pa",
    "model_limit_pa",
    "model_limit",
}


def test_dynamic_range_report_structure_and_consistency(any_tip):
    import json

    report = any_tip.dynamic_range()
    assert set(report) == DOCUMENTED_KEYS
    json.dumps(report, allow_nan=False)  # JSON-ready as promised (all finite here)
    assert [m["mode"] for m in report["modes"]] == list(MODES)
    for m in report["modes"]:
        assert {"mode", "freq_hz", "p_min_pa", "p_max_pa"} <= set(m)
        assert_allclose(m["freq_hz"], any_tip.element.natural_frequency_hz(m["mode"]), rtol=1e-15)
        assert m["p_min_pa"] < m["p_max_pa"]
    assert report["p_min_pa"] == min(m["p_min_pa"] for m in report["modes"])
    assert report["p_max_pa"] == max(m["p_max_pa"] for m in report["modes"])
    assert_allclose(report["dynamic_range_beyond_model"], report["p_max_pa"] / report["p_min_pa"], rtol=1e-15)
    top = min(report["p_max_pa"], report["model_limit_pa"])  # the range within the model stops where the model does
    assert report["p_max_within_model_pa"] == top
    assert_allclose(report["dynamic_range"], top / report["p_min_pa"], rtol=1e-15)
    assert_allclose(report["coverage_m"], any_tip.coverage, rtol=0)
    sw = report["switch_pressures_pa"]
    assert sw == sorted(sw) and len(sw) == len(report["mode_bands"]) - 1
    assert report["mode_bands"][0]["from_pa"] == report["p_min_pa"]
    assert report["mode_bands"][-1]["to_pa"] == report["p_max_pa"]


def test_the_model_ends_at_the_lower_of_the_backstop_and_the_gels_valid_strain(whole, tip_only):
    from piezotip.sensor import Mounting

    gel_pa = whole.gel.params.max_valid_pressure_pa
    assert_allclose(gel_pa, 37333.33, rtol=1e-6)  # Gent at 50 % strain, the default gel
    assert whole.model_limit() == (whole.backstop_pressure_pa(), "backstop")  # 23.8 kPa: the beam's stop first
    assert tip_only.model_limit() == (gel_pa, "gel_strain")  # the tip's stop is at 74.5 kPa
    free = Fingertip(coverage=whole.coverage, mounting=Mounting(kind="free-span"))
    assert free.model_limit() == (gel_pa, "gel_strain") and free.dynamic_range()["backstop_pressure_pa"] is None


def test_the_range_within_the_model_is_capped_where_the_model_ends():
    from piezotip.sensor.fingertip import range_within_model

    r = range_within_model(1.0, 1e5, 2e4)  # P_max past the model's end: the range stops there
    assert r == {"p_max_within_model_pa": 2e4, "dynamic_range": 2e4, "dynamic_range_beyond_model": 1e5}
    assert range_within_model(1.0, 1e3, 2e4)["dynamic_range"] == 1e3  # P_max within it: the same figure
    assert math.isnan(range_within_model(3e4, 1e5, 2e4)["dynamic_range"])  # P_min past it: none within the model
    assert all(math.isnan(v) for v in range_within_model(math.inf, math.nan, 2e4).values())


def test_frequencies_are_the_cantilever_modes(whole):
    # f_n = (beta_n L)^2 / (2 pi L^2) sqrt(EI / rho A) with the clamped-free roots (physics.md section 2)
    p = whole.element.params
    ts, tp, b, length = 25e-6, 200e-6, 5e-3, 7.5e-3
    ei = b * (105e9 * (2 * ts) ** 3 / 12 + (2 / 3) * 62e9 * ((ts + tp) ** 3 - ts**3))
    rho_a = b * (2 * ts * 4500 + 2 * tp * 7650)
    assert_allclose([p.bending_stiffness_n_m2, p.mass_per_length_kg_m], [ei, rho_a], rtol=1e-14)
    roots = [1.8751040687, 4.6940911330, 7.8547574382, 10.9955407349]
    for mode, bl in zip(MODES, roots, strict=True):
        assert_allclose(whole.freq_hz(mode), bl**2 / length**2 * math.sqrt(ei / rho_a) / (2 * math.pi), rtol=1e-9)


def test_calibration_targets_of_the_paper(whole):
    # physics.md section 4: mode 1 resolved 1-2.5 Pa; mode 3 still measured >= 10 kPa; range >= 1e4
    assert whole.detection_limit(1) <= 2.5
    assert whole.upper_limit(3) >= 1e4
    report = whole.dynamic_range()
    assert report["dynamic_range"] >= 1e4


def test_tip_coverage_widens_range_and_lowers_sensitivity(whole, tip_only):
    # physics.md section 3 (the paper's qualitative finding)
    for mode in MODES:
        assert tip_only.detection_limit(mode) > whole.detection_limit(mode)
        assert tip_only.upper_limit(mode) > whole.upper_limit(mode)


# ---------------------------------------------------------------------------------------
# Mode switching.
# ---------------------------------------------------------------------------------------


def test_switch_pressures_are_resolution_crossings(any_tip):
    bands = any_tip.mode_bands()
    sw = any_tip.switch_pressures()
    assert len(sw) >= 1
    assert all(a < b for a, b in itertools.pairwise(sw)), "switch pressures must ascend"
    for (a, _, s), (b, _, _) in itertools.pairwise(bands):
        assert a != b
        # the two resolution curves cross there (brentq xtol 1e-12 in log P; slopes ~O(1) in log-log)
        assert_allclose(float(any_tip.resolution(s, a)), float(any_tip.resolution(s, b)), rtol=1e-6)
        assert_allclose(float(resolution_ref(any_tip, s, a)), float(resolution_ref(any_tip, s, b)), rtol=1e-6)
        assert int(any_tip.best_mode(s * (1 - 1e-4))) == a
        assert int(any_tip.best_mode(s * (1 + 1e-4))) == b


def test_switch_pressures_match_an_independent_scan(any_tip):
    p_lo, p_hi = any_tip.sensor_limits()
    grid = np.geomspace(p_lo, p_hi, 3000)
    res = np.stack([resolution_ref(any_tip, grid, m) for m in MODES])
    best = np.asarray(MODES)[np.argmin(res, axis=0)]
    changes = np.nonzero(best[1:] != best[:-1])[0]
    sw = any_tip.switch_pressures()
    assert len(sw) == len(changes)
    # each switch lies between the grid points where the test's own argmin changes
    for s, i in zip(sw, changes, strict=True):
        assert grid[i] <= s <= grid[i + 1]
    bands = any_tip.mode_bands()
    assert [b[0] for b in bands] == [int(best[0]), *[int(best[i + 1]) for i in changes]]


def test_best_mode_is_argmin_of_resolution(whole):
    p = np.geomspace(1.0, 1e6, 50)
    res = np.stack([3 * sigma_ref(whole, m) / np.abs(whole.output_slope(p, m)) for m in MODES])
    assert np.array_equal(whole.best_mode(p), np.asarray(MODES)[np.argmin(res, axis=0)])


# ---------------------------------------------------------------------------------------
# The inverse.
# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("mode", MODES)
def test_estimate_inverts_output_across_the_mode_range(any_tip, mode):
    p_min, p_max = any_tip.detection_limit(mode), any_tip.upper_limit(mode)
    # (1 +- 1e-6) keeps the exact band edges out: there the status flips on rounding
    p = np.geomspace(p_min * (1 + 1e-6), p_max * (1 - 1e-6), 80)
    est = any_tip.estimate(any_tip.output(p, mode), mode)
    assert np.all(est.status == "ok")
    assert_allclose(est.pressure_pa, p, rtol=1e-6)
    # one-sigma uncertainty: sigma / |dV/dP| at the estimate, with the test's slope (FD ~1e-8)
    assert_allclose(est.uncertainty_pa, sigma_ref(any_tip, mode) / np.abs(fd_slope(any_tip, p, mode)), rtol=1e-6)


@pytest.mark.parametrize("mode", MODES)
def test_noisy_estimates_are_calibrated(whole, mode):
    p_min, p_max = whole.detection_limit(mode), whole.upper_limit(mode)
    n = 2000
    for k, p in enumerate(np.geomspace(10 * p_min, 0.3 * p_max, 3)):
        rng = np.random.default_rng(1000 * mode + k)
        readings = whole.noisy_output(np.full(n, p), mode, rng=rng)
        assert_allclose(np.std(readings), sigma_ref(whole, mode), rtol=0.1)  # 2000 samples: std error 1.6 %
        est = whole.estimate(readings, mode)
        assert np.mean(est.status == "ok") >= 0.99
        z = (est.pressure_pa - p) / est.uncertainty_pa
        z = z[np.isfinite(z)]
        # Gaussian: 99.7 % within 3 sigma; >= 99 % leaves room for the slight non-linearity
        assert np.mean(np.abs(z) <= 3) >= 0.99
        assert 0.8 <= np.std(z) <= 1.2
        assert abs(np.mean(z)) < 0.2  # unbiased to well under the noise (std error of the mean 0.022)


@pytest.mark.parametrize("mode", MODES)
def test_estimate_status_below_detection_and_saturated(whole, mode):
    s = sigma_ref(whole, mode)
    est = whole.estimate(np.array([1.0 - s, 1.0 - 2.9 * s, 1.0]), mode)
    assert list(est.status) == ["below_detection"] * 3
    assert np.all(np.isfinite(est.pressure_pa)) and np.all(est.pressure_pa >= 0)
    assert np.all(est.pressure_pa <= whole.detection_limit(mode))
    assert_allclose(est.uncertainty_pa, whole.detection_limit(mode), rtol=0)
    p_max = whole.upper_limit(mode)
    past = whole.output(np.array([1.01 * p_max, 2 * p_max, 1e6]), mode)
    est = whole.estimate(np.concatenate([past, [0.0, -0.1]]), mode)
    assert list(est.status) == ["saturated"] * 5
    assert np.all(np.isnan(est.pressure_pa))
    # a reading above 1 (noise on an unloaded element) is zero pressure
    assert_allclose(whole.estimate_pressure(np.array([1.0 + s, 1.5]), mode), 0.0, atol=0)


# ---------------------------------------------------------------------------------------
# Bad input.
# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("bad", [-1.0, math.nan, math.inf])
def test_bad_pressure_raises(whole, bad):
    with pytest.raises(ValueError, match="pressure"):
        whole.output(bad, 1)
    with pytest.raises(ValueError, match="pressure"):
        whole.resolution(bad, 1)
    with pytest.raises(ValueError, match="pressure"):
        whole.best_mode(bad)
    with pytest.raises(ValueError, match="pressure"):
        whole.stress(bad)


@pytest.mark.parametrize(("mode", "msg"), [(5, "mode 5"), (0, "mode"), (-1, "mode"), (1.5, "mode"), (True, "mode"), (1.0, "mode")])
def test_bad_mode_raises(mode, msg):
    tip = Fingertip()  # fresh: nothing cached yet
    for call in (tip.output, tip.output_slope, tip.resolution):
        with pytest.raises(ValueError, match=msg):
            call(10.0, mode)
    for call in (tip.detection_limit, tip.upper_limit, tip.freq_hz, tip.sigma):
        with pytest.raises(ValueError, match=msg):
            call(mode)
    with pytest.raises(ValueError, match=msg):
        tip.estimate(0.9, mode)


@pytest.mark.parametrize("mode", [1.0, True])
def test_cached_limits_still_validate_mode(mode):
    # detection_limit and upper_limit are functools.cache'd on (self, mode); 1.0 and True hash and
    # compare equal to 1, so once mode 1 is cached they return mode 1's limit instead of raising
    # the ValueError they raise on a fresh Fingertip.
    tip = Fingertip()
    tip.detection_limit(1)
    tip.upper_limit(1)
    with pytest.raises(ValueError, match="mode"):
        tip.detection_limit(mode)
    with pytest.raises(ValueError, match="mode"):
        tip.upper_limit(mode)


def test_nan_reading_raises(whole):
    with pytest.raises(ValueError, match="NaN"):
        whole.estimate(np.array([0.9, math.nan]), 1)


@pytest.mark.parametrize(
    "kwargs",
    [{"coverage": (3e-3, 2e-3)}, {"coverage": (0.0, 8e-3)}, {"modes": ()}, {"modes": (0,)}, {"rated_pressure_pa": -1.0}],
)
def test_bad_construction_raises(kwargs):
    with pytest.raises(ValueError):
        Fingertip(**kwargs)


# ---------------------------------------------------------------------------------------
# Property test.
# ---------------------------------------------------------------------------------------


@settings(max_examples=50, deadline=None)
@given(p=st.floats(0.0, 1.3e6), mode=st.sampled_from(MODES), tip_cov=st.booleans())
def test_outputs_are_finite_and_in_unit_interval(whole, tip_only, p, mode, tip_cov):
    tip = tip_only if tip_cov else whole
    v = float(tip.output(p, mode))
    assert math.isfinite(v) and 0.0 <= v <= 1.0
    assert math.isfinite(float(tip.output_slope(p, mode))) and float(tip.output_slope(p, mode)) <= 0
