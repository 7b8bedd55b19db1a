"""The touch's trade (analysis/touch_trade.py): the force at the touch grows with the closing
speed (about k v t: the pads' contact stiffness, the speed, the loop's reaction time) and shrinks
with the control period, measured on the issue's 2 g wafer from the referee's record."""

from __future__ import annotations

import pytest

from piezotip.analysis import touch_trade


@pytest.fixture(scope="module")
def summary():
    return touch_trade.summarize(touch_trade.touch_trade(speeds_m_s=(0.01, 0.04), periods_s=(0.002, 0.005)))


@pytest.mark.slow
def test_a_faster_closing_touches_harder_and_sooner(summary):
    for period in (0.002, 0.005):
        slow, fast = (next(r for r in summary if r["control_period_s"] == period and r["closing_speed_m_s"] == v) for v in (0.01, 0.04))
        # k v t: four times the speed, a touch at least twice as hard (the detection's own force
        # and the hold's grip are in both), in a quarter of the travel time or so.
        assert fast["median_touch_peak_n"] > 2.0 * slow["median_touch_peak_n"]
        assert fast["median_time_to_touch_s"] < 0.5 * slow["median_time_to_touch_s"]


@pytest.mark.slow
def test_a_shorter_control_period_touches_gentler(summary):
    for v in (0.01, 0.04):
        short, long = (next(r for r in summary if r["control_period_s"] == p and r["closing_speed_m_s"] == v) for p in (0.002, 0.005))
        assert short["median_touch_peak_n"] < long["median_touch_peak_n"]


def test_the_plot_and_the_csv_are_written(tmp_path):
    rows = [
        {
            "closing_speed_m_s": v,
            "control_period_s": 0.005,
            "size_m": 0.03,
            "touch_peak_n": 0.05 * v / 0.01,
            "time_to_touch_s": 0.06 / v,
            "outcome": "success",
            "sim_time_s": 7.0,
        }
        for v in (0.01, 0.02)
    ]
    summary = touch_trade.summarize(rows)
    assert [r["median_touch_peak_n"] for r in summary] == [0.05, 0.1]
    png = touch_trade.plot(summary, tmp_path / "t.png")
    assert png.read_bytes().startswith(b"\x89PNG")
    assert (touch_trade.write_csv(rows, tmp_path / "t.csv")).read_text().splitlines()[0] == ",".join(touch_trade.COLUMNS)
