"""Property tests of the invertible maps: a map and its inverse checked against each other on
generated inputs, with tolerances that follow from float precision or from a table's spacing.

1. The ``--set`` text: a config printed as overrides (:func:`scenarios.override_strings` of a
   mapping, the one printer: ``piezotip.run(overrides={...})``, the sweep's grid points) and parsed
   back (:func:`scenarios.config.with_overrides`, the command line's reader) is the same config.
2. The gel law (sensor/gel.py): Gent's pressure against indentation and its inverse, the
   stretch at a pressure; the Winkler stiffness as the derivative dP/d(indentation).
3. Each mode's inverse (sensor/estimator.py): the exact estimate (Newton on the forward model)
   and the per-step table inverse, against the forward model V_1(P) (sensor/fingertip.py).
4. Cheap maps of the geometry: the pad's strips, the coverage cells and their weights, the
   element's per-cell modal integrals, and eq. 19 as the ratio of eqs. 17 and 18.

Every test is deterministic (``derandomize=True``, no example database).
"""

from __future__ import annotations

import dataclasses
import functools
import itertools
import math
import typing
from unittest import mock

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from piezotip import scenarios
from piezotip.cosim import build_checks
from piezotip.cosim.loop import coverage_cells, coverage_weights, make_fingertip
from piezotip.cosim.pad_geometry import PadGeometry
from piezotip.scenarios.config import (
    FRICTION_RANGE,
    INTEGRATORS,
    LOAD_SPREADS,
    MAX_CONTROL_PERIOD_S,
    MAX_EXTRA_LOAD_N,
    MAX_PERSIST_S,
    MAX_RECORDED_STEPS,
    MAX_SEED,
    MAX_TIMESTEP_S,
    MAX_WIDTH_SIGMA_M,
    MIN_COVERAGE_MM,
    MIN_QUALITY_FACTOR,
    MIN_TIMESTEP_S,
    OBJECT_SHAPES,
    RATED_MASS_KG,
    SENSOR_DYNAMICS,
    ControllerConfig,
    DisturbConfig,
    ObjectConfig,
    PerceptionConfig,
    PhysicsConfig,
    ScenarioConfig,
    SensorConfig,
    with_overrides,
)
from piezotip.sensor import ElementParams, Fingertip, SensorElement
from piezotip.sensor.calibration import CALIBRATIONS
from piezotip.sensor.estimator import _TABLE_P, mode_tables
from piezotip.sensor.gel import GelModel, GelParams, contact_fraction, gent_tangent_pa
from piezotip.sensor.inference import MAX_GAIN, WINDOW_S
from piezotip.sensor.variation import TEMPERATURE_RANGE_C, VARIATIONS

EPS = float(np.finfo(float).eps)


def _settings(examples: int):
    return settings(max_examples=examples, deadline=None, derandomize=True, database=None)


# ---------------------------------------------------------------------------------------
# 1. The override parse/print round trip.
# ---------------------------------------------------------------------------------------

_MM = 1e-3


def _value(config, key: str):
    """The value at a dotted key (``sensor.coverage_mm``)."""
    return functools.reduce(getattr, key.split("."), config)


def _printed(config: ScenarioConfig) -> list[str]:
    """``config`` printed as ``--set`` strings, every settable key."""
    return scenarios.override_strings({key: _value(config, key) for key in scenarios.valid_keys(config)})


def _positive_floats(max_value: float | None = None):
    """Any positive finite float up to ``max_value`` (subnormals included: their repr reads back)."""
    return st.floats(min_value=0.0, max_value=max_value, exclude_min=True, allow_nan=False, allow_infinity=False)


def _fraction(lo: float, hi: float, exclude_min: bool = True, exclude_max: bool = True):
    return st.floats(lo, hi, exclude_min=exclude_min, exclude_max=exclude_max)


#: Any text, as a name or description (surrounding whitespace included: test_text_with_surrounding_...
#: below pins that case); 200 characters keep a repr's escapes inside MAX_VALUE_CHARS.
_TEXT = st.text(max_size=200)

#: sensor.quality_factor's valid range at any control period: at least MIN_QUALITY_FACTOR, and at
#: most the readout's limit pi f_1 MAX_GAIN sqrt(W^3 / (192 dt)) at the coarsest period dt (2.1e4 at
#: 20 ms: SensorConfig's docstring, ScenarioConfig._check_quality_factor), so that no Q drawn depends
#: on the period drawn with it (less 1e-12 of it: the product rounds the same number in its own order).
_Q_MAX_ANY_PERIOD = (
    math.pi
    * SensorElement(ElementParams()).natural_frequency_hz(1)
    * MAX_GAIN
    * math.sqrt(WINDOW_S**3 / (192.0 * MAX_CONTROL_PERIOD_S))
    * (1 - 1e-12)
)


@st.composite
def physics_configs(draw) -> PhysicsConfig:
    timestep = draw(st.floats(MIN_TIMESTEP_S, MAX_TIMESTEP_S))
    substeps = draw(st.integers(1, max(1, math.floor(MAX_CONTROL_PERIOD_S / timestep))))
    period = substeps * timestep
    assume(period <= MAX_CONTROL_PERIOD_S)
    return PhysicsConfig(
        timestep_s=timestep,
        integrator=draw(st.sampled_from(INTEGRATORS)),
        pad_segments=draw(st.integers(1, 64)),
        control_period_s=period,
        gel_update=draw(st.sampled_from(("substep", "control"))),
    )


@st.composite
def sensor_configs(draw) -> SensorConfig:
    x1 = draw(st.floats(0.0, 7.5 - MIN_COVERAGE_MM))
    x2 = draw(st.floats(x1 + MIN_COVERAGE_MM, 7.5))
    assume(x2 - x1 >= MIN_COVERAGE_MM)
    quality = draw(st.none() | st.floats(MIN_QUALITY_FACTOR, _Q_MAX_ANY_PERIOD))
    return SensorConfig(
        pads=tuple(draw(st.lists(st.sampled_from(("left", "right")), min_size=1, max_size=2, unique=True))),
        modes=tuple(draw(st.lists(st.integers(1, 30), min_size=1, max_size=6, unique=True))),
        dynamics=draw(st.sampled_from(SENSOR_DYNAMICS)),
        quality_factor=quality,
        gel_frequency_dependent=draw(st.booleans()),
        coverage_mm=(x1, x2),
        noise=draw(st.booleans()),
        seed=draw(st.integers(0, MAX_SEED)),
        damage_stiffness=draw(_fraction(0.0, 1.0, exclude_max=False)),
        damage_coupling=draw(_fraction(0.0, 1.0, exclude_max=False)),
        # at most 2 Q (critical damping) for the lowest Q allowed
        damage_damping=draw(st.floats(1.0, 2.0 * MIN_QUALITY_FACTOR)),
        exact_gel=draw(st.booleans()),
        carrier_samples_per_cycle=draw(st.integers(4, 256)),
        gel_layer=draw(st.sampled_from(("winkler", "dynamic"))),
        load_spread=draw(st.sampled_from(LOAD_SPREADS)),
        variation=draw(st.sampled_from(VARIATIONS)),
        unit_seed=draw(st.integers(0, MAX_SEED)),
        calibration=draw(st.none() | st.sampled_from(CALIBRATIONS)),
        temperature_c=draw(st.floats(*TEMPERATURE_RANGE_C)),
        temperature_drift_c_per_s=draw(st.floats(allow_nan=False, allow_infinity=False)),
    )


def _controller_classes() -> dict[str, type[ControllerConfig]]:
    """The built-in controllers' config classes by kind (one registered by a test's script, with
    fields of its own kinds, is left out)."""
    from piezotip import controllers

    registered = {kind: controllers.get(kind).config for kind in controllers.names()}
    return {kind: cls for kind, cls in registered.items() if cls.__module__.startswith("piezotip.")}


#: Candidate values of a controller field by its type; a candidate its config refuses (each
#: field's range is its class's validate) gives way to the default.  Floats from the three kinds
#: of range the fields have: positive, a fraction, above 1.
_FLOAT = st.one_of(_positive_floats(), _fraction(0.0, 1.0), st.floats(1.0, 1e3))
_CANDIDATES = {
    float: _FLOAT,
    float | None: st.none() | _FLOAT,
    # (persist: 50 readings of the longest period, 20 ms, are MAX_PERSIST_S)
    int: st.integers(0, math.floor(MAX_PERSIST_S / MAX_CONTROL_PERIOD_S)),
    bool: st.booleans(),
}


@st.composite
def controller_configs(draw, sensor_modes: tuple[int, ...]) -> ControllerConfig:
    kind = draw(st.sampled_from(sorted(_controller_classes().items())))[0]
    cls = _controller_classes()[kind]
    config = cls(kind=kind)
    config = dataclasses.replace(config, modes=tuple(draw(st.lists(st.sampled_from(sensor_modes), min_size=1, unique=True))))
    hints = typing.get_type_hints(cls)
    for f in dataclasses.fields(cls):
        if f.name in ("kind", "modes") or hints[f.name] not in _CANDIDATES:
            continue
        try:
            candidate = dataclasses.replace(config, **{f.name: draw(_CANDIDATES[hints[f.name]])})
            candidate.validate()
        except ValueError:
            continue
        config = candidate
    return config


@st.composite
def scenario_configs(draw) -> ScenarioConfig:
    physics = draw(physics_configs())
    sensor = draw(sensor_configs())
    return ScenarioConfig(
        name=draw(_TEXT),
        description=draw(_TEXT),
        duration_s=draw(_positive_floats(MAX_RECORDED_STEPS * physics.control_period_s)),
        object=ObjectConfig(
            shape=draw(st.sampled_from(OBJECT_SHAPES)),
            mass_kg=draw(st.floats(*RATED_MASS_KG)),
            size_m=draw(st.floats(12 * _MM, 85 * _MM)),
            friction=draw(st.floats(*FRICTION_RANGE)),
            crush_force_n=draw(st.none() | _positive_floats()),
        ),
        physics=physics,
        sensor=sensor,
        controller=draw(controller_configs(sensor.modes)),
        disturb=DisturbConfig(extra_load_n=draw(st.none() | st.floats(0.0, MAX_EXTRA_LOAD_N)), ramp_s=draw(_positive_floats())),
        perception=PerceptionConfig(
            width_sigma_m=draw(st.none() | st.floats(0.0, MAX_WIDTH_SIGMA_M)),
            width_m=draw(st.none() | _positive_floats()),
            seed=draw(st.integers(0, MAX_SEED)),
        ),
    )


def _without_fingertip_check():
    """The overrides' build check without its fingertip check, the fingertip's modes against the controller
    (it builds and calibrates a fingertip per sensor configuration, seconds each, and judges the
    physics of a coverage, not the text): every other range is checked as the command line does."""
    return mock.patch.object(build_checks, "_check_fingertip", lambda *args: None)


@_settings(60)
@given(config=scenario_configs())
def test_every_config_printed_as_overrides_parses_back_to_itself(config):
    with _without_fingertip_check():
        config.validate()  # the strategies draw valid configs only
        printed = _printed(config)
        assert len(printed) == len(scenarios.valid_keys(config))
        parsed = with_overrides(ScenarioConfig(name="other", description="other"), printed)
    assert parsed == config


@pytest.mark.parametrize("preset", [None, *scenarios.PRESETS])
@pytest.mark.parametrize("name", scenarios.names())
def test_every_registered_scenario_printed_and_parsed_is_itself(name, preset):
    """The real reader, the fingertip check included: every scenario at every preset."""
    config = scenarios.get(name, preset=preset)
    mapping = {key: _value(config, key) for key in scenarios.valid_keys(config)}
    assert scenarios.get(name, mapping) == config
    assert scenarios.get(name, _printed(config)) == config


@pytest.mark.parametrize("text", [" x", "x ", "\tx", "x\n", "  "])
def test_text_with_surrounding_whitespace_printed_and_parsed_is_itself(text):
    """Text with surrounding whitespace is printed quoted: the ``key=value`` reader strips what is
    plain, so ``scenarios.get("grasp", {"description": " x"}).description`` was "x".  (Only name and
    description take free text.)"""
    printed = scenarios.override_strings({"description": text})
    assert scenarios.get("grasp", printed).description == text


# ---------------------------------------------------------------------------------------
# 2. The gel law against its indentation.
# ---------------------------------------------------------------------------------------
#
# Float budget.  The stretch lambda = 1 - d / h0 is rounded to half an ulp of 1 (eps/2), which
# moves P by T eps / 2 (T = -dP/dlambda, Pa); Gent's quotient is then evaluated to a few roundings
# whose cancellations (lambda^-2 - lambda near 1, J_m - I_1 + 3 near the lock) amount to at most
# about eps (P + T) (measured 1.3 eps (P + T) against 50-digit arithmetic over E 1e3-1e6 Pa,
# J_m 0.1-300, h0 1-20 mm).  The inverse returns lambda to within an ulp (its Newton step's proof,
# sensor/gel.py), i.e. eps in lambda.  Together: indentation to 4 eps h0, pressure to 4 eps (P + T).
_GEL_ULPS = 4.0


@st.composite
def gels(draw) -> GelModel:
    """Gels over the plausible range of soft pads: E 1-1000 kPa, J_m 0.1-300, h0 1-20 mm."""
    params = GelParams(
        thickness_m=draw(st.floats(1e-3, 2e-2)),
        youngs_modulus_pa=draw(st.floats(1e3, 1e6)),
        gent_jm=draw(st.floats(0.1, 300.0)),
    )
    return GelModel(params)


def _lock_indentation_m(gel: GelModel) -> float:
    """The indentation at which Gent's law locks, m."""
    return (1.0 - gel.params.locking_stretch) * gel.params.thickness_m


def _tangent_pa(gel: GelModel, indentation_m: float) -> float:
    return float(gent_tangent_pa(1.0 - indentation_m / gel.params.thickness_m, gel.params))


@_settings(300)
@given(gel=gels(), share=st.floats(0.0, 1.0))
def test_indentation_to_pressure_and_back_is_the_indentation(gel, share):
    """d -> P (pressure_from_indentation) -> strain h0 (the inverse, GelModel.state) is d, up to
    the lock; at or past it the forward law refuses (the housing must take the load)."""
    h0 = gel.params.thickness_m
    d = share * _lock_indentation_m(gel)
    lam = 1.0 - d / h0
    if lam <= gel.params.locking_stretch or gel.params.gent_jm - (lam**2 + 2.0 / lam - 3.0) <= 0.0:  # at the lock, to an ulp
        with pytest.raises(ValueError, match="locking thickness"):
            gel.pressure_from_indentation(d)
        return
    p = float(gel.pressure_from_indentation(d))
    assert math.isfinite(p) and p >= 0.0
    back = float(gel.state(p).strain) * h0
    assert abs(back - d) <= _GEL_ULPS * EPS * h0, (d, back)


@_settings(300)
@given(gel=gels(), log_p=st.floats(-6.0, 9.0))
def test_pressure_to_indentation_and_back_is_the_pressure(gel, log_p):
    """P -> indentation (the inverse) -> P (the forward law), across 15 decades of pressure."""
    p = 10.0**log_p
    d = float(gel.state(p).strain) * gel.params.thickness_m
    assert 0.0 < d < _lock_indentation_m(gel)
    back = float(gel.pressure_from_indentation(d))
    assert abs(back - p) <= _GEL_ULPS * EPS * (p + _tangent_pa(gel, d)), (p, back)


#: Pairs for the monotony tests: a point and one a relative step 10^log_step above it, from far
#: apart down to steps of a few ulps (a wiggle in a map shows only between near points).
_LOG_STEPS = st.floats(-15.0, 0.0)


@_settings(200)
@given(gel=gels(), share=st.floats(0.0, 1.0, exclude_max=True), log_step=_LOG_STEPS)
def test_more_pressure_more_indentation(gel, share, log_step):
    d_lo = share * _lock_indentation_m(gel)
    d_hi = d_lo + 10.0**log_step * _lock_indentation_m(gel)
    assume(1.0 - d_hi / gel.params.thickness_m > gel.params.locking_stretch)
    try:
        p_lo, p_hi = (float(gel.pressure_from_indentation(d)) for d in (d_lo, d_hi))
    except ValueError:  # within an ulp of the lock, where the law refuses (its denominator is 0)
        assume(False)
    assert p_lo <= p_hi
    strain_lo, strain_hi = (float(gel.state(p).strain) for p in (p_lo, p_hi))
    assert strain_lo <= strain_hi


def test_zero_at_zero():
    gel = GelModel()
    assert float(gel.pressure_from_indentation(0.0)) == 0.0
    assert float(gel.pressure_from_indentation(-1e-3)) == 0.0  # a strip pulled out carries no compression
    state = gel.state(0.0)
    assert float(state.stretch) == 1.0 and float(state.strain) == 0.0
    assert [float(v) for v in gel.foundation(0.0, 3768.0)] == [0.0, 0.0]


@_settings(200)
@given(gel=gels(), share=st.floats(1e-12, 1.0 - 1e-6))
def test_winkler_stiffness_is_the_slope_of_pressure_against_indentation(gel, share):
    """k_e / phi at a quasi-static drive (Re R = 1) is K = dP/dd: bracketed by the backward and
    forward differences of the law (P is convex in d: gent_curvature_pa > 0), widened by the
    rounding of the three pressures (eps (P + T) each, the budget above) over the step.

    The step is 2^-20 of the distance to the lock (so d + h stays inside the law): the bracket's
    relative width from the curvature is then about 1e-6 everywhere, and the rounding slack some
    1e-8 mid-range, growing to 1e-2 at shares of 1 - 1e-6 of the lock (the last drawn: the step is
    then 1e-12 of it).  Shares from 1e-12 keep the pressure, and so the contact fraction phi, far
    from subnormal."""
    h0 = gel.params.thickness_m
    d_lock = _lock_indentation_m(gel)
    d = share * d_lock
    h = (d_lock - d) * 2.0**-20
    assume(1.0 - (d + h) / h0 > gel.params.locking_stretch)
    p_back, p, p_fwd = (float(gel.pressure_from_indentation(max(x, 0.0))) for x in (d - h, d, d + h))
    backward = (p - p_back) / h if d >= h else math.nan  # (at d < h the backward point is clipped to 0)
    forward = (p_fwd - p) / h
    slack = 2.0 * _GEL_ULPS * EPS * (p_fwd + _tangent_pa(gel, d + h)) / h
    # the model's stiffness, as the sensor sees it: k_e at a drive slow enough that Re R = 1 to rounding
    k_e, _ = gel.foundation(p, 1e-6)
    phi = float(contact_fraction(p, gel.params))
    stiffness = float(gel.state(p).stiffness_n_m3)
    assert float(k_e) == pytest.approx(stiffness, rel=4 * EPS, abs=0.0)
    winkler = stiffness / phi
    assert winkler <= forward + slack, (winkler, forward, slack)
    if not math.isnan(backward):
        assert backward - slack <= winkler, (backward, winkler, slack)


# ---------------------------------------------------------------------------------------
# 3. Each mode's inverse.
# ---------------------------------------------------------------------------------------

MODES = (1, 2, 3, 4)
#: Pressures this close (relatively) to a mode's P_min or P_max are left out: there the status
#: flips on rounding.  1e-9 is far above the estimate's own error (below 1e-12 relative, the
#: budget of test_exact_estimate_recovers_the_pressure) and the drop's (3 sigma ~ 3e-3 moves by
#: 3e-12 at 1e-9 of P_min).
_EDGE = 1e-9


@functools.cache
def _fingertip(kind: str) -> Fingertip:
    """The fingertips the runs use: the default scenario's (the tip covered), its fast preset's
    (one gel frequency), and the whole beam covered."""
    if kind == "grasp":
        return make_fingertip(scenarios.get("grasp"))
    if kind == "fast":
        return make_fingertip(scenarios.get("grasp", preset="fast"))
    return Fingertip()


_FINGERTIPS = ("grasp", "fast", "whole")


def _in_range(tip: Fingertip, mode: int, share: float) -> float:
    """The pressure a ``share`` of the way across the mode's measurable range in log P, Pa."""
    p_min, p_max = tip.detection_limit(mode) * (1 + _EDGE), tip.upper_limit(mode) * (1 - _EDGE)
    return math.exp(math.log(p_min) + share * (math.log(p_max) - math.log(p_min)))


@_settings(120)
@given(kind=st.sampled_from(_FINGERTIPS), mode=st.sampled_from(MODES), share=st.floats(0.0, 1.0))
def test_exact_estimate_recovers_the_pressure(kind, mode, share):
    """estimate(output(p)) = p.  Budget: the reading V_1 = output(p) and Newton's last evaluation
    of it are each within 4 eps of eq. 19 (V_1 <= 1; a handful of roundings in k_e, c_e and the
    hypot), so the estimate is where the curve passes within 8 eps of the reading: in ln P within
    8 eps / |dV_1/d ln P| (Newton's own error after three steps from the table's 3e-4: 1e-7, 1e-14,
    then below rounding)."""
    tip = _fingertip(kind)
    p = _in_range(tip, mode, share)
    est = tip.estimate(tip.output(np.array([p]), mode), mode)
    assert est.status[0] == "ok"
    slope = abs(p * float(tip.output_slope(p, mode)))
    assert abs(math.log(float(est.pressure_pa[0]) / p)) <= 8 * EPS / slope


@functools.cache
def _table_inverse(kind: str, mode: int):
    """The per-step readout's tables (presets without exact_gel): the (k_e, c_e) table and the inverse."""
    return mode_tables(_fingertip(kind), mode, exact=False)


def _table_output(kind: str, mode: int, p: float) -> float:
    """The forward model the per-step readout is built on: V_1 from the tabulated (k_e, c_e)."""
    tip = _fingertip(kind)
    table, _ = _table_inverse(kind, mode)
    k_e, c_e = table(np.array([p]))
    return float(tip.element.normalized_output(k_e, c_e, mode, tip.coverage)[0])


#: The table's resolution: its pressures are 60 a decade, a node interval spans a factor 10^(1/60).
_CELL = float(_TABLE_P[1] / _TABLE_P[0])


@_settings(150)
@given(kind=st.sampled_from(_FINGERTIPS), mode=st.sampled_from(MODES), share=st.floats(0.0, 1.0))
def test_table_inverse_lands_in_the_pressure_cell_of_the_table(kind, mode, share):
    """The per-step inverse interpolates ln P between the table's nodes, where the forward curve
    takes its exact values (the (k_e, c_e) table's nodes are the gel model's), and between nodes
    the curve is monotone (k_e, c_e interpolated monotonically, V_1 falling in both): so the
    estimate lies in the node interval that holds p, the table's resolution of a factor _CELL
    (3.9 %), up to the rounding of exp(ln P) (|ln P| + 1 eps relative).

    Hence also its status: a pressure a cell inside the mode's range [P_min, P_max] reads "ok"
    (its estimate cannot pass P_max, its reading drops at least as far as the node below it,
    itself past P_min); nearer the limits the table may call it saturated or below detection."""
    tip = _fingertip(kind)
    p = _in_range(tip, mode, share)
    _, inverse = _table_inverse(kind, mode)
    v = _table_output(kind, mode, p)
    back = inverse.pressure(v)
    j = int(np.searchsorted(_TABLE_P, p, side="right")) - 1
    rounding = (abs(math.log(p)) + 1.0) * EPS
    assert _TABLE_P[j] * (1 - rounding) <= back <= _TABLE_P[j + 1] * (1 + rounding), (p, back)
    estimate = inverse(v)
    if tip.detection_limit(mode) * _CELL * (1 + _EDGE) <= p <= tip.upper_limit(mode) / (_CELL * (1 + _EDGE)):
        assert estimate.status == "ok"
    if estimate.status == "ok":
        assert estimate.pressure_pa == back
        # the inferred reading's inverse (compiled where built) is the same inverse
        inferred = inverse.inferred(v, 1.0)
        assert (inferred.status, inferred.pressure_pa) == ("ok", back)


@_settings(100)
@given(kind=st.sampled_from(_FINGERTIPS), mode=st.sampled_from(MODES), j=st.integers(0, _TABLE_P.size - 1))
def test_table_inverse_at_a_node_is_the_node(kind, mode, j):
    p = float(_TABLE_P[j])
    tip = _fingertip(kind)
    assume(tip.detection_limit(mode) < p < tip.upper_limit(mode))
    _, inverse = _table_inverse(kind, mode)
    back = inverse.pressure(_table_output(kind, mode, p))
    assert abs(back - p) <= (abs(math.log(p)) + 1.0) * EPS * p


@_settings(150)
@given(kind=st.sampled_from(_FINGERTIPS), mode=st.sampled_from(MODES), share=st.floats(0.0, 1.0), log_step=st.floats(-9.0, 0.0))
def test_each_mode_falls_with_pressure_and_its_inverse_rises(kind, mode, share, log_step):
    """Steps down to 1e-9 of P: far enough apart for V_1 to differ (|dV_1/d ln P| >= 3e-3 in range)."""
    tip = _fingertip(kind)
    p_lo = _in_range(tip, mode, share)
    p_hi = p_lo * (1 + 10.0**log_step)
    assume(p_hi <= _in_range(tip, mode, 1.0))
    v_lo, v_hi = (float(tip.output(p, mode)) for p in (p_lo, p_hi))
    assert v_lo > v_hi
    est = tip.estimate(np.array([v_lo, v_hi]), mode).pressure_pa
    assert est[0] < est[1]
    _, inverse = _table_inverse(kind, mode)
    t_lo, t_hi = (_table_output(kind, mode, p) for p in (p_lo, p_hi))
    assert t_lo >= t_hi
    assert inverse.pressure(t_lo) <= inverse.pressure(t_hi)


# ---------------------------------------------------------------------------------------
# 4. The geometry's maps.
# ---------------------------------------------------------------------------------------


@st.composite
def pad_geometries(draw) -> PadGeometry:
    element_length = draw(st.floats(1e-3, 2e-2))
    pad_length = element_length * draw(st.sampled_from([1.0, 1.0 + 1e-9, 1.5, 2.67, 10.0]))
    return PadGeometry(segments=draw(st.integers(1, 64)), pad_length_m=pad_length, element_length_m=element_length)


@_settings(200)
@given(geometry=pad_geometries())
def test_the_pad_strips_tile_the_pad_and_the_element(geometry):
    """Strip lengths sum to the pad, the element strips to the element; the edges are their
    running sum, centred on the element (n strips: n roundings of the pad's length)."""
    n = geometry.strip_lengths_m.size
    tol = 2 * n * EPS * geometry.pad_length_m
    edges = geometry.strip_edges_m
    assert np.all(np.diff(edges) > 0)
    np.testing.assert_allclose(np.diff(edges), geometry.strip_lengths_m, rtol=0, atol=tol)
    span = geometry.pad_length_m if geometry.has_guards else geometry.element_length_m
    assert geometry.strip_lengths_m.sum() == pytest.approx(span, abs=tol)
    np.testing.assert_allclose([edges[0], edges[-1]], [-span / 2, span / 2], rtol=0, atol=tol)
    assert geometry.strip_lengths_m[geometry.on_element].sum() == pytest.approx(geometry.element_length_m, abs=tol)
    assert geometry.strip_areas_m2.sum() == pytest.approx(span * geometry.pad_width_m, abs=tol * geometry.pad_width_m)
    np.testing.assert_allclose(geometry.segment_centers_m, -geometry.segment_centers_m[::-1], rtol=0, atol=tol)


_ELEMENT = SensorElement(ElementParams())
_L = _ELEMENT.params.length_m


@st.composite
def coverages_m(draw) -> tuple[float, float]:
    x1 = draw(st.floats(0.0, _L, exclude_max=True))
    x2 = draw(st.floats(x1, _L, exclude_min=True))
    assume(x1 < x2)
    return (x1, x2)


@_settings(200)
@given(segments=st.integers(1, 64), coverage=coverages_m())
def test_coverage_cells_tile_the_coverage_each_under_its_strip(segments, coverage):
    strip_edges = np.linspace(0.0, _L, segments + 1)  # as CoSimulation cuts the element
    edges, index = coverage_cells(strip_edges, coverage)
    assert (edges[0], edges[-1]) == coverage
    assert np.all(np.diff(edges) > 0)
    assert np.sum(np.diff(edges)) == pytest.approx(coverage[1] - coverage[0], rel=0, abs=2 * edges.size * EPS * _L)
    assert np.all(strip_edges[index] <= edges[:-1]) and np.all(edges[1:] <= strip_edges[index + 1])


@_settings(150)
@given(segments=st.integers(1, 64), coverage=coverages_m(), mode=st.sampled_from(MODES))
def test_the_cells_modal_integrals_sum_to_the_coverage(segments, coverage, mode):
    """The per-cell integrals of Z_n^2 / A_L over the coverage cells add up to the coverage's:
    a uniform load sampled per cell is the uniform-load result (Gauss-Legendre to rounding: a few
    ulps of the whole beam's ratio, 1, per cell)."""
    edges, _ = coverage_cells(np.linspace(0.0, _L, segments + 1), coverage)
    total = float(np.sum(_ELEMENT.cell_ratios(mode, edges)))
    assert total == pytest.approx(_ELEMENT.coverage_ratio(mode, coverage), rel=0, abs=8 * edges.size * EPS)


@_settings(150)
@given(geometry=pad_geometries(), coverage=coverages_m(), depth=st.sampled_from([0.0, 5e-3]))
def test_coverage_weights_sum_to_one_and_map_each_cell_to_the_strips_over_it(geometry, coverage, depth):
    """Each cell's weights sum to 1 (a uniform strip pressure reaches it as it is); with no spread
    a weight is the share of the cell under the strip, the strip's z mapped to the element's
    x = L/2 - z (the pad lists strips distal first, the element runs root to tip)."""
    length = geometry.element_length_m
    coverage = (coverage[0] * length / _L, coverage[1] * length / _L)
    # A coverage the scenario config accepts (at least MIN_COVERAGE_MM wide; its cells may be any
    # sliver a strip edge cuts): a 1e-38 m coverage under 5 mm of gel spreads to weights that
    # underflow, which coverage_weights refuses by name.
    assume(coverage[1] - coverage[0] >= MIN_COVERAGE_MM * 1e-3 * length / _L)
    edges, _ = coverage_cells(np.linspace(0.0, length, geometry.segments + 1), coverage)
    weights = coverage_weights(geometry, length, edges, depth)
    assert len(weights) == edges.size - 1
    for row in weights:
        assert all(w > 0 for _, w in row)
        assert sum(w for _, w in row) == pytest.approx(1.0, rel=0, abs=4 * len(row) * EPS)
    if depth:
        return
    z = geometry.strip_edges_m
    for (c1, c2), row in zip(itertools.pairwise(edges), weights, strict=True):
        expected = {}
        for s in range(z.size - 1):
            x_lo, x_hi = length / 2 - z[s + 1], length / 2 - z[s]
            overlap = min(c2, x_hi) - max(c1, x_lo)
            if overlap > 0:
                expected[s] = overlap / (c2 - c1)
        got = dict(row)
        assert set(got) == set(expected)
        for s, w in got.items():
            assert w == pytest.approx(expected[s], rel=0, abs=8 * EPS * length / (c2 - c1))


@_settings(200)
@given(k_e=st.floats(0.0, 1e15), c_e=st.floats(0.0, 1e9), mode=st.sampled_from(MODES), coverage=coverages_m())
def test_normalized_output_is_the_sensed_over_the_unloaded_voltage(k_e, c_e, mode, coverage):
    """Eq. 19's V_1 is eq. 17's |V_s| over eq. 18's V_0: the voltage and its normalized reading
    convert into each other (three roundings each side)."""
    v_s = float(_ELEMENT.output_voltage(k_e, c_e, mode, coverage))
    v_0 = _ELEMENT.unloaded_voltage(mode)
    v_1 = float(_ELEMENT.normalized_output(k_e, c_e, mode, coverage))
    assert v_s / v_0 == pytest.approx(v_1, rel=8 * EPS, abs=0.0)
