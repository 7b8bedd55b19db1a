"""The touch's trade (reports/touch_trade.py): the force at the touch grows with the bound the
gentle controller keeps it within (about k v t: the pads' contact stiffness, the closing speed the
bound sets, the loop's reaction time), the time to touch shrinks with it and with the control
period, measured on the issue's 2 g wafer from the referee's record."""

from __future__ import annotations

import math

import pytest

from piezotip.reports import touch_trade


@pytest.fixture(scope="module")
def summary():
    rows = touch_trade.touch_trade(bound_floors=(2.0, 5.0), periods_s=(0.002, 0.005), sigmas_m=(), reference=False)
    return touch_trade.summarize(rows)


@pytest.mark.slow
def test_a_harder_bound_touches_harder_and_sooner_and_within_itself(summary):
    for period in (0.002, 0.005):
        gentle, hard = sorted((r for r in summary if r["control_period_s"] == period), key=lambda r: r["touch_force_n"])
        assert hard["median_impact_n"] > gentle["median_impact_n"]
        assert hard["median_time_to_touch_s"] < gentle["median_time_to_touch_s"]
        for r in (gentle, hard):
            assert r["max_impact_n"] <= r["touch_force_n"] and r["crushed"] == 0


@pytest.mark.slow
def test_a_shorter_control_period_closes_faster_at_the_same_bound(summary):
    bounds = sorted({r["touch_force_n"] for r in summary})
    for bound in bounds:
        short, long = (next(r for r in summary if r["touch_force_n"] == bound and r["control_period_s"] == p) for p in (0.002, 0.005))
        assert short["touch_speed_m_s"] > 1.5 * long["touch_speed_m_s"]
        assert short["median_time_to_touch_s"] < long["median_time_to_touch_s"]


def test_the_plot_the_table_and_the_csv_are_written(tmp_path):
    def row(controller, bound, sigma, speed, impact, to_touch):
        return {
            "controller": controller,
            "touch_force_n": bound,
            "control_period_s": 0.005,
            "width_sigma_m": sigma,
            "touch_speed_m_s": speed,
            "size_m": 0.03,
            "seed": 0,
            "impact_n": impact,
            "touch_peak_n": 0.03,
            "time_to_touch_s": to_touch,
            "outcome": "success",
            "sim_time_s": 7.0,
        }

    rows = [
        row("gentle", 0.0124, 0.001, 0.0007, 0.009, 5.8),
        row("gentle", 0.0185, 0.001, 0.0014, 0.012, 3.6),
        row("gentle", 0.0309, 0.001, 0.0028, 0.018, 2.5),
        row("gentle", math.nan, None, 0.0014, 0.009, 42.0),
        row("multimode", None, None, math.nan, 0.12, 3.05),
    ]
    summary = touch_trade.summarize(rows)
    assert [r["median_impact_n"] for r in summary] == [0.009, 0.012, 0.018, 0.009, 0.12]
    assert math.isnan(summary[3]["width_sigma_m"]) and math.isnan(summary[4]["touch_force_n"])
    png = touch_trade.plot(summary, tmp_path / "t.png")
    assert png.read_bytes().startswith(b"\x89PNG")
    text = touch_trade.table(summary)
    assert text.count("\n") == len(summary) + 1 and "| gentle | 18.5 | 5 ms | 1 mm | 1.4 | 12 (12) |" in text
    assert (touch_trade.write_csv(rows, tmp_path / "t.csv")).read_text().splitlines()[0] == ",".join(touch_trade.COLUMNS)
