"""A skin on a hand (examples/shadow_hand_skin.py): piezotip fingertips on the five fingertips of
Gymnasium-Robotics' Shadow Hand, in the hand's own timestep and integrator (Euler at 2 ms), the
hand closed on a ball in a plain ``mj_step`` loop.  Skipped unless the package's hand model is
installed (the optional extra ``hand``).

One run of the example's ``main`` (4 s simulated, its default) into a temporary folder; the tests
read what it wrote.  The thresholds, and where they come from:

* The options: the hand's own but its friction cone (elliptic) and impratio (100), the two the
  grasp needs (the example's docstring: under the hand's pyramidal cone the ball slides out from
  under the fingertips; at its impratio 1 it slides 6 mm/s along them, with or without the
  fingertips, and their loads fall by 20-95 % over the hold).  The period is 5 ms rounded to the
  hand's 2 ms steps: 4 ms.
* The hold: the example's own, from the hand closed, its servos settled (five time constants)
  and one readout inference window on (2.8 s).  Before it the pads stick and slip on the ball
  while the fingers close, and the truth jumps by 17-42 % from one 4 ms period to the next.
* A fingertip holds the ball when its pad touches it (MuJoCo's contacts) at every period of
  the hold and its true pressure stays above mode 1's detection limit: the readout has a load
  to read.  Measured: the first, middle, ring and little finger (26.6-32.1 kPa, each steady
  within 0.5 %); the thumb is pushed off the ball as the fingers close.  At least three must
  hold it (the issue's "a hand closed on an object"; a grasp that loses the ball leaves fewer).
* Every holding fingertip is read: at least 100 "ok" readings each in the hold's 301 periods.  A
  held load reads "ok" 99 % of the time (sensor/inference.py: the change and ramp tests' false
  alarms), less a mode switch's ring-up; a third of the hold leaves room for those and makes 5 %
  five readings, not one.  A load that keeps changing reads "settling" instead, and fails this:
  at the hand's impratio 1 the little finger's load, falling 8-33 %/s as the ball slides, read
  "settling" at all 301 periods and the others 43-104 times.  Measured: 296, 295, 300 and 301.
* >= 95 % of each holding fingertip's "ok" readings hold the truth within 3 sigma (the issue:
  "every touching fingertip within 3 sigma of its true pressure").  The readout promises 99.7 %
  on held loads and 99.3 % with load steps (docs/physics.md); 95 % leaves room for the few
  readings a step still catches, while a pad that chatters fails it by far.  Measured: 100 % of
  each (296, 295, 300 and 301; the largest error 1.5 sigma).
* An untouched fingertip reads no load: not one reading of the hold "ok" or "saturated" (it is
  "below_detection", or "settling" for a period when noise trips the ramp test).  Measured:
  299 below detection, 2 settling.
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
#: The hand's step (reach.xml) and the readout's period on it (5 ms rounded to whole steps).
HAND_TIMESTEP_S = 0.002
PERIOD_S = 0.004
MIN_HOLDING = 3
MIN_OK_READINGS = 100
MIN_COVERAGE = 0.95
COLUMNS = ["pressure_pa", "sigma_pa", "status", "mode", "true_pressure_pa", "touching_ball"]


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


def _options(spec) -> dict:
    option = spec.option
    return {name: np.array(getattr(option, name)) for name in dir(option) if not name.startswith("_")}


def test_the_hand_keeps_its_options_but_the_grasps_friction():
    """The example's scene has the hand's own options (Euler at 2 ms, as reach.xml sets them),
    but the friction cone and impratio the grasp needs."""
    import mujoco

    scene = skin.hand_assets()
    shipped, used = _options(mujoco.MjSpec.from_file(str(scene))), _options(skin.build_scene(scene))
    assert float(shipped["timestep"]) == HAND_TIMESTEP_S
    assert int(shipped["integrator"]) == mujoco.mjtIntegrator.mjINT_EULER
    assert int(shipped["cone"]) == mujoco.mjtCone.mjCONE_PYRAMIDAL and float(shipped["impratio"]) == 1.0
    changed = {name for name in shipped if not np.array_equal(shipped[name], used[name])}
    assert changed == {"cone", "impratio"}
    assert int(used["cone"]) == mujoco.mjtCone.mjCONE_ELLIPTIC and float(used["impratio"]) == 100.0


def test_it_writes_the_readings_and_the_plot(written):
    out, data = written
    periods = round(SECONDS / PERIOD_S)
    assert list(data["fingertips"]) == ["ff", "mf", "rf", "lf", "th"]
    np.testing.assert_allclose(data["time_s"], PERIOD_S * np.arange(1, periods + 1), rtol=0, atol=1e-9)
    for key in COLUMNS:
        assert data[key].shape == (periods, 5), key
    assert list(data["status_names"]) == ["ok", "below_detection", "saturated", "settling"]
    with (out / "readings.csv").open() as handle:
        rows = list(csv.reader(handle))
    assert rows[0] == ["time_s", "fingertip", *COLUMNS]
    assert len(rows) == 1 + 5 * periods
    assert {row[4] for row in rows[1:]} <= set(data["status_names"])
    png = (out / "skin.png").read_bytes()
    assert png.startswith(b"\x89PNG") and len(png) > 50_000  # five panels drawn, not an empty canvas


def test_the_hand_holds_the_ball_with_three_fingertips_or_more(written):
    _, data = written
    holding = _holding(data)
    assert len(holding) >= MIN_HOLDING, f"fingertips holding the ball: {[data['fingertips'][j] for j in holding]}"


def test_every_holding_fingertip_reads_its_truth_within_3_sigma(written):
    _, data = written
    hold = _hold(data)
    for j in _holding(data):
        name = data["fingertips"][j]
        est, sigma, truth = (data[k][hold, j] for k in ("pressure_pa", "sigma_pa", "true_pressure_pa"))
        ok = data["status"][hold, j] == 0
        assert ok.sum() >= MIN_OK_READINGS, f"{name}: {ok.sum()} ok readings in the hold"
        assert np.isfinite(est[ok]).all() and np.isfinite(sigma[ok]).all(), name
        within = np.abs(est[ok] - truth[ok]) <= 3 * sigma[ok]
        assert within.mean() >= MIN_COVERAGE, f"{name}: {within.mean():.1%} of {ok.sum()} ok readings within 3 sigma"


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
    from piezotip.cosim.attach import fingertip_config
    from piezotip.cosim.control.selector import PyModeSelector
    from piezotip.cosim.loop import make_fingertip

    _, data = written
    config = fingertip_config(None, skin.build_scene(skin.hand_assets()).option)  # the fingertip attach made there
    selector = PyModeSelector(make_fingertip(config), config.sensor.modes)
    up_pa = selector.switch_pa[(1, 2)] * (1 + selector.hysteresis)
    for j in _holding(data):
        if data["true_pressure_pa"][-1, j] > up_pa:
            assert data["mode"][-1, j] > 1, data["fingertips"][j]


def test_the_bench_times_the_hand_bare_with_gel_pads_and_with_touch_pads(capsys):
    """``--bench``: the three variants timed side by side; the touch pads add no geometry, so
    the hand with them steps as the bare hand does (its pads' sites only) plus the readout."""
    times = skin.bench(skin.hand_assets(), steps=20, repeats=1)
    assert set(times) == {"bare", "gel", "touch"} and all(t > 0 for t in times.values())
    assert skin.main(["--bench"]) == 0
    assert "touch" in capsys.readouterr().out
