"""The build checks (cosim/build_checks.py): run once per buildable configuration."""

from __future__ import annotations

from piezotip import scenarios
from piezotip.cosim import build_checks


def test_the_fingertip_check_is_cached_once_whatever_the_noise_seed():
    """The readout's noise seed builds no other fingertip: a new seed (each Gym reset draws one)
    adds no entry; another unit seed, which does build another unit, does."""
    build_checks._FINGERTIPS.clear()
    for seed in (0, 1, 12345):
        scenarios.get("grasp", [f"sensor.seed={seed}"])
    assert len(build_checks._FINGERTIPS) == 1
    scenarios.get("grasp", ["sensor.variation=typical", "sensor.unit_seed=3"])
    assert len(build_checks._FINGERTIPS) == 2
