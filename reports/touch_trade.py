"""The touch's trade, measured: how hard the fingers meet an object against how long they take to.

At the touch the finger force climbs by about k v t: the pads' contact stiffness, the closing
speed, and the time until the fingers stop (the loop's reading, one control period; the drive's
braking) (docs/cosimulation.md, "The touch").  The gentle controller (the default) closes fast
until it nears the width its camera reports, and from ``perception.width_sigma_m`` x
``controller.touch_band_sigmas`` wide of it at the speed that keeps the touch within its bound,
v = (F_touch - F_floor) / (k t_react) (cosim/control/gentle.py).  The keys that move along the
trade:

- ``controller.touch_force_n``, the bound: a harder touch is allowed a faster closing;
- ``physics.control_period_s``: the loop's reaction, t_react = one period + the fingers' stop;
- ``perception.width_sigma_m``: how wide the band closed at the touch speed is (None: no camera,
  the whole stroke).

This runs the default grasp of a light, fragile object over bounds x control periods, and over
the camera's sigma at the default bound, with the multimode controller (20 mm/s all the way, no
camera) for reference, and reads from each run's record the referee's ``touch_peak_n`` (the
largest true finger force from the first contact until the object leaves the table: for a
light object the probe's grip, not the touch's) and ``time_to_touch_s``, and the touch's own
force, ``impact_n``: the largest true finger force from the first contact until the lift
begins (the touch and the squeeze at the grip floor, before the probe's grip).

    python -m piezotip.reports.touch_trade --out out/touch-trade     # touch_trade.csv, .png

The object is the issue's wafer: 2 g, friction 0.39 (its least grip 0.025 N), crushing at
0.05 N.  Each point runs three times, at 29.93, 30 and 30.07 mm (the contact at another phase of
the control period) with the camera's error drawn from seeds 0, 1 and 2 (the band's slow travel
is (3 + z) sigma for an error of z sigma), and the table gives their median and largest.  Runs
are sequential (fifty, about a second each).
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from piezotip.analysis.referee import impact_n  # the touch's own force from a record (the gentle touch's tests read it too)

#: The wafer: the object keys of every run (mass kg, friction, crush force N).
WAFER = {"object.shape": "box", "object.mass_kg": 0.002, "object.friction": 0.39, "object.crush_force_n": 0.05}
#: Each point's runs: (size m, camera seed): the contact at three phases of the control period
#: (0.07 mm is a third of a period's closing at the top speed), three camera errors.
RUNS = ((0.02993, 0), (0.03, 1), (0.03007, 2))
#: The bounds, in grip floors (TOUCH_FLOORS = 3 is the default), and the control periods (s; 5 ms
#: the default).
BOUND_FLOORS = (1.5, 2.0, 3.0, 5.0, 8.0)
CONTROL_PERIODS_S = (0.002, 0.005)
#: The camera's sigmas, m, at the default bound (None: no camera; 1 mm the default).
WIDTH_SIGMAS_M = (0.0005, 0.001, 0.002, None)
#: The longest run, s: without a camera the touch speed closes the whole stroke (about 35 s).
DURATION_S = 60.0
#: The CSV's columns, units in their names.
COLUMNS = (
    "controller",
    "touch_force_n",
    "control_period_s",
    "width_sigma_m",
    "touch_speed_m_s",
    "size_m",
    "seed",
    "impact_n",
    "touch_peak_n",
    "time_to_touch_s",
    "outcome",
    "sim_time_s",
)


def grip_floor_n(overrides: dict) -> float:
    """The grip floor of the default grasp with ``overrides``, N: what the touch bound counts in."""
    from piezotip import scenarios
    from piezotip.cosim.loop import CoSimulation

    return CoSimulation(scenarios.get("grasp", overrides)).controller.grip_floor_n


def touch_speed_m_s(overrides: dict) -> float:
    """The gentle controller's touch speed in the default grasp with ``overrides``, m/s of opening
    (NaN for another controller)."""
    from piezotip import scenarios
    from piezotip.cosim.loop import CoSimulation

    return float(getattr(CoSimulation(scenarios.get("grasp", overrides)).controller, "touch_speed_m_s", math.nan))


def _run(controller: str, bound_n: float | None, period_s: float, sigma_m: float | None, preset: str | None) -> list[dict]:
    import piezotip

    rows = []
    for size, seed in RUNS:
        overrides = {**WAFER, "object.size_m": size, "physics.control_period_s": period_s, "duration_s": DURATION_S}
        if controller == "gentle":
            overrides.update({"perception.width_sigma_m": sigma_m, "perception.seed": seed})
            if bound_n is not None:
                overrides["controller.touch_force_n"] = bound_n
        else:
            overrides["controller.kind"] = controller
        result = piezotip.run("grasp", overrides=overrides, preset=preset)
        s = result.summary
        rows.append(
            {
                "controller": controller,
                "touch_force_n": bound_n if bound_n is not None else math.nan,
                "control_period_s": period_s,
                "width_sigma_m": sigma_m if sigma_m is not None else math.nan,
                "touch_speed_m_s": touch_speed_m_s(overrides),
                "size_m": size,
                "seed": seed,
                "impact_n": impact_n(result.data),
                "touch_peak_n": s["touch_peak_n"],
                "time_to_touch_s": s["time_to_touch_s"],
                "outcome": s["outcome"],
                "sim_time_s": s["sim_time_s"],
            }
        )
    return rows


def touch_trade(
    bound_floors: Sequence[float] = BOUND_FLOORS,
    periods_s: Sequence[float] = CONTROL_PERIODS_S,
    sigmas_m: Sequence[float | None] = WIDTH_SIGMAS_M,
    reference: bool = True,
    preset: str | None = None,
) -> list[dict]:
    """The runs (module docstring), at fidelity ``preset``: the gentle controller at each bound (in
    grip floors) and control period (s) with the default camera; at the default bound and period
    with each other camera sigma (m; None: none); and, with ``reference``, the multimode
    controller at each period."""
    floor = grip_floor_n({})
    rows = []
    for period in periods_s:
        for floors in bound_floors:
            rows += _run("gentle", floors * floor, period, 0.001, preset)
    for sigma in sigmas_m:
        if sigma != 0.001:
            rows += _run("gentle", None, 0.005, sigma, preset)
    if reference:
        for period in periods_s:
            rows += _run("multimode", None, period, None, preset)
    return rows


def write_csv(rows: list[dict], path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=COLUMNS)
        writer.writeheader()
        writer.writerows(rows)
    return path


def summarize(rows: list[dict]) -> list[dict]:
    """Per point (controller, bound, control period, camera sigma): the touch speed (m/s), the
    median and largest impact and touch peak over its runs (N), the median and largest time to
    touch (s), the median whole run (s), and how many of the runs crushed the wafer."""
    out = []

    def key(r: dict) -> tuple:  # NaN (no bound, no camera) as None: NaN equals nothing, not even itself
        bound, sigma = _num(r["touch_force_n"]), _num(r["width_sigma_m"])
        return (r["controller"], None if math.isnan(bound) else bound, r["control_period_s"], None if math.isnan(sigma) else sigma)

    for point in dict.fromkeys(map(key, rows)):
        group = [r for r in rows if key(r) == point]

        def finite(name: str, group: list[dict] = group) -> np.ndarray:
            values = np.array([_num(r[name]) for r in group], float)
            return values[np.isfinite(values)]

        impact, peak, times, total = (finite(name) for name in ("impact_n", "touch_peak_n", "time_to_touch_s", "sim_time_s"))
        out.append(
            {
                "controller": point[0],
                "touch_force_n": _num(point[1]),
                "control_period_s": point[2],
                "width_sigma_m": _num(point[3]),
                "touch_speed_m_s": _num(group[0]["touch_speed_m_s"]),
                "median_impact_n": float(np.median(impact)) if impact.size else math.nan,
                "max_impact_n": float(impact.max()) if impact.size else math.nan,
                "median_touch_peak_n": float(np.median(peak)) if peak.size else math.nan,
                "max_touch_peak_n": float(peak.max()) if peak.size else math.nan,
                "median_time_to_touch_s": float(np.median(times)) if times.size else math.nan,
                "max_time_to_touch_s": float(times.max()) if times.size else math.nan,
                "median_sim_time_s": float(np.median(total)) if total.size else math.nan,
                "crushed": sum(r["outcome"] == "crushed" for r in group),
                "runs": len(group),
            }
        )
    return out


def _num(value) -> float:
    """A number of a row, NaN for None (a JSON null, or no bound or camera)."""
    return math.nan if value is None else float(value)


def plot(summary: list[dict], path: Path) -> Path:
    """The touch's impact (N, median; the runs' largest as a bar) against the time to touch (s,
    median): one line per control period along the bound (each point labelled with its bound and
    touch speed), one along the camera's sigma, the multimode reference as crosses; the wafer's
    crush force drawn across."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 5))
    sigma_points = [r for r in summary if r["controller"] == "gentle" and math.isnan(r["touch_force_n"])]
    lines = [
        (f"bound (controller.touch_force_n), control period {period * 1e3:g} ms", [r for r in summary if _bound_line(r, period)])
        for period in sorted({r["control_period_s"] for r in summary if r["controller"] == "gentle"})
    ]
    default_point = [r for r in summary if _bound_line(r, 0.005) and abs(r["touch_force_n"] / _default_bound(summary) - 1) < 1e-6]
    lines.append(("camera sigma (perception.width_sigma_m), 5 ms", sorted(sigma_points + default_point, key=_sigma_order)))
    for label, line in lines:
        line = [r for r in line if math.isfinite(r["median_impact_n"])]
        if not line:
            continue
        x = [r["median_time_to_touch_s"] for r in line]
        y = [r["median_impact_n"] for r in line]
        up = [r["max_impact_n"] - m for m, r in zip(y, line, strict=True)]
        ax.errorbar(x, y, yerr=[[0.0] * len(y), up], fmt="o-", capsize=3, label=label)
        for r, xi, yi in zip(line, x, y, strict=True):
            ax.annotate(_point_label(r, label), (xi, yi), fontsize=7, xytext=(4, 4), textcoords="offset points")
    for r in (r for r in summary if r["controller"] != "gentle"):
        ax.plot(r["median_time_to_touch_s"], r["median_impact_n"], "kx", ms=8)
        where = (r["median_time_to_touch_s"], r["median_impact_n"])
        ax.annotate(f"{r['controller']}, {r['control_period_s'] * 1e3:g} ms", where, fontsize=7)
    ax.axhline(WAFER["object.crush_force_n"], color="tab:red", ls="--", label="the wafer crushes (0.05 N)")
    ax.set_xlabel("time to touch, s (closing start to first contact; median of 3 runs)")
    ax.set_ylabel("touch impact, N (first contact to the lift's start)")
    ax.set_xscale("log")
    ax.set_yscale("log")
    from matplotlib.ticker import FuncFormatter, NullFormatter

    ax.xaxis.set_major_formatter(FuncFormatter(lambda x, _: f"{x:g}"))
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_xticks([1.5, 2, 3, 5, 10, 20, 40])
    ax.set_title("The touch's trade: a 2 g wafer, the gentle controller (default) and the multimode one")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def _bound_line(r: dict, period: float) -> bool:
    gentle = r["controller"] == "gentle" and r["control_period_s"] == period
    return gentle and math.isfinite(r["touch_force_n"]) and r["width_sigma_m"] == 0.001


def _default_bound(summary: list[dict]) -> float:
    """The bound of the BOUND_FLOORS point nearest the default (3 floors), N: the middle one."""
    bounds = sorted({r["touch_force_n"] for r in summary if math.isfinite(r["touch_force_n"])})
    return bounds[len(bounds) // 2] if bounds else math.nan


def _sigma_order(r: dict) -> float:
    return math.inf if math.isnan(r["width_sigma_m"]) else r["width_sigma_m"]


def _point_label(r: dict, line: str) -> str:
    speed = f"{r['touch_speed_m_s'] * 1e3:.2g} mm/s"
    if line.startswith("camera"):
        sigma = "no camera" if math.isnan(r["width_sigma_m"]) else f"{r['width_sigma_m'] * 1e3:g} mm"
        return f"{sigma}, {speed}"
    return f"{r['touch_force_n'] * 1e3:.3g} mN, {speed}"


def table(summary: list[dict]) -> str:
    """The summary as the docs' Markdown table."""
    lines = [
        "| controller | bound [mN] | control period | camera sigma | touch speed [mm/s] | impact, median (max) [mN] "
        "| touch peak, median [mN] | time to touch, median (max) [s] | whole run [s] | crushed |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in summary:
        bound = "-" if math.isnan(r["touch_force_n"]) else f"{r['touch_force_n'] * 1e3:.3g}"
        sigma = "none" if math.isnan(r["width_sigma_m"]) else f"{r['width_sigma_m'] * 1e3:g} mm"
        speed = "-" if math.isnan(r["touch_speed_m_s"]) else f"{r['touch_speed_m_s'] * 1e3:.3g}"
        lines.append(
            f"| {r['controller']} | {bound} | {r['control_period_s'] * 1e3:g} ms | {sigma} | {speed} "
            f"| {r['median_impact_n'] * 1e3:.3g} ({r['max_impact_n'] * 1e3:.3g}) | {r['median_touch_peak_n'] * 1e3:.3g} "
            f"| {r['median_time_to_touch_s']:.2f} ({r['max_time_to_touch_s']:.2f}) | {r['median_sim_time_s']:.2f} "
            f"| {r['crushed']} of {r['runs']} |"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out/touch-trade", help="folder for touch_trade.csv, touch_trade.png and touch_trade.md")
    parser.add_argument("--preset", help="fidelity preset of every run (default: the scenario's)")
    args = parser.parse_args(argv)
    rows = touch_trade(preset=args.preset)
    summary = summarize(rows)
    out = Path(args.out)
    text = table(summary)
    print(text)
    out.mkdir(parents=True, exist_ok=True)
    (out / "touch_trade.md").write_text(text + "\n")
    for path in (write_csv(rows, out / "touch_trade.csv"), plot(summary, out / "touch_trade.png")):
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
