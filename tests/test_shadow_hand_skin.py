"""A skin on a hand (examples/shadow_hand_skin.py): piezotip fingertips on the five fingertips of
Gymnasium-Robotics' Shadow Hand, the hand closed on a ball.  Skipped unless the package's hand
model is installed (the optional extra ``hand``).

One run of the example's ``main`` (4 s simulated, its default) into a temporary folder; the tests
read what it wrote.  The thresholds, and where they come from:

* The hold: the example's own, from the hand closed, its servos settled (five time constants)
  and one readout inference window on (2.8 s).  Before it the pads stick and slip on the ball
  while the fingers close, and the truth saws by 20-60 % from one 5 ms period to the next.
* A fingertip holds the ball when its pad touches it (MuJoCo's contacts) at every period of
  the hold and its true pressure stays above mode 1's detection limit: the readout has a load
  to read.  Measured: the first, middle, ring and little finger (3-21 kPa); the thumb is pushed
  off the ball as the fingers close.  At least three must hold it (the task's "a hand closed on
  an object"; a grasp that loses the ball leaves fewer).
* >= 95 % of the holding fingertips' "ok" readings hold the truth within 3 sigma.  The readout
  promises 99.7 % on held loads and 99.3 % with load steps (docs/physics.md); 95 % leaves room
  for the few readings a step still catches, while a hand whose pads chatter fails it by far
  (the hand's own pyramidal friction cone: 14-69 % over the run, the ball lost).  Measured:
  100 % of 289.  At least 100 readings, so that 5 % is five readings, not a single one.
* An untouched fingertip reads no load: not one reading of the hold "ok" or "saturated" (it is
  "below_detection", or "settling" for a period when noise trips the ramp test).  Measured:
  237 below detection, 4 settling.
"""

from __future__ import annotations

import csv
import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "shadow_hand_skin.py"


def _load_example():
    spec = importlib.util.spec_from_file_location("shadow_hand_skin", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up while they are made
    spec.loader.exec_module(module)
    return module


skin = _load_example()
pytestmark = pytest.mark.skipif(skin.hand_assets() is None, reason="Gymnasium-Robotics' Shadow Hand is not installed (the 'hand' extra)")

SECONDS = 4.0
MIN_HOLDING = 3
MIN_COVERAGE = 0.95
MIN_OK_READINGS = 100


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    """The folder the example wrote, and its readings.npz."""
    out = tmp_path_factory.mktemp("shadow-hand")
    assert skin.main(["--out", str(out), "--seconds", str(SECONDS)]) == 0
    with np.load(out / "readings.npz") as npz:
        return out, {key: npz[key] for key in npz.files}


def _hold(data) -> np.ndarray:
    return data["time_s"] >= float(data["hold_from_s"])


def _holding(data) -> list[int]:
    """The fingertips that hold the ball: touching it, and pressed above detection, every period of the hold."""
    hold = _hold(data)
    touching = data["touching_ball"][hold].all(axis=0)
    pressed = (data["true_pressure_pa"][hold] > float(data["detection_limit_pa"])).all(axis=0)
    return np.flatnonzero(touching & pressed).tolist()


def test_it_writes_the_readings_and_the_plot(written):
    out, data = written
    periods = round(SECONDS / 0.005)
    assert list(data["fingertips"]) == ["ff", "mf", "rf", "lf", "th"]
    for key in ("estimate_pa", "sigma_pa", "status", "mode", "voltage_v", "true_pressure_pa", "touching_ball"):
        assert data[key].shape == (periods, 5), key
    assert list(data["status_names"]) == ["ok", "below_detection", "saturated", "settling"]
    with (out / "readings.csv").open() as handle:
        rows = list(csv.reader(handle))
    assert rows[0] == ["time_s", "fingertip", "estimate_pa", "sigma_pa", "status", "mode", "voltage_v", "true_pressure_pa", "touching_ball"]
    assert len(rows) == 1 + 5 * periods
    assert {row[4] for row in rows[1:]} <= set(data["status_names"])
    png = (out / "skin.png").read_bytes()
    assert png.startswith(b"\x89PNG") and len(png) > 50_000  # five panels drawn, not an empty canvas


def test_the_hand_holds_the_ball_with_three_fingertips_or_more(written):
    _, data = written
    holding = _holding(data)
    assert len(holding) >= MIN_HOLDING, f"fingertips holding the ball: {[data['fingertips'][j] for j in holding]}"


def test_ok_readings_of_the_holding_fingertips_hold_the_truth(written):
    _, data = written
    hold, holding = _hold(data), _holding(data)
    est, sigma, truth = (data[k][hold][:, holding] for k in ("estimate_pa", "sigma_pa", "true_pressure_pa"))
    ok = data["status"][hold][:, holding] == 0
    assert ok.any(axis=0).all(), "a holding fingertip never read ok in the hold"
    assert ok.sum() >= MIN_OK_READINGS
    within = np.abs(est[ok] - truth[ok]) <= 3 * sigma[ok]
    assert within.mean() >= MIN_COVERAGE, f"{within.mean():.1%} of {ok.sum()} ok readings within 3 sigma"


def test_untouched_fingertips_read_below_detection(written):
    _, data = written
    hold, holding = _hold(data), set(_holding(data))
    untouched = [j for j in range(5) if j not in holding and not data["touching_ball"][hold, j].any()]
    assert untouched, "every fingertip touches the ball: nothing here checks an untouched one"
    names = list(data["status_names"])
    for j in untouched:
        status = data["status"][hold, j]
        assert not np.isin(status, [names.index("ok"), names.index("saturated")]).any(), data["fingertips"][j]
        assert (status == names.index("below_detection")).mean() > 0.5


def test_loaded_fingertips_are_driven_past_mode_1(written):
    """The mode follows the pressure: a fingertip pressed past the switch pressure from mode 1
    to mode 2 (with the selector's hysteresis) is driven in a stiffer mode by the hold's end."""
    import mujoco

    from piezotip.cosim.attach import fingertip_config
    from piezotip.cosim.control.selector import PyModeSelector
    from piezotip.cosim.loop import make_fingertip

    _, data = written
    option = mujoco.MjSpec().option  # the example's options: the fingertip attach made there
    option.timestep, option.integrator = 0.001, mujoco.mjtIntegrator.mjINT_DISCRETE
    config = fingertip_config(None, option)
    selector = PyModeSelector(make_fingertip(config), config.sensor.modes)
    up_pa = selector.switch_pa[(1, 2)] * (1 + selector.hysteresis)
    for j in _holding(data):
        if data["true_pressure_pa"][-1, j] > up_pa:
            assert data["mode"][-1, j] > 1, data["fingertips"][j]
