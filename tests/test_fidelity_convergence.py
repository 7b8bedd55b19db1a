"""The reference's convergence: Richardson extrapolation, the observed order, the held window,
the refined reference's settings.  Closed forms only: no co-simulation runs here."""

import math

import numpy as np
import pytest

from piezotip import scenarios
from piezotip.reports.fidelity import (
    HELD_WINDOW_S,
    SAFETY_ASYMPTOTIC,
    SAFETY_NOT_ASYMPTOTIC,
    held_quantities,
    held_window,
    ladder_convergence,
    observed_order,
    richardson,
)
from piezotip.scenarios.presets import PRESETS, REFERENCE_HALVED, reference_refined


@pytest.mark.parametrize("order", [0.7, 1.0, 1.5, 2.0, 4.0])
@pytest.mark.parametrize("ratio", [2.0, 3.0])
def test_richardson_recovers_the_limit_and_order_of_a_power_law(order, ratio):
    """q(h) = L + C h^p at h, h/r, h/r^2: the observed order is p and the extrapolation L."""
    limit, c, h = 2452.5, -37.0, 0.25
    q = [limit + c * (h / ratio**k) ** order for k in range(3)]
    p = observed_order(*q, ratio=ratio)
    assert p == pytest.approx(order, rel=1e-9)
    assert richardson(q[1], q[2], p, ratio=ratio) == pytest.approx(limit, rel=1e-12)
    # The reference's uncertainty: the safety factor times its distance from the limit.
    found = ladder_convergence(q, relative=True, ratio=ratio)
    assert found["asymptotic"]
    assert found["extrapolated"] == pytest.approx(limit, rel=1e-12)
    assert found["uncertainty"] == pytest.approx(SAFETY_ASYMPTOTIC * abs(q[0] - limit) / abs(q[0]), rel=1e-7)
    assert found["halving_change"] == pytest.approx((q[1] - q[0]) / abs(q[0]), rel=1e-12)
    assert found["finest_change"] == pytest.approx((q[2] - q[1]) / abs(q[0]), rel=1e-12)


def test_a_ladder_that_shows_no_order_gets_the_conservative_bound():
    """Changes of opposite signs, a growing change or a very low order: no extrapolation, and
    the uncertainty is 3x the largest departure from the reference's value."""
    for q in ([10.0, 10.2, 10.1], [10.0, 10.1, 10.3], [10.0, 10.1, 10.1 + 0.1 * 2**-0.3]):
        found = ladder_convergence(q)
        assert not found["asymptotic"] and math.isnan(found["extrapolated"])
        assert found["uncertainty"] == pytest.approx(SAFETY_NOT_ASYMPTOTIC * max(abs(q[0] - q[1]), abs(q[0] - q[2])))
    assert math.isnan(observed_order(1.0, 1.0, 2.0)) and math.isnan(observed_order(1.0, 2.0, 1.0))
    assert math.isnan(richardson(1.0, 2.0, math.nan))


def test_an_exactly_converged_quantity_has_no_uncertainty():
    found = ladder_convergence([3.0, 3.0, 3.0], relative=True)
    assert found["uncertainty"] == 0 and found["extrapolated"] == 3.0 and found["asymptotic"]


def _held_run(lift_top_m: float, hold: bool, end_s: float = 4.0, period_s: float = 0.005) -> dict:
    """A recorded run: close, lift (ramp to the top, then settle), hold (or stay in lift when
    the lift sagged too far for the controller's hold), place; constant pressures."""
    t = np.arange(1, round(end_s / period_s) + 1) * period_s
    phase = np.where(t < 1.0, 1.0, np.where(t < 3.0, 3.0, 5.0))
    if hold:
        phase[(t >= 1.6) & (t < 3.0)] = 4.0
    ramp = np.clip((t - 1.0) / 0.5, 0.0, 1.0) * lift_top_m
    settle = np.where(t > 1.5, 2e-3 * np.exp(-(t - 1.5) / 0.03), 0.0)  # the servo's overshoot decaying
    lift = np.where(t < 3.0, ramp + settle, lift_top_m - (t - 3.0) * 0.05)
    values = {
        f"{p}_{c}": np.full(t.size, v)
        for p in ("left", "right")
        for c, v in (("estimate_pa", 2450.0), ("true_pressure_pa", 2452.5), ("v1", 0.4), ("mode", 2.0))
    }
    return {"time_s": t, "phase": phase, "lift_m": lift, **values}


@pytest.mark.parametrize("hold", [True, False])
def test_the_held_window_starts_when_the_lift_settled(hold):
    data = _held_run(0.05, hold)
    window = held_window(data)
    t = data["time_s"][window]
    # The overshoot 2 mm x exp(-s / 30 ms) is below 0.1 mm after 30 ms x ln 20 = 90 ms.
    assert t[0] == pytest.approx(1.5 + 0.03 * math.log(20), abs=0.006)
    assert t[-1] - t[0] == pytest.approx(HELD_WINDOW_S, abs=0.006)
    assert set(data["phase"][window]) <= {3.0, 4.0}
    q = held_quantities(data)
    assert q["true_pressure_pa"] == {"left": 2452.5, "right": 2452.5} and q["mode"]["left"] == 2.0


def test_a_window_cut_short_gives_no_value():
    """An object held for less than most of the window (dropped, or a run cut early) is not compared."""
    data = _held_run(0.05, True, end_s=2.0)
    assert held_window(data).any()
    assert math.isnan(held_quantities(data)["estimate_pa"]["left"])


def test_the_refined_reference_halves_every_step():
    ref = scenarios.get("grasp", [], "reference")
    assert scenarios.get("grasp", list(reference_refined(0))) == ref
    assert REFERENCE_HALVED == reference_refined(1)
    for halvings in (1, 2):
        c = scenarios.get("grasp", list(reference_refined(halvings)))
        factor = 2**halvings
        assert c.physics.timestep_s == pytest.approx(ref.physics.timestep_s / factor, rel=1e-15)
        assert c.physics.pad_segments == ref.physics.pad_segments * factor
        assert c.sensor.carrier_samples_per_cycle == ref.sensor.carrier_samples_per_cycle * factor
        assert c.sensor.dynamics == "carrier" and c.physics.control_period_s == ref.physics.control_period_s
    alone = scenarios.get("grasp", list(reference_refined(1, ("timestep",))))
    assert alone.physics.pad_segments == ref.physics.pad_segments and alone.physics.timestep_s == ref.physics.timestep_s / 2
    assert set(PRESETS) == {"fast", "balanced", "accurate", "reference"}
    with pytest.raises(ValueError, match="knobs"):
        reference_refined(1, ("timestep", "gel"))
    with pytest.raises(ValueError, match="halvings"):
        reference_refined(-1)
