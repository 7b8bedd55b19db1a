"""Grasp experiments across objects and controllers (``run_sim.py experiment grasp-range``).

Every object of :data:`OBJECTS` is grasped by the multimode controller and by each
single-mode baseline (``controller.modes=[n]``), with the same controller code and settings
(never tuned per object).  Each run's outcome is judged by :mod:`analysis.run_report`;
the table says, per object and controller: success, peak and held pressure, the time from
first contact to detected touch, mode switches, crushed, slipped, and why a run failed.
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .plotting import new_figure, save_figure
from .runner import json_safe


@dataclass(frozen=True)
class TestObject:
    """One object of the set: a name and its ``--set`` overrides."""

    name: str
    overrides: tuple[str, ...]


#: From about 1 g to 10 kg, two of them fragile.
OBJECTS: tuple[TestObject, ...] = (
    TestObject("tissue-box-1g", ("object.shape=box", "object.mass_kg=0.001", "object.size_m=0.03", "object.friction=0.6")),
    TestObject("cube-3g", ("object.shape=box", "object.mass_kg=0.003", "object.size_m=0.02", "object.friction=0.8")),
    # A ripe raspberry crushes at 1-2 N of squeeze between flat plates; 1.5 N here.
    TestObject(
        "raspberry-4g",
        ("object.shape=sphere", "object.mass_kg=0.004", "object.size_m=0.02", "object.friction=0.9", "object.crush_force_n=1.5"),
    ),
    TestObject(
        "egg-60g",
        ("object.shape=egg", "object.mass_kg=0.06", "object.size_m=0.044", "object.friction=0.6", "object.crush_force_n=25.0"),
    ),
    TestObject("box-100g", ("object.shape=box", "object.mass_kg=0.1", "object.size_m=0.04", "object.friction=1.0")),
    TestObject("can-500g", ("object.shape=cylinder", "object.mass_kg=0.5", "object.size_m=0.06", "object.friction=1.0")),
    TestObject("block-2kg", ("object.shape=box", "object.mass_kg=2.0", "object.size_m=0.06", "object.friction=1.0")),
    TestObject("block-10kg", ("object.shape=box", "object.mass_kg=10.0", "object.size_m=0.08", "object.friction=1.0")),
)

#: The controllers compared: the multimode one and each mode alone.
CONTROLLERS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("multimode", ("controller.modes=[1, 2, 3, 4]",)),
    ("mode 1 only", ("controller.modes=[1]",)),
    ("mode 2 only", ("controller.modes=[2]",)),
    ("mode 3 only", ("controller.modes=[3]",)),
    ("mode 4 only", ("controller.modes=[4]",)),
)

COLUMNS = (
    "object",
    "controller",
    "success",
    "crushed",
    "slipped",
    "lifted",
    "peak_pressure_pa",
    "held_pressure_pa",
    "touch_latency_s",
    "mode_switches",
    "peak_grip_force_n",
    "why",
)


def why_failed(row: dict, events: list[dict]) -> str:
    """A short reason for a failed run, from the outcome and the controller's events."""
    if row["success"]:
        return ""
    reasons = []
    if row["crushed"]:
        reasons.append("crushed")
    kinds = {e["kind"]: e["message"] for e in events}
    for kind in ("self_test", "out_of_range", "no_object", "blind", "lost", "saturated"):
        if kind in kinds:
            reasons.append(f"{kind}: {kinds[kind]}")
    if row["slipped"]:
        reasons.append("slipped")
    if not row["lifted"]:
        reasons.append("not lifted")
    return "; ".join(reasons) or "hold not completed"


def run_grid(run_one, objects=OBJECTS, controllers=CONTROLLERS, base_overrides: tuple[str, ...] = (), progress=None) -> list[dict]:
    """Run every (object, controller); ``run_one(overrides) -> (summary dict, data dict)``."""
    rows = []
    for obj in objects:
        for ctrl_name, ctrl_overrides in controllers:
            summary, data = run_one([*base_overrides, *obj.overrides, *ctrl_overrides])
            held = data["phase"] == 4.0 if data else np.zeros(0, bool)
            pads = [k.removesuffix("_true_pressure_pa") for k in data if k.endswith("_true_pressure_pa")] if data else []
            true_p = np.max([data[f"{p}_true_pressure_pa"] for p in pads], axis=0) if pads else np.zeros(0)
            contact = np.nonzero(true_p > 0.5)[0]
            contact_t = float(data["time_s"][contact[0]]) if contact.size else math.nan
            touch_t = summary.get("touch_time_s", math.nan)
            row = {
                "object": obj.name,
                "controller": ctrl_name,
                "success": summary["success"],
                "crushed": summary["crushed"],
                "slipped": summary["slipped"],
                "lifted": summary["lifted"],
                "peak_pressure_pa": summary["max_pressure_pa"],
                "held_pressure_pa": float(np.mean(true_p[held])) if held.any() else math.nan,
                "touch_latency_s": touch_t - contact_t if math.isfinite(touch_t) and math.isfinite(contact_t) else math.nan,
                "mode_switches": summary["mode_switches"],
                "peak_grip_force_n": summary["peak_grip_force_n"],
            }
            row["why"] = why_failed(row, summary.get("events", []))
            rows.append(row)
            if progress is not None:
                progress.update(1)
    return rows


def format_table(rows: list[dict]) -> str:
    """The experiment's table as text."""
    head = f"{'object':<16} {'controller':<12} {'ok':<3} {'peak P [Pa]':>11} {'held P [Pa]':>11} {'touch [ms]':>10} {'switch':>6}  why"
    lines = [head, "-" * len(head)]
    for r in rows:
        touch = 1e3 * r["touch_latency_s"] if math.isfinite(r["touch_latency_s"]) else math.nan
        lines.append(
            f"{r['object']:<16} {r['controller']:<12} {'yes' if r['success'] else 'NO':<3} {r['peak_pressure_pa']:>11.3g}"
            f" {r['held_pressure_pa']:>11.3g} {touch:>10.1f} {r['mode_switches']:>6}  {r['why']}"
        )
    return "\n".join(lines)


def write_outputs(rows: list[dict], out_dir: Path) -> list[Path]:
    """grasp_range.csv, grasp_range.json and grasp_range.png (success matrix and peak pressures)."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    csv_path = out_dir / "grasp_range.csv"
    with csv_path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=COLUMNS)
        writer.writeheader()
        writer.writerows(rows)
    json_path = out_dir / "grasp_range.json"
    units = {"peak_pressure_pa": "Pa", "held_pressure_pa": "Pa", "touch_latency_s": "s", "peak_grip_force_n": "N"}
    json_path.write_text(json.dumps(json_safe({"units": units, "rows": rows}), indent=2) + "\n")
    objects = list(dict.fromkeys(r["object"] for r in rows))
    controllers = list(dict.fromkeys(r["controller"] for r in rows))
    grid = np.zeros((len(objects), len(controllers)))
    peak = np.full((len(objects), len(controllers)), np.nan)
    for r in rows:
        i, j = objects.index(r["object"]), controllers.index(r["controller"])
        # green: success; yellow: lifted but the hold failed; red: not lifted or crushed
        grid[i, j] = 1.0 if r["success"] else (0.5 if r["lifted"] and not r["crushed"] else 0.0)
        peak[i, j] = r["peak_pressure_pa"]
    fig, axes = new_figure(1, 2, figsize=(14, 5.5))
    ax, ax_p = axes[0]
    ax.imshow(grid, cmap="RdYlGn", vmin=0, vmax=1, aspect="auto")
    for r in rows:
        i, j = objects.index(r["object"]), controllers.index(r["controller"])
        label = "ok" if r["success"] else ("crushed" if r["crushed"] else ("slipped" if r["slipped"] else "fail"))
        ax.text(j, i, label, ha="center", va="center", fontsize=8)
    ax.set_xticks(range(len(controllers)), controllers, rotation=20)
    ax.set_yticks(range(len(objects)), objects)
    ax.set_title("grasp outcome (green: success, red: failed or crushed)")
    for j, c in enumerate(controllers):
        ax_p.semilogy(range(len(objects)), peak[:, j], "o-", label=c)
    ax_p.set_xticks(range(len(objects)), objects, rotation=30)
    ax_p.set(ylabel="peak pressure on the element [Pa]", title="peak pressure per object")
    ax_p.grid(True, which="both", alpha=0.3)
    ax_p.legend(fontsize=8)
    png = save_figure(fig, out_dir / "grasp_range.png")
    return [csv_path, json_path, png]
