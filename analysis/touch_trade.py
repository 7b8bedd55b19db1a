"""The touch's trade, measured: how hard the fingers meet an object against how long they take to.

At the touch the finger force climbs by about k v t: the pads' contact stiffness, the closing
speed, and the time until the fingers stop (the readout's detection, the control period, the
drive's braking) (docs/cosimulation.md, "The touch").  The controller's keys move along the
trade: ``controller.closing_speed_m_s`` (v) and ``physics.control_period_s`` (t).  This runs the
default (gentle) grasp of a light, fragile object over a grid of both and reads, from the
referee's record, ``touch_peak_n`` (the largest true finger force from the first contact until
the object leaves the table) and ``time_to_touch_s`` (from the closing's start to the first
contact), with the outcome and the whole run's simulated time.

    python -m piezotip.analysis.touch_trade --out out/touch-trade     # touch_trade.csv, .png

The object is the issue's wafer: 2 g, friction 0.39 (its least grip 0.025 N), crushing at
0.05 N.  Where within a control period the pads meet it decides how long they press on before
the loop reacts, so each point is run at three sizes, 29.93, 30 and 30.07 mm (0.07 mm of width is a third of
each finger's travel over a 5 ms period at the default 20 mm/s: the contact falls at another
phase of the period), and the table gives their median and largest touch.  Runs are
sequential (thirty, a second or two each).
"""

from __future__ import annotations

import argparse
import csv
import sys
from collections.abc import Sequence
from pathlib import Path

#: The wafer: the object keys of every run (mass kg, size m, friction, crush force N).
WAFER = {"object.shape": "box", "object.mass_kg": 0.002, "object.friction": 0.39, "object.crush_force_n": 0.05}
#: Its sizes, m: the contact at three phases of the control period.
SIZES_M = (0.02993, 0.03, 0.03007)
#: The grid: closing speeds (m/s; the default 0.02) and control periods (s; the default 0.005).
CLOSING_SPEEDS_M_S = (0.01, 0.015, 0.02, 0.03, 0.04)
CONTROL_PERIODS_S = (0.002, 0.005)
#: The CSV's columns, units in their names.
COLUMNS = ("closing_speed_m_s", "control_period_s", "size_m", "touch_peak_n", "time_to_touch_s", "outcome", "sim_time_s")


def touch_trade(
    speeds_m_s: Sequence[float] = CLOSING_SPEEDS_M_S, periods_s: Sequence[float] = CONTROL_PERIODS_S, preset: str | None = None
) -> list[dict]:
    """One row per (closing speed m/s, control period s): the referee's touch peak (N), time to
    touch (s), outcome and simulated time (s) of the wafer's grasp (module docstring)."""
    import piezotip

    rows = []
    for period in periods_s:
        for speed in speeds_m_s:
            for size in SIZES_M:
                overrides = {**WAFER, "object.size_m": size, "controller.closing_speed_m_s": speed, "physics.control_period_s": period}
                s = piezotip.run("grasp", overrides=overrides, preset=preset).summary
                rows.append(
                    {
                        "closing_speed_m_s": speed,
                        "control_period_s": period,
                        "size_m": size,
                        "touch_peak_n": s["touch_peak_n"],
                        "time_to_touch_s": s["time_to_touch_s"],
                        "outcome": s["outcome"],
                        "sim_time_s": s["sim_time_s"],
                    }
                )
    return rows


def write_csv(rows: list[dict], path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=COLUMNS)
        writer.writeheader()
        writer.writerows(rows)
    return path


def summarize(rows: list[dict]) -> list[dict]:
    """Per (closing speed, control period): the median and the largest touch peak over the sizes
    (N), the median time to touch (s), and how many of the runs crushed the wafer."""
    import numpy as np

    out = []
    for key in dict.fromkeys((r["closing_speed_m_s"], r["control_period_s"]) for r in rows):
        group = [r for r in rows if (r["closing_speed_m_s"], r["control_period_s"]) == key]
        peaks = np.array([r["touch_peak_n"] for r in group if r["touch_peak_n"] is not None], float)
        times = np.array([r["time_to_touch_s"] for r in group if r["time_to_touch_s"] is not None], float)
        peaks, times = peaks[np.isfinite(peaks)], times[np.isfinite(times)]
        out.append(
            {
                "closing_speed_m_s": key[0],
                "control_period_s": key[1],
                "median_touch_peak_n": float(np.median(peaks)) if peaks.size else None,
                "max_touch_peak_n": float(peaks.max()) if peaks.size else None,
                "min_touch_peak_n": float(peaks.min()) if peaks.size else None,
                "median_time_to_touch_s": float(np.median(times)) if times.size else None,
                "crushed": sum(r["outcome"] == "crushed" for r in group),
                "runs": len(group),
            }
        )
    return out


def plot(summary: list[dict], path: Path) -> Path:
    """The median touch peak (N) against the median time to touch (s), the sizes' range as bars,
    one line per control period, each point labelled with its closing speed; the wafer's crush
    force drawn across."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.5))
    for period in sorted({r["control_period_s"] for r in summary}):
        line = [r for r in summary if r["control_period_s"] == period and r["median_touch_peak_n"] is not None]
        x = [r["median_time_to_touch_s"] for r in line]
        y = [r["median_touch_peak_n"] for r in line]
        err = [
            [m - r["min_touch_peak_n"] for m, r in zip(y, line, strict=True)],
            [r["max_touch_peak_n"] - m for m, r in zip(y, line, strict=True)],
        ]
        ax.errorbar(x, y, yerr=err, fmt="o-", capsize=3, label=f"control period {period * 1e3:g} ms")
        for r, xi, yi in zip(line, x, y, strict=True):
            ax.annotate(f"{r['closing_speed_m_s'] * 1e3:g} mm/s", (xi, yi), fontsize=8, xytext=(4, 4), textcoords="offset points")
    ax.axhline(WAFER["object.crush_force_n"], color="tab:red", ls="--", label="the wafer crushes (0.05 N)")
    ax.set_xlabel("time to touch, s (closing start to first contact; median of 3 sizes)")
    ax.set_ylabel("touch peak, N (first contact to lift-off)")
    ax.set_yscale("log")
    ax.set_title("The touch's trade: a 2 g wafer, the default controller")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out/touch-trade", help="folder for touch_trade.csv and touch_trade.png")
    parser.add_argument("--preset", help="fidelity preset of every run (default: the scenario's)")
    args = parser.parse_args(argv)
    rows = touch_trade(preset=args.preset)
    summary = summarize(rows)
    out = Path(args.out)
    print(f"{'speed mm/s':>10} {'period ms':>9} {'touch peak N: median':>20} {'max':>7} {'to touch s':>10}  crushed")
    for r in summary:
        peak = (
            f"{r['median_touch_peak_n']:20.4f} {r['max_touch_peak_n']:7.4f}"
            if r["median_touch_peak_n"] is not None
            else f"{'-':>20} {'-':>7}"
        )
        to = f"{r['median_time_to_touch_s']:10.3f}" if r["median_time_to_touch_s"] is not None else f"{'-':>10}"
        print(f"{r['closing_speed_m_s'] * 1e3:10g} {r['control_period_s'] * 1e3:9g} {peak} {to}  {r['crushed']} of {r['runs']}")
    for path in (write_csv(rows, out / "touch_trade.csv"), plot(summary, out / "touch_trade.png")):
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
