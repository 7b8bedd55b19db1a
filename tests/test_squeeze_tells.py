"""The squeeze lifts only once each fingertip can tell whether its pad feels the grip floor
(cosim/control/multimode.py, :func:`tells_the_floor`; ``controller.squeeze_wait_s``).

At ``balanced`` and ``accurate`` the envelope readout was still "settling" 0.1 s after the touch
in every house scenario, and the lift began then: the squeeze's false-touch check (a fingertip
reading nothing at the floor was alarmed by something else) never ran.  Waiting for readings
that are merely trusted is not enough either: just after the touch's load step the inference's
noise is several readings' worth, and a pad at the floor reads "below detection" (half the time
where the floor sits at the detection limit), which read as a false touch in 5 of 7 scenarios."""

import math

import numpy as np
import pytest

from piezotip import api
from piezotip.cosim.control.multimode import tells_the_floor
from piezotip.cosim.rows import STATUS_CODES
from piezotip.sensor.estimator import mode_tables


def test_only_a_trusted_reading_whose_detection_limit_is_half_the_floor_tells():
    floor_pa = 15.4  # the house pads' grip floor, 6.18 mN over 20 x 20 mm
    assert not tells_the_floor(False, "ok", 1.0, floor_pa)  # settling: the last trusted estimate is held
    assert tells_the_floor(True, "ok", 4.6, floor_pa)
    assert tells_the_floor(True, "saturated", math.nan, floor_pa)
    assert tells_the_floor(True, "below_detection", 0.5 * floor_pa, floor_pa)
    assert not tells_the_floor(True, "below_detection", 0.51 * floor_pa, floor_pa)


@pytest.mark.parametrize("gain", [1.0, 2.5])
def test_a_pad_at_the_floor_is_missed_rarely_by_a_reading_that_tells_and_half_the_time_at_the_limit(gain):
    """Against the readout's own inverse (mode 1, an inferred reading whose noise is ``gain``
    readings'): with the floor at twice the detection limit at that noise (the least
    tells_the_floor accepts), a pad at the floor reads "below detection" about 0.13 % of the
    time (3 sigma over the 3-sigma threshold); with the floor at the limit, about half."""
    tip = api.fingertip("grasp")
    inverse = mode_tables(tip, 1, False)[1]
    limit_pa = inverse.inferred(1.0, gain).uncertainty_pa  # what a below-detection estimate reports
    assert limit_pa == pytest.approx(inverse.p_min_pa * gain)
    rng = np.random.default_rng(7)

    def missed(floor_pa: float) -> float:
        v_floor = float(tip.output(np.array([floor_pa]), 1)[0])
        readings = v_floor + rng.normal(0.0, gain * inverse.sigma, 20000)
        return float(np.mean([inverse.inferred(v, gain).status == "below_detection" for v in readings]))

    assert tells_the_floor(True, "below_detection", limit_pa, 2.0 * limit_pa)
    assert missed(2.0 * limit_pa) < 0.004
    assert 0.35 < missed(limit_pa) < 0.65


def _lift_row(result) -> int:
    phase = np.asarray(result.data["phase"])
    return int(np.nonzero(phase == 3)[0][0])  # Phase.LIFT


@pytest.mark.parametrize("preset", ["balanced", "accurate"])
def test_the_lift_begins_once_every_fingertip_tells_whether_it_feels_the_floor(preset):
    """Before: both fingertips "settling" at the lift's first record, in every house scenario at
    these presets.  Now each one's status there is a trusted one, and no false touch was
    called on a pad that carried the floor."""
    result = api.run("grasp", preset=preset)
    assert result.outcome == "success", result.summary["reason"]
    row = _lift_row(result)
    for side in ("left", "right"):
        status = STATUS_CODES[int(result.data[f"{side}_status"][row])]
        assert status != "settling", (side, status)
        assert result.data[f"{side}_true_pressure_pa"][row] > 0.0  # the pad carries the floor
    assert not [e for e in result.events if e["kind"] in ("false_touch", "touch_unconfirmed")]


def test_past_squeeze_wait_s_the_lift_goes_on_and_says_so():
    result = api.run("grasp", overrides={"controller.squeeze_wait_s": 0.1}, preset="balanced")
    assert result.outcome == "success", result.summary["reason"]
    unconfirmed = [e for e in result.events if e["kind"] == "touch_unconfirmed"]
    assert unconfirmed and "could not tell the grip floor" in unconfirmed[0]["message"]


def test_a_wait_shorter_than_the_settling_is_refused_naming_both():
    with pytest.raises(ValueError, match=r"squeeze_wait_s must be at least controller.squeeze_settle_s \(0.1 s\), got 0.05"):
        api.config("grasp", {"controller.squeeze_wait_s": 0.05})
