"""The physical unit (sensor/variation.py): draws, temperature, and the caches' keys.

Independent numbers: a unit's resonance at temperature from a Fingertip built with the moduli
moved by hand (closed form sqrt(EI(T) / EI(25))); the gel's storage modulus at 35 C from the
Prony series with every time divided by the WLF shift computed by hand; the spreads' sizes from
many draws (sample standard deviation against the stated sigma).
"""

import math
from dataclasses import replace

import numpy as np
import pytest
from numpy.testing import assert_allclose

from piezotip.sensor import ElementParams, Fingertip, GelModel, GelParams, SensorElement
from piezotip.sensor.estimator import foundation_table, mode_tables
from piezotip.sensor.gel import modulus_ratio
from piezotip.sensor.variation import (
    PZT_YOUNGS_TC_PER_K,
    SPREADS,
    TITANIUM_YOUNGS_TC_PER_K,
    PhysicalUnit,
    UnitDraw,
    check_temperature,
    draw_unit,
    gel_params_at,
    stiffness_temperature_coefficient,
)

NOMINAL = Fingertip(coverage=(6.5e-3, 7.5e-3))


def test_same_seed_same_unit_and_another_seed_another():
    a, b = draw_unit("typical", 7, 4), draw_unit("typical", 7, 4)
    assert a == b
    assert PhysicalUnit(NOMINAL, a).fingertip_at(25.0).config_key() == PhysicalUnit(NOMINAL, b).fingertip_at(25.0).config_key()
    assert draw_unit("typical", 8, 4) != a
    # a unit's first modes do not depend on how many modes are drawn
    assert draw_unit("typical", 7, 6).freq_factors[:4] == a.freq_factors


def test_variation_none_is_the_nominal_unit():
    unit = PhysicalUnit(NOMINAL, draw_unit("none", 3, 4))
    assert unit.fingertip_at(25.0).config_key() == NOMINAL.config_key()


def test_spreads_are_the_stated_sigmas():
    draws = [draw_unit("wide", s, 2) for s in range(400)]
    spread = SPREADS["wide"]
    # log-normal factors: the log's standard deviation is the spread (400 draws: +-7 % of it at 2 sigma)
    for values, sigma in (
        ([d.gel_modulus_factor for d in draws], spread.gel_modulus),
        ([d.damping_factor for d in draws], spread.damping),
        ([d.freq_factors[0] for d in draws], math.hypot(spread.freq_common, spread.freq_mode)),
    ):
        assert_allclose(np.std(np.log(values)), sigma, rtol=0.1)
    assert_allclose(np.std([d.coverage_offsets_m[0] for d in draws]), spread.coverage_edge_m, rtol=0.1)
    # modes move together: the common part dominates their correlation
    f1, f2 = np.log([d.freq_factors[0] for d in draws]), np.log([d.freq_factors[1] for d in draws])
    assert np.corrcoef(f1, f2)[0, 1] > 0.9


@pytest.mark.parametrize("temperature_c", [-20.0, 5.0, 40.0, 80.0])
def test_resonance_moves_with_the_moduli(temperature_c):
    unit = PhysicalUnit(NOMINAL, draw_unit("typical", 2, 4))
    dt = temperature_c - 25.0
    p = unit.params_25
    by_hand = replace(
        p,
        pzt_youngs_pa=p.pzt_youngs_pa * (1 + PZT_YOUNGS_TC_PER_K * dt),
        substrate_youngs_pa=p.substrate_youngs_pa * (1 + TITANIUM_YOUNGS_TC_PER_K * dt),
    )
    el_t = SensorElement(by_hand, trims=unit.trims)
    el_25 = SensorElement(p, trims=unit.trims)
    for m in (1, 2, 3, 4):
        ratio = el_t.natural_frequency_hz(m) / el_25.natural_frequency_hz(m)
        assert_allclose(unit.fingertip_at(temperature_c).freq_hz(m), el_t.natural_frequency_hz(m), rtol=1e-14)
        assert_allclose(unit.resonance_ratio(temperature_c), ratio, rtol=1e-12)
        assert_allclose(ratio, math.sqrt(by_hand.bending_stiffness_n_m2 / p.bending_stiffness_n_m2), rtol=1e-12)
    # eq. 17's gain goes as Y_p^2
    v_t = el_t.unloaded_voltage(1) * el_t.natural_angular_frequency(1)
    v_25 = el_25.unloaded_voltage(1) * el_25.natural_angular_frequency(1)
    assert_allclose(v_t / v_25, unit.gain_ratio(temperature_c), rtol=1e-12)


def test_pzt_carries_the_bending_stiffness():
    # Table I: the 50 um titanium is 0.2 % of EI, so beta is the PZT's coefficient to 0.5 %
    beta = stiffness_temperature_coefficient(ElementParams())
    assert_allclose(beta, PZT_YOUNGS_TC_PER_K, rtol=0.01)


def test_warm_gel_is_softer_at_the_drive_frequency():
    gel = GelParams()
    warm = gel_params_at(gel, 35.0)
    # WLF by hand: log a_T = -17.44 (T - Tg) / (51.6 + T - Tg), Tg = -55 C
    log_a = -17.44 * 90 / (51.6 + 90) + 17.44 * 80 / (51.6 + 80)
    assert_allclose(warm.prony_tau_s, np.array(gel.prony_tau_s) * 10**log_a, rtol=1e-12)
    assert_allclose(warm.youngs_modulus_pa, gel.youngs_modulus_pa * 308.15 / 298.15, rtol=1e-12)
    f = 3768.0
    storage = lambda g: g.youngs_modulus_pa * modulus_ratio(f, g).real  # noqa: E731
    drop = 1 - storage(warm) / storage(gel)
    assert 0.08 < drop < 0.14  # 11 %: the transition's tail moves out of the band


@pytest.mark.parametrize("bad", [-20.5, 80.1, math.nan, "warm"])
def test_temperature_outside_the_materials_range_is_named(bad):
    with pytest.raises(ValueError, match="temperature_c"):
        check_temperature(bad)


@pytest.mark.parametrize(
    "field, value",
    [
        ("freq_factors", (1.01, 1.0, 1.0, 1.0)),
        ("damping_factor", 1.1),
        ("d31_factor", 1.05),
        ("capacitance_factor", 1.1),
        ("gel_modulus_factor", 1.1),
        ("gel_thickness_factor", 1.02),
        ("coverage_offsets_m", (-5e-5, 0.0)),
    ],
)
def test_config_key_changes_with_each_varied_parameter(field, value):
    base = UnitDraw(freq_factors=(1.0,) * 4)
    unit = PhysicalUnit(NOMINAL, replace(base, **{field: value}))
    tip = unit.fingertip_at(25.0)
    assert tip.config_key() != NOMINAL.config_key()
    # the caches keyed by it hold separate entries for the unit and the nominal model
    assert foundation_table(tip, 1) is not foundation_table(NOMINAL, 1)
    assert mode_tables(tip, 1, False)[1] is not mode_tables(NOMINAL, 1, False)[1]


def test_config_key_changes_with_temperature():
    unit = PhysicalUnit(NOMINAL, draw_unit("none", 0, 4))
    assert unit.fingertip_at(30.0).config_key() != NOMINAL.config_key()
    assert unit.fingertip_at(30.0).config_key() != unit.fingertip_at(30.1).config_key()


def test_gel_factors_reach_the_gel():
    unit = PhysicalUnit(NOMINAL, UnitDraw(freq_factors=(1.0,) * 4, gel_modulus_factor=1.2, gel_thickness_factor=0.9))
    gel = unit.fingertip_at(25.0).gel
    assert isinstance(gel, GelModel)
    assert_allclose(gel.params.youngs_modulus_pa, 1.2 * NOMINAL.gel.params.youngs_modulus_pa)
    assert_allclose(gel.params.thickness_m, 0.9 * NOMINAL.gel.params.thickness_m)
