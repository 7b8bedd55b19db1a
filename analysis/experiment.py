"""Grasp experiments across objects and controllers (``run_sim.py experiment grasp-range``).

Every object of the catalogue (:data:`scenarios.objects.OBJECTS`: 1 g to 10 kg, crush limits
from 0.1 N, friction 0.3 to 1.2) is grasped by each controller registered for the experiment
(:mod:`piezotip.controllers`: the multimode one and the gentle one) with every mode, and by the
default controller's single-mode baselines (``controller.modes=[n]``), with the same controller
code and settings (never tuned per object).  The user's ``--set`` overrides apply to every run, after the
object's and the controller's.  Each run is judged by the referee (:mod:`analysis.referee`);
the table says, per object and controller: the outcome and its reason, peak and held pressure,
the time from first contact to detected touch and which sense felt it (the fingertips or the
finger joints), mode switches, the peak grip, the grip economy, the touch (the largest finger
force from the first contact to lift-off, and the time from the start of closing to the first
contact), whether the run left the model's valid range, and whether the gripper could
physically do it at all.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .plotting import save_figure
from .referee import needed_grip_n
from .runner import json_safe
from .sweep import SweepRun
from .sweep_output import OUTCOME_COLOUR
from .sweep_rows import GRIP_ECONOMY_COLUMNS, TOUCH_COLUMNS


@dataclass(frozen=True)
class TestObject:
    """One object of the set: a name and its ``--set`` overrides."""

    name: str
    overrides: tuple[str, ...]


def _objects() -> tuple[TestObject, ...]:
    from piezotip.scenarios import OBJECTS, object_overrides

    return tuple(TestObject(name, tuple(object_overrides(name))) for name in OBJECTS)


#: The catalogue's objects, as overrides.
OBJECTS: tuple[TestObject, ...] = _objects()


def experiment_controllers() -> tuple[tuple[str, tuple[str, ...]], ...]:
    """The controllers compared, as (label, overrides): each registered for the experiment
    (``piezotip.controllers.register(..., experiment=True)``: the multimode one, the gentle one)
    with every mode of the grasp scenario's sensor, then the scenario's own controller with each
    mode alone ("mode n only").  A kind is named only where it is not the scenario's own, so the
    overrides (which key each run's folder and record) are those the experiment always gave."""
    from piezotip import scenarios
    from piezotip.cosim.control import registry as controllers

    grasp = scenarios.get("grasp")
    every = f"controller.modes={list(grasp.sensor.modes)}"
    compared = [
        (name, (every,) if name == grasp.controller.kind else (f"controller.kind={name}", every))
        for name in controllers.names()
        if controllers.get(name).experiment
    ]
    baselines = [(f"mode {mode} only", (f"controller.modes={[mode]}",)) for mode in grasp.sensor.modes]
    return (*compared, *baselines)


def pass_rule_controllers() -> tuple[str, ...]:
    """The controllers held to the experiment's pass rule (a success exactly where the gripper
    can carry the object): those registered for the experiment, by their labels in its rows."""
    from piezotip.cosim.control import registry as controllers

    return tuple(name for name in controllers.names() if controllers.get(name).experiment)


def passes(rows) -> bool:
    """The experiment's pass rule: every controller held to it (:func:`pass_rule_controllers`)
    succeeds on exactly the objects the gripper can carry (``feasible``), and on no other."""
    held = pass_rule_controllers()
    return all(r["success"] == r["feasible"] for r in rows if r["controller"] in held)


def __getattr__(name: str):
    # CONTROLLERS: the registry's experiment controllers as they are now (one registered after
    # this module was imported is in it).
    if name == "CONTROLLERS":
        return experiment_controllers()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


COLUMNS = (
    "object",
    "controller",
    "outcome",
    "reason",
    "success",
    "feasible",
    "crushed",
    "slipped",
    "lifted",
    "peak_pressure_pa",
    "held_pressure_pa",
    "touch_latency_s",
    "touch_sense",
    "mode_switches",
    "peak_grip_force_n",
    *GRIP_ECONOMY_COLUMNS,
    *TOUCH_COLUMNS,
    "outside_model",
)


@functools.cache
def gripper() -> tuple[float, float]:
    """(the fingers' force limit, N per finger; gravity, m/s^2) as the gripper's model has them
    (one model for every object: the gripper does not change with what it grasps): the house
    gripper's :func:`gripper_limits`."""
    from piezotip import scenarios

    limit_n, gravity, _ = gripper_limits(scenarios.get("grasp"))
    return limit_n, gravity


def gripper_limits(config) -> tuple[float, float, float]:
    """(the fingers' force limit, N per finger; gravity, m/s^2; the widest object its open pads
    take, m) of ``config``'s gripper: the house's, or the one its ``gripper.*`` keys mount
    (:func:`cosim.assembly.gripper_ranges`: robosuite's Panda is rated 20 N and takes 64 mm)."""
    from piezotip.cosim.assembly import gripper_ranges

    ranges = gripper_ranges(config)
    return ranges.finger_force_limit_n, ranges.gravity_m_s2, ranges.widest_object_m


def feasible(
    obj, finger_force_limit_n: float | None = None, gravity_m_s2: float | None = None, widest_object_m: float | None = None
) -> tuple[bool, str]:
    """Whether any controller could carry ``obj``: it must fit between the open pads (where
    ``widest_object_m``, m, is given), and holding its weight needs m g / (2 mu) per finger,
    which must fit under the fingers' force limit and the object's crush limit (the limit and g
    default to the gripper model's: :func:`gripper`)."""
    if widest_object_m is not None and obj.size_m > widest_object_m:
        return False, f"{1e3 * obj.size_m:.3g} mm wide, past the {1e3 * widest_object_m:.3g} mm the gripper's open pads take"
    if finger_force_limit_n is None or gravity_m_s2 is None:
        limit_n, g = gripper()
        finger_force_limit_n = limit_n if finger_force_limit_n is None else finger_force_limit_n
        gravity_m_s2 = g if gravity_m_s2 is None else gravity_m_s2
    need = needed_grip_n(obj.mass_kg, obj.friction, gravity_m_s2)
    limit = min(finger_force_limit_n, obj.crush_force_n if obj.crush_force_n is not None else math.inf)
    if need <= limit:
        return True, ""
    return False, f"holding it needs {need:.3g} N per finger, over the {limit:.3g} N allowed"


def experiment_points(objects=None, controllers=None, base_overrides: tuple[str, ...] = ()) -> list:
    """A sweep point per (object, controller), labelled by both (``controllers``: as
    :func:`experiment_controllers` gives them, which None takes).

    ``base_overrides`` (the user's ``--set``) come last, so they win over the object's and the
    controller's own settings.
    """
    from .sweep_grid import Point

    objects = OBJECTS if objects is None else objects
    controllers = experiment_controllers() if controllers is None else controllers
    return [
        Point({"object": obj.name, "controller": ctrl_name}, (*obj.overrides, *ctrl_overrides, *base_overrides), f"{obj.name}, {ctrl_name}")
        for obj in objects
        for ctrl_name, ctrl_overrides in controllers
    ]


def experiment_row(row: dict, limits: tuple[float, float, float] | None = None, planned=None) -> dict:
    """A sweep row as a row of the experiment's table (:data:`COLUMNS`), with the gripper's
    feasibility for the object that was simulated (after every override; ``planned``, the
    point's ObjectConfig, where the run raised before it said): the house gripper's, or
    ``limits``' (:func:`gripper_limits`: a mounted gripper's).  An object wider than the
    gripper's open pads, which the mount refuses (the sweep's ``error``), is ``does_not_fit``."""
    from piezotip.scenarios.config import ObjectConfig

    ok, why_not, fits = True, "", True
    simulated = planned
    if row.get("object_config"):
        simulated = ObjectConfig(**{k: row["object_config"][k] for k in ("shape", "mass_kg", "size_m", "friction", "crush_force_n")})
    if simulated is not None:
        ok, why_not = feasible(simulated, *(limits or ()))
        fits = limits is None or simulated.size_m <= limits[2]
    return {
        "object": row["object"],
        "controller": row["controller"],
        "outcome": "does_not_fit" if not fits and row["outcome"] == "error" else row["outcome"],
        "reason": row["reason"] + (f" (infeasible: {why_not})" if not ok else ""),
        "success": row["success"],
        "feasible": ok,
        "crushed": row["crushed"],
        "slipped": row["slipped"],
        "lifted": row["lifted"],
        "peak_pressure_pa": row["max_pressure_pa"],
        "held_pressure_pa": row["held_pressure_pa"],
        "touch_latency_s": row["touch_latency_s"],
        "touch_sense": row.get("touch_sense") or "",
        "mode_switches": row["mode_switches"],
        "peak_grip_force_n": row["peak_grip_force_n"],
        **{key: row.get(key, math.nan) for key in (*GRIP_ECONOMY_COLUMNS, *TOUCH_COLUMNS)},
        "outside_model": row["outside_model"],
    }


def run_experiment(
    preset: str | None = None,
    base_overrides: tuple[str, ...] = (),
    out: Path | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: bool = True,
    options: dict | None = None,
    objects=None,
    controllers=None,
) -> SweepRun:
    """Every (object, controller) on the sweep machinery (:func:`analysis.sweep.run_points`:
    Dask, resumable from ``out``); each run's files in ``out/runs/NN``.  The result's rows are
    the experiment's (:func:`experiment_row`), its ``skipped`` the runs found done in ``out``."""
    from piezotip import scenarios

    from .sweep import run_points

    points = experiment_points(objects, controllers, base_overrides)
    result = run_points(
        "grasp", points, preset, out, workers, scheduler, progress, keep_runs=out is not None, desc="grasp-range", options=options
    )
    limits = gripper_limits(scenarios.get("grasp", list(base_overrides), preset))  # the gripper the runs had
    planned = {point.values["object"]: point for point in points}  # an object's overrides are every controller's
    objects_of = {name: scenarios.get("grasp", list(point.overrides), preset).object for name, point in planned.items()}
    return dataclasses.replace(result, rows=[experiment_row(r, limits, objects_of.get(r["object"])) for r in result.rows])


def experiment_provenance(preset: str | None = None, base_overrides: tuple[str, ...] = (), objects=None, controllers=None) -> dict:
    """What the experiment's tables carry (:mod:`piezotip.provenance`): the versions; the seeds
    and the config of the grasp scenario with the preset and the user's overrides; and each
    object's and controller's overrides (a row's run is that config with its object's, then its
    controller's, then the user's overrides applied: :func:`experiment_points`)."""
    from piezotip import scenarios
    from piezotip.runtime.provenance import config_provenance

    objects = OBJECTS if objects is None else objects
    controllers = experiment_controllers() if controllers is None else controllers
    return {
        "experiment": "grasp-range",
        "scenario": "grasp",
        "preset": preset,
        "overrides": list(base_overrides),
        "objects": {obj.name: list(obj.overrides) for obj in objects},
        "controllers": {name: list(overrides) for name, overrides in controllers},
        **config_provenance(scenarios.get("grasp", list(base_overrides), preset)),
    }


def format_table(rows: list[dict]) -> str:
    """The experiment's table as text."""
    head = (
        f"{'object':<16} {'controller':<12} {'outcome':<12} {'peak P [Pa]':>11} {'held [N]':>8} {'needs [N]':>9} {'margin':>6}"
        f" {'peak [N]':>8} {'touch [N]':>9} {'to touch [s]':>12} {'touch [ms]':>10} {'by':<9} {'sw':>3}  reason"
    )
    lines = [head, "-" * len(head)]
    for r in rows:
        touch = 1e3 * r["touch_latency_s"] if math.isfinite(r["touch_latency_s"]) else math.nan
        flag = " [outside model]" if r["outside_model"] else ""
        lines.append(
            f"{r['object']:<16} {r['controller']:<12} {r['outcome']:<12} {r['peak_pressure_pa']:>11.3g} {r['hold_grip_n']:>8.3g}"
            f" {r['needed_grip_n']:>9.3g} {r['grip_margin']:>6.2f} {r['peak_contact_n']:>8.3g} {r['touch_peak_n']:>9.3g}"
            f" {r['time_to_touch_s']:>12.3f} {touch:>10.1f} {r.get('touch_sense') or '-':<9} {r['mode_switches']:>3}  {r['reason']}{flag}"
        )
    return "\n".join(lines)


def write_outputs(
    rows: list[dict], out_dir: Path, plot: bool = True, aim: ControllerAim | None = None, provenance: dict | None = None
) -> list[Path]:
    """grasp_range.csv, grasp_range.json and (with ``plot``) grasp_range.png (outcome matrix and
    peak pressures; ``aim``: the grip margin the experiment's controller aims at, as
    :func:`experiment_figure` takes it).  ``provenance`` (:func:`experiment_provenance`; None:
    the versions alone) heads both tables: the CSV's ``# `` lines, the JSON's keys."""
    from piezotip.runtime.provenance import csv_header, versions

    from .sweep_output import write_csv_rows

    provenance = {"versions": versions()} if provenance is None else provenance
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    csv_path = out_dir / "grasp_range.csv"
    with csv_path.open("w", newline="") as fh:
        fh.write(csv_header(provenance, "piezotip experiment grasp-range"))
        write_csv_rows(fh, COLUMNS, [[r.get(c) for c in COLUMNS] for r in rows])
    json_path = out_dir / "grasp_range.json"
    units = {
        "peak_pressure_pa": "Pa",
        "held_pressure_pa": "Pa",
        "touch_latency_s": "s",
        "touch_sense": "which sense felt the touch: fingertip, joints, or empty (no touch)",
        "peak_grip_force_n": "N",
        "hold_grip_n": "N",
        "needed_grip_n": "N",
        "grip_margin": "hold_grip_n / needed_grip_n",
        "contact_tilt_deg": "deg (the fingers' contacts' tilt below the horizontal while held; the need is read on it)",
        "peak_contact_n": "N",
        "touch_peak_n": "N (the largest true finger force from the first contact until the object leaves the table)",
        "time_to_touch_s": "s (from the start of closing to the first true contact)",
    }
    json_path.write_text(json.dumps(json_safe({"units": units, **provenance, "rows": rows}), indent=2) + "\n")
    if not plot:
        return [csv_path, json_path]
    png = save_figure(experiment_figure(rows, aim), out_dir / "grasp_range.png")
    return [csv_path, json_path, png]


#: The bound issue 43 sets on the hold grip (within 1.5x the grip that holds the object), drawn
#: on the plot as a bound: no controller aims at it (:func:`controller_aim` says what they aim at).
MARGIN_BOUND = 1.5
#: MARGIN_BOUND's earlier name (it was drawn as "the target").
TARGET_MARGIN = MARGIN_BOUND


@dataclass(frozen=True)
class ControllerAim:
    """The grip margin a controller aims its hold at: ``kind`` (``controller.kind``) and
    ``margin`` (hold grip over the grip that holds the object, -)."""

    kind: str
    margin: float


def controller_aim(controller) -> ControllerAim | None:
    """What ``controller`` (a scenario's controller config) aims its hold at: its
    ``grip_safety``, the factor over the friction limit it holds with once it has the friction
    (the gentle controller measures it within -2 to +6 %, so it holds at 1.2-1.4x with the default
    1.25); None for a controller with no such factor (a fixed grip)."""
    safety = getattr(controller, "grip_safety", None)
    return None if safety is None else ControllerAim(controller.kind, float(safety))


def default_aim() -> ControllerAim | None:
    """:func:`controller_aim` of the grasp scenario's own controller, as registered."""
    from piezotip import scenarios

    return controller_aim(scenarios.get("grasp").controller)


def _grid(rows: list[dict], key: str) -> tuple[list[str], list[str], np.ndarray]:
    """(objects, controllers, the rows' ``key`` as an objects x controllers array, NaN where missing)."""
    objects = list(dict.fromkeys(r["object"] for r in rows))
    controllers = list(dict.fromkeys(r["controller"] for r in rows))
    values = np.full((len(objects), len(controllers)), np.nan)
    for r in rows:
        v = r.get(key)
        values[objects.index(r["object"]), controllers.index(r["controller"])] = np.nan if v is None else float(v)
    return objects, controllers, values


def experiment_figure(rows: list[dict], aim: ControllerAim | None = None):
    """The experiment's figure: the referee's outcome matrix (left); per object, a group of bars,
    one per controller, of the grip margin (log axis, lines at 1, at the experiment's controller's
    aim, ``aim`` (None: :func:`default_aim`), and at :data:`MARGIN_BOUND`;
    a run that never carried the object is an empty hatched bar named by its outcome) and the
    peak pressure of each run as a point above its bar (nothing joins different objects)."""
    from matplotlib.figure import Figure
    from matplotlib.patches import Patch

    objects, controllers, margin = _grid(rows, "grip_margin")
    peak = _grid(rows, "peak_pressure_pa")[2]
    outcome = {(r["object"], r["controller"]): r["outcome"] for r in rows}
    fig = Figure(figsize=(21, 9.5))
    grid = fig.add_gridspec(2, 2, width_ratios=(1.0, 1.75), height_ratios=(1.6, 1.0))
    ax = fig.add_subplot(grid[:, 0])
    ax_g = fig.add_subplot(grid[0, 1])
    ax_p = fig.add_subplot(grid[1, 1], sharex=ax_g)

    # the referee's outcome per object and controller
    for r in rows:
        i, j = objects.index(r["object"]), controllers.index(r["controller"])
        ax.add_patch(_cell(j, i, OUTCOME_COLOUR.get(r["outcome"], "white")))
        label = r["outcome"].replace("_", " ") + ("\n(outside model)" if r["outside_model"] else "")
        ax.text(j, i, label, ha="center", va="center", fontsize=7)
    ax.set_xlim(-0.5, len(controllers) - 0.5)
    ax.set_ylim(len(objects) - 0.5, -0.5)
    ax.set_xticks(range(len(controllers)), controllers, rotation=20)
    infeasible = {r["object"] for r in rows if not r["feasible"]}
    ax.set_yticks(range(len(objects)), [f"{o} (infeasible)" if o in infeasible else o for o in objects])
    ax.set_title("referee's outcome per object and controller (green: success)")

    # grip margin: grouped bars, objects on x, one bar per controller
    width = 0.8 / max(len(controllers), 1)
    offsets = (np.arange(len(controllers)) - 0.5 * (len(controllers) - 1)) * width
    x = np.arange(len(objects))
    finite = margin[np.isfinite(margin) & (margin > 0)]
    lo = min(0.5, 0.5 * float(finite.min())) if finite.size else 0.5
    hi = max(2.0 * MARGIN_BOUND, 3.0 * float(finite.max())) if finite.size else 10.0
    colours = [f"C{j}" for j in range(len(controllers))]
    for j, (name, colour) in enumerate(zip(controllers, colours, strict=True)):
        carried = np.isfinite(margin[:, j])
        heights = np.where(carried, margin[:, j] - lo, hi - lo)
        bars = ax_g.bar(x + offsets[j], heights, width, bottom=lo, color=colour, edgecolor=colour, label=name)
        for i, bar in enumerate(bars.patches):
            words = outcome.get((objects[i], name), "").replace("_", " ") or "no run"
            if carried[i]:
                if words != "success":  # carried, and still not a success: say why above the bar
                    ax_g.text(x[i] + offsets[j], margin[i, j] * 1.08, words, rotation=90, ha="center", va="bottom", fontsize=7)
                continue
            bar.set(facecolor="none", hatch="///", alpha=0.45, lw=0.6)
            box = {"facecolor": "white", "edgecolor": "none", "alpha": 0.8, "pad": 1.0}
            ax_g.text(x[i] + offsets[j], math.sqrt(lo * hi), words, rotation=90, ha="center", va="center", fontsize=7, bbox=box)
    ax_g.axhline(1.0, color="k", lw=1.2, label="1: holds it exactly")
    aim = default_aim() if aim is None else aim
    if aim is not None:  # what the controller holds at, from its own config: not a number typed here
        label = f"{aim.margin:g}: the {aim.kind} controller's aim (controller.grip_safety)"
        ax_g.axhline(aim.margin, color="tab:green", ls="-.", lw=1.2, label=label)
    ax_g.axhline(MARGIN_BOUND, color="k", ls="--", lw=1.2, label=f"{MARGIN_BOUND:g}: issue 43's bound on a hold (not an aim)")
    ax_g.set_yscale("log")
    ax_g.set_ylim(lo, hi)
    ax_g.set(ylabel="grip margin [-]\n(hold grip / grip that holds it)")
    ax_g.set_title("grip margin per object and controller (hatched: never carried clear of the table)")
    ax_g.grid(True, axis="y", which="both", alpha=0.3)
    hatched = Patch(facecolor="none", edgecolor="0.4", hatch="///", label="never carried (no margin)")
    handles, _ = ax_g.get_legend_handles_labels()
    ax_g.legend(handles=[*handles, hatched], fontsize=8, loc="upper left", bbox_to_anchor=(1.005, 1.0))

    # peak pressure: a point per run, at its bar's place
    for j, (name, colour) in enumerate(zip(controllers, colours, strict=True)):
        ax_p.scatter(x + offsets[j], peak[:, j], s=18, color=colour, edgecolor="k", linewidth=0.3, label=name, zorder=3)
    ax_p.set_yscale("log")
    ax_p.set(ylabel="peak pressure on the element [Pa]")
    ax_p.set_title("peak pressure per run", fontsize=10)
    ax_p.grid(True, axis="y", which="both", alpha=0.3)
    ax_p.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.005, 1.0))
    for ax_b in (ax_g, ax_p):
        for edge in np.arange(len(objects) + 1) - 0.5:  # the objects' groups, apart
            ax_b.axvline(edge, color="0.85", lw=0.8, zorder=0)
    ax_p.set_xlim(-0.5, len(objects) - 0.5)
    ax_p.set_xticks(x, objects, rotation=30, ha="right")
    ax_g.tick_params(labelbottom=False)
    return fig


def _cell(x: float, y: float, colour: str):
    from matplotlib.patches import Rectangle

    return Rectangle((x - 0.5, y - 0.5), 1.0, 1.0, facecolor=colour, edgecolor="white")
