"""Over the scenario library, wherever the readout says "ok", the true pressure lies inside its
reported 3-sigma interval (the readout's uncertainty is honest in whole grasps).

One exception is physical, not a tuning matter: the reading taken in the control period in which
the load changes (a touch, a release) still shows the load before it, for Table I's resonator
moves by less than a sigma in one period (tests/test_readout_honesty.py measures this "detection
horizon" at channel level).  Those readings are counted apart and bounded.
"""

import numpy as np
import pytest

from piezotip import scenarios
from piezotip.analysis.runner import run_scenario
from piezotip.cosim.rows import STATUS_CODES

OK = STATUS_CODES.index("ok")
#: A 3-sigma interval covers 99.73 % of a Gaussian error; the readout's error is not exactly
#: Gaussian (its inference windows, a load that drifts within them), so 99 % is the bar, away
#: from load changes and with them (issue 29: a reading taken while the load ramps under it is
#: "settling", sensor/inference.py's RAMP_SUSPECT_CHI2; 98 % with them before).
COVERAGE_STEADY = 0.99
COVERAGE_ALL = 0.99
GROSS_SIGMAS = 10.0
#: Readings within this many control periods of a change of the true pressure larger than the
#: reported 3 sigma are on the detection horizon.
HORIZON_PERIODS = 2
#: The library's grasps whose coverage is pooled (the documented 99.24 %).
POOLED = scenarios.names()


@pytest.fixture(scope="module")
def records(tmp_path_factory):
    return {name: run_scenario(name, [], tmp_path_factory.mktemp(name), plot=False, quiet=True)[1] for name in scenarios.names()}


def readings(data):
    """Per "ok" reading: its error in reported sigmas, and whether it is on a change's horizon."""
    zs, near = [], []
    for side in ("left", "right"):
        ok = data[f"{side}_status"] == OK
        # The truth a fingertip reads is the pressure the gel brings to its coverage (the pad's
        # own pressure differs from it for a contact beside the coverage: sensor/spread.py).
        est, unc, true = (data[f"{side}_{k}"] for k in ("estimate_pa", "uncertainty_pa", "coverage_pressure_pa"))
        change = np.zeros_like(true)
        for k in range(1, HORIZON_PERIODS + 1):
            change[k:] = np.maximum(change[k:], np.abs(true[k:] - true[:-k]))
        zs.append((np.abs(est - true) / unc)[ok])
        near.append((change > 3.0 * unc)[ok])
    return np.concatenate(zs), np.concatenate(near)


@pytest.mark.slow
def test_the_reported_uncertainty_covers_the_truth_over_the_scenario_library(records):
    pairs = [readings(records[name]) for name in POOLED]
    z, near = np.concatenate([p[0] for p in pairs]), np.concatenate([p[1] for p in pairs])
    assert z.size > 5000  # thousands of "ok" readings, light to heavy, every mode
    steady = float(np.mean(z[~near] <= 3.0))
    overall = float(np.mean(z <= 3.0))
    assert steady >= COVERAGE_STEADY, f"3-sigma coverage away from load changes {steady:.4f}"
    assert overall >= COVERAGE_ALL, f"3-sigma coverage {overall:.4f}"
    assert near.mean() < 0.02  # the horizon is a few readings per grasp, not a loophole


@pytest.mark.slow
@pytest.mark.parametrize("name", scenarios.names())
def test_a_grossly_wrong_ok_reading_is_only_ever_the_one_at_a_load_change(records, name):
    z, near = readings(records[name])
    gross = z > GROSS_SIGMAS
    assert not np.any(gross & ~near), f"{name}: {np.sum(gross & ~near)} readings off by more than {GROSS_SIGMAS:g} sigma"
