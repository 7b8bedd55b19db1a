"""Is the readout honest over whole grasps?  The 3-sigma coverage of its "ok" readings.

The readout's contract (:meth:`sensor.channel.SensorChannel.estimate`): where a fingertip's
status is "ok", the pressure its gel brings to the element's coverage
(``<side>_coverage_pressure_pa``, the truth the estimate is checked against) lies within
``estimate_pa +- 3 uncertainty_pa``.  :func:`estimate_coverage` measures that over recorded
grasps, load changes included (touchdown, lift, place, release): the "ok" readings, the share
of them that hold the truth, and the worst miss in sigmas with its run, time and phase.

:func:`holdout_coverage` runs a set of hold-out grasps (:data:`HOLDOUT`: objects that are not in
the experiment's catalogue, :data:`analysis.experiment.OBJECTS`, and a few other presets and
sensor designs) and measures them; :func:`main` prints it (``python -m
piezotip.reports.coverage [--json] [--workers N] [--seeds S ...] [--only NAME ...]``).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

#: The interval's half-width, in reported uncertainties.
SIGMAS = 3.0
#: The share of "ok" readings that must hold the truth (issue 29, item 5).
TARGET = 0.99
#: A miss by more than this many sigmas is gross (counted apart).
GROSS_SIGMAS = 10.0
SIDES = ("left", "right")


def _codes():
    from piezotip.cosim.control import PHASES
    from piezotip.cosim.rows import STATUS_CODES

    return STATUS_CODES, PHASES


def _named(records) -> list[tuple[str, Mapping[str, np.ndarray]]]:
    """``records`` as (name, data) pairs: a mapping of names to recordings, an iterable of
    recordings or of (name, recording) pairs, or a single recording."""
    if isinstance(records, Mapping):
        if "time_s" in records:  # one recording
            return [("run", records)]
        return [(str(name), data) for name, data in records.items()]
    out = []
    for k, item in enumerate(records):
        if isinstance(item, tuple) and len(item) == 2:
            out.append((str(item[0]), item[1]))
        else:
            out.append((f"run {k}", item))
    return out


def estimate_coverage(records, sigmas: float = SIGMAS) -> dict:
    """The 3-sigma coverage of the "ok" readings over whole recorded grasps.

    ``records``: recordings (``run.npz``'s columns as arrays, e.g. :attr:`piezotip.Result.data`)
    as a mapping name -> recording, an iterable of them (or of (name, recording) pairs), or one
    recording.  Every control step of both fingertips counts, load changes included.

    Returns a dict: ``ok`` (the count of "ok" readings), ``within`` (those whose coverage
    pressure lies within estimate +- ``sigmas`` uncertainty), ``share`` (within / ok; NaN with no
    "ok" reading), ``misses`` and ``gross`` (off by more than ``sigmas`` and
    :data:`GROSS_SIGMAS`), ``readings`` (every fingertip reading), ``by_phase`` (per phase:
    ok, within, share, worst sigmas), ``by_run`` (the same per run) and ``worst`` (the worst miss:
    run, side, time_s, phase, sigmas, estimate_pa, uncertainty_pa, truth_pa, mode; None without
    an "ok" reading).
    """
    status_codes, phases = _codes()
    ok_code = status_codes.index("ok")
    total = dict(ok=0, within=0, misses=0, gross=0, readings=0)
    by_phase: dict[str, dict] = {}
    by_run: dict[str, dict] = {}
    worst = None

    def tally(bucket: dict, key: str, z: np.ndarray) -> None:
        entry = bucket.setdefault(key, dict(ok=0, within=0, worst_sigmas=0.0))
        entry["ok"] += int(z.size)
        entry["within"] += int(np.count_nonzero(z <= sigmas))
        if z.size:
            entry["worst_sigmas"] = max(entry["worst_sigmas"], float(z.max()))

    for name, data in _named(records):
        t = np.asarray(data["time_s"], float)
        phase = np.asarray(data["phase"]).astype(int) if "phase" in data else np.full(t.shape, -1)
        for side in SIDES:
            if f"{side}_status" not in data:
                continue
            status = np.asarray(data[f"{side}_status"]).astype(int)
            est = np.asarray(data[f"{side}_estimate_pa"], float)
            unc = np.asarray(data[f"{side}_uncertainty_pa"], float)
            truth = np.asarray(data[f"{side}_coverage_pressure_pa"], float)
            total["readings"] += int(status.size)
            ok = status == ok_code
            with np.errstate(divide="ignore", invalid="ignore"):
                z_all = np.abs(est - truth) / unc
            z_all = np.where(np.isfinite(z_all), z_all, math.inf)  # an "ok" reading without a finite interval misses
            z = z_all[ok]
            total["ok"] += int(z.size)
            total["within"] += int(np.count_nonzero(z <= sigmas))
            total["misses"] += int(np.count_nonzero(z > sigmas))
            total["gross"] += int(np.count_nonzero(z > GROSS_SIGMAS))
            tally(by_run, name, z)
            for code in np.unique(phase[ok]):
                label = phases[code] if 0 <= code < len(phases) else str(code)
                tally(by_phase, label, z_all[ok & (phase == code)])
            if z.size:
                k = int(np.flatnonzero(ok)[np.argmax(z)])
                if worst is None or z_all[k] > worst["sigmas"]:
                    code = int(phase[k])
                    worst = dict(
                        run=name,
                        side=side,
                        time_s=float(t[k]),
                        phase=phases[code] if 0 <= code < len(phases) else str(code),
                        sigmas=float(z_all[k]),
                        estimate_pa=float(est[k]),
                        uncertainty_pa=float(unc[k]),
                        truth_pa=float(truth[k]),
                        mode=int(data[f"{side}_mode"][k]) if f"{side}_mode" in data else None,
                    )
    for bucket in (by_phase, by_run):
        for entry in bucket.values():
            entry["share"] = entry["within"] / entry["ok"] if entry["ok"] else math.nan
    return dict(
        total,
        share=total["within"] / total["ok"] if total["ok"] else math.nan,
        sigmas=sigmas,
        worst=worst,
        by_phase=by_phase,
        by_run=by_run,
    )


@dataclass(frozen=True)
class Grasp:
    """One hold-out grasp: a label, the ``--set`` overrides and the fidelity preset."""

    name: str
    overrides: tuple[str, ...]
    preset: str | None = None


def _object(shape: str, mass_kg: float, size_m: float, friction: float, crush_force_n: float | None = None) -> tuple[str, ...]:
    return (
        f"object.shape={shape!r}",
        f"object.mass_kg={mass_kg!r}",
        f"object.size_m={size_m!r}",
        f"object.friction={friction!r}",
        f"object.crush_force_n={crush_force_n!r}",
    )


#: Hold-out grasps: objects that are not in the experiment's catalogue (masses 7 g to 6 kg,
#: frictions 0.3 to 1.3, every shape, sizes 20 to 70 mm, some with a crush limit), two run at
#: the ``fast`` and two at the ``accurate`` preset, two with a soft-PZT Q of 70.  Chosen to span
#: the range, not to pass: none was dropped for its result.
HOLDOUT: tuple[Grasp, ...] = (
    Grasp("box-7g", _object("box", 0.007, 0.025, 0.7)),
    Grasp("sphere-7g-fragile", _object("sphere", 0.007, 0.03, 0.6, crush_force_n=0.5)),
    Grasp("egg-35g", _object("egg", 0.035, 0.04, 0.45, crush_force_n=10.0)),
    Grasp("cylinder-35g", _object("cylinder", 0.035, 0.02, 1.3)),
    Grasp("sphere-300g", _object("sphere", 0.3, 0.055, 0.8)),
    Grasp("box-300g-slippery", _object("box", 0.3, 0.05, 0.35)),
    Grasp("cylinder-1.5kg", _object("cylinder", 1.5, 0.07, 0.9)),
    Grasp("egg-1.5kg-fragile", _object("egg", 1.5, 0.06, 1.1, crush_force_n=40.0)),
    Grasp("box-6kg", _object("box", 6.0, 0.07, 1.3)),
    Grasp("sphere-6kg", _object("sphere", 6.0, 0.065, 1.2)),
    Grasp("box-35g-fast", _object("box", 0.035, 0.03, 0.5), "fast"),
    Grasp("cylinder-1.5kg-fast", _object("cylinder", 1.5, 0.05, 0.6), "fast"),
    Grasp("sphere-35g-accurate", _object("sphere", 0.035, 0.035, 0.9), "accurate"),
    Grasp("box-300g-accurate", _object("box", 0.3, 0.045, 0.7), "accurate"),
    Grasp("box-300g-q70", (*_object("box", 0.3, 0.04, 0.8), "sensor.quality_factor=70.0")),
    Grasp("egg-35g-q70", (*_object("egg", 0.035, 0.045, 0.6, crush_force_n=8.0), "sensor.quality_factor=70.0")),
)
#: Each hold-out run draws its own readout noise (``sensor.seed``): with one seed every run
#: draws the same noise at the same step, and one unlucky draw on an unloaded pad would count
#: once per run.
SEEDS = (1, 2)


def seeded(grasps: Iterable[Grasp], seeds: Iterable[int] = SEEDS) -> list[Grasp]:
    """Each grasp once per seed, every run with its own ``sensor.seed`` (named ``NAME#SEED``)."""
    grasps, seeds = list(grasps), list(seeds)
    return [
        Grasp(f"{g.name}#{s}", (*g.overrides, f"sensor.seed={s * len(grasps) + k}"), g.preset) for s in seeds for k, g in enumerate(grasps)
    ]


def run_grasp(grasp: Grasp, scenario: str = "grasp") -> tuple[str, dict, dict[str, np.ndarray]]:
    """Run one grasp headless: (its name, the run's summary, its recording)."""
    from piezotip.analysis.runner import run_scenario

    with tempfile.TemporaryDirectory(prefix="piezotip-coverage-") as tmp:
        summary, data = run_scenario(scenario, list(grasp.overrides), Path(tmp), plot=False, quiet=True, preset=grasp.preset)
    return grasp.name, summary, data


def holdout_coverage(grasps: Iterable[Grasp] = HOLDOUT, seeds: Iterable[int] = SEEDS, workers: int = 1, scenario: str = "grasp") -> dict:
    """Run ``grasps`` (default :data:`HOLDOUT`) once per noise seed in ``seeds`` (:func:`seeded`)
    and measure them (:func:`estimate_coverage`); the result also lists each run's ``outcome``
    under ``outcomes``.  ``workers`` > 1 runs the grasps in that many processes."""
    grasps = seeded(grasps, seeds)
    if workers > 1:
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(workers) as pool:
            results = list(pool.map(run_grasp, grasps, [scenario] * len(grasps)))
    else:
        results = [run_grasp(g, scenario) for g in grasps]
    report = estimate_coverage({name: data for name, _, data in results})
    report["outcomes"] = {name: summary.get("outcome") for name, summary, _ in results}
    report["target"] = TARGET
    return report


def format_report(report: dict) -> str:
    """A few lines of text for :func:`estimate_coverage`'s or :func:`holdout_coverage`'s result."""
    lines = [
        f"'ok' readings: {report['ok']} of {report['readings']}; within {report['sigmas']:g} sigma: "
        f"{report['within']} ({100.0 * report['share']:.2f} %, target {100.0 * report.get('target', TARGET):g} %); "
        f"misses {report['misses']}, over {GROSS_SIGMAS:g} sigma {report['gross']}"
    ]
    w = report["worst"]
    if w is not None:
        lines.append(
            f"worst miss: {w['sigmas']:.1f} sigma, {w['run']} {w['side']} at t = {w['time_s']:.3f} s ({w['phase']}, mode {w['mode']}): "
            f"estimate {w['estimate_pa']:.4g} +- {w['uncertainty_pa']:.3g} Pa, truth {w['truth_pa']:.4g} Pa"
        )
    lines.append(
        "by phase: " + ", ".join(f"{k} {v['within']}/{v['ok']} (worst {v['worst_sigmas']:.1f})" for k, v in report["by_phase"].items())
    )
    outcomes = report.get("outcomes", {})
    for name, entry in report["by_run"].items():
        outcome = f" [{outcomes[name]}]" if name in outcomes else ""
        lines.append(
            f"  {name}{outcome}: {entry['within']}/{entry['ok']} ({100.0 * entry['share']:.2f} %), worst {entry['worst_sigmas']:.1f} sigma"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """``python -m piezotip.reports.coverage``: run the hold-out grasps and print the figure;
    exit status 0 when at least :data:`TARGET` of the "ok" readings hold the truth, else 1."""
    parser = argparse.ArgumentParser(prog="python -m piezotip.reports.coverage", description=__doc__.splitlines()[0])
    parser.add_argument("--json", action="store_true", help="print the result as JSON")
    parser.add_argument("--workers", type=int, default=1, help="processes to run the grasps in (default 1)")
    parser.add_argument(
        "--seeds",
        type=int,
        nargs="+",
        default=list(SEEDS),
        help=f"readout-noise seeds, one run of each grasp per seed (default {' '.join(map(str, SEEDS))})",
    )
    parser.add_argument("--only", nargs="*", default=None, help="run only these hold-out grasps (by name)")
    args = parser.parse_args(argv)
    grasps = HOLDOUT
    if args.only:
        known = {g.name: g for g in HOLDOUT}
        unknown = [n for n in args.only if n not in known]
        if unknown:
            parser.error(f"unknown hold-out grasp(s) {', '.join(unknown)}; valid: {', '.join(known)}")
        grasps = tuple(known[n] for n in args.only)
    report = holdout_coverage(grasps, seeds=args.seeds, workers=args.workers)
    if args.json:
        from piezotip.analysis.runner import json_safe

        print(json.dumps(json_safe(report), indent=2))
    else:
        print(format_report(report))
    return 0 if report["share"] >= TARGET else 1


if __name__ == "__main__":
    sys.exit(main())
