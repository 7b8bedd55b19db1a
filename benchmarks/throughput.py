"""Many grasps, fast: what a user waits for, as ratios measured in one run.

    python -m benchmarks.throughput [--baseline REV] [--json]

Each figure times whole commands as a user runs them (a fresh Python process: imports, set-up,
the runs, the files), so start-up and Dask's cluster are in the numbers:

- ``experiment_speedup``: ``experiment grasp-range`` as it runs by default (a local Dask
  cluster over this machine's cores, the disk cache of set-up tables warm from an earlier
  run) against the same experiment run serially with every cache off (``--workers 0``,
  ``PIEZOTIP_CACHE=off``: each run computes its own mode bands and tables, as before the
  caches existed): the caches' and the workers' share, the same loop on both sides.  Also the
  cold-cache default run (a fresh cache folder).
- ``sweep_speedup_2_vs_1``: one sweep on a local cluster of 2 workers against 1 worker (the
  median over :data:`SWEEP_ROUNDS` pairs of runs, each pair's ratio taken seconds apart), on
  the sweep of :data:`SWEEP_GRID` (96 grasps: objects x controllers x sensor designs);
  ``small_sweep_speedup_2_vs_1`` the same on :data:`SMALL_SWEEP_GRID` (24 grasps), where the
  command's start-up is a larger share.
- ``hold_rt_ratio``: the loop's real-time factor over the hold phase of a grasp held 300 s
  (its median 10 s window) against one held 10 s, recorder included (a recorder whose cost grew
  with the run's length shows here); ``long_run_rt_ratio`` the same over the whole runs (see :func:`long_run_times`).
- with ``--baseline REV``: ``baseline_speedup``, the same experiment as git revision REV of this
  repository runs it against the present code's default run, both with their figure (an old
  revision may have no ``--no-plot``): the whole speed-up since REV, loop included.  The
  revision runs from a copy of its tree (``git archive``) with this environment's packages,
  laid out as its own pyproject installs it (:func:`benchmarks.revisions.revision_tree`, its
  Python references), in the same run.

The caches used are in a temporary folder (``PIEZOTIP_CACHE_DIR``), never the user's.  Every
tree that runs (the installed package's source folders, a baseline revision's copy) has its
modules' bytecode compiled first (:func:`benchmarks.revisions.compile_bytecode`).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

if not __package__:  # run as a file (python benchmarks/throughput.py): its siblings by their package's name
    sys.path.append(str(Path(__file__).resolve().parents[1]))  # last: the installed piezotip comes first

from benchmarks.revisions import REPO, compile_bytecode, resolve_revision, revision_tree, source_folders

#: The sweeps timed for the worker speed-up (their grids, ``--grid`` text), at the default fidelity.
#: The sweep of the size the users run ("by the hundred: objects x controllers x sensor designs"):
#: 96 grasps, four masses by three frictions by two sizes, by the multimode controller and the
#: single-mode baseline, by the element's tip coverage and the whole beam's.  The small sweep (24
#: grasps, the objects alone) is reported beside it: each command pays about a second of start-up
#: (imports, Dask's cluster) on 1 worker and on 2, which the small sweep's 5 s of work does not hide.
SWEEP_GRID = (
    "object.mass_kg=0.02,0.1,0.4,1.0",
    "object.friction=0.5,0.8,1.1",
    "object.size_m=0.03,0.05",
    "controller.modes=[1],[1,2,3,4]",
    "sensor.coverage_mm=[0,7.5],[6.5,7.5]",
)
SMALL_SWEEP_GRID = SWEEP_GRID[:3]


def _timed_command(args: list[str], env: dict[str, str], script: str | None = None, cwd: Path | None = None) -> float:
    """Wall time of ``python run_sim.py ARGS`` in a fresh process, s (it must succeed or exit 1):
    this code's command line, or ``script`` run from ``cwd`` (a revision's, :func:`baseline_times`)."""
    entry = ["-m", "piezotip.cli"] if script is None else [script]
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, *entry, *args], env=env, cwd=cwd, capture_output=True, text=True)
    wall = time.perf_counter() - start
    if proc.returncode not in (0, 1):
        where = f" (in {cwd})" if cwd is not None else ""
        raise RuntimeError(f"run_sim.py {' '.join(args)}{where} failed ({proc.returncode}): {proc.stderr.strip()[-500:]}")
    return wall


def _env(cache_dir: Path, cache: bool = True) -> dict[str, str]:
    env = {**os.environ, "PIEZOTIP_CACHE_DIR": str(cache_dir), "MPLBACKEND": "Agg"}
    env.pop("PIEZOTIP_CACHE", None)
    if not cache:
        env["PIEZOTIP_CACHE"] = "off"
    return env


def experiment_times(work: Path, workers: int | None = None) -> dict:
    """``experiment grasp-range`` serial without caches, default cold, default warm; s."""
    cache_dir = work / "cache"
    serial = _timed_command(
        ["experiment", "grasp-range", "--workers", "0", "--no-plot", "--out", str(work / "serial")], _env(cache_dir, cache=False)
    )
    parallel_args = ["experiment", "grasp-range", "--no-plot"] + (["--workers", str(workers)] if workers is not None else [])
    cold = _timed_command([*parallel_args, "--out", str(work / "cold")], _env(cache_dir))
    warm = _timed_command([*parallel_args, "--out", str(work / "warm")], _env(cache_dir))
    return {
        "experiment_serial_uncached_s": serial,
        "experiment_default_cold_cache_s": cold,
        "experiment_default_s": warm,
        "experiment_speedup": serial / warm,
        "experiment_speedup_cold_cache": serial / cold,
    }


#: Rounds of the sweeps' 1-worker and 2-worker runs: on a shared VM single runs of the same
#: command vary by 10-20 %, so each round pairs two runs made seconds apart (their order
#: alternating) and the figure is the rounds' median.
SWEEP_ROUNDS = 3


def grid_points_count(grid: tuple[str, ...]) -> int:
    """How many points a sweep over ``grid`` (``--grid`` texts) runs."""
    from piezotip.analysis.sweep_grid import parse_grid

    return math.prod(len(values) for values in parse_grid(list(grid)).values())


def _paired_rounds(time_one, rounds: int) -> tuple[list[float], list[float], list[float]]:
    """``rounds`` pairs of ``time_one(workers, k)`` for 1 and 2 workers, the order alternating:
    the 1-worker times, the 2-worker times, each pair's ratio."""
    ones, twos = [], []
    for k in range(rounds):
        for workers in (1, 2) if k % 2 == 0 else (2, 1):
            (ones if workers == 1 else twos).append(time_one(workers, k))
    return ones, twos, [one / two for one, two in zip(ones, twos, strict=True)]


def sweep_times(work: Path, rounds: int = SWEEP_ROUNDS) -> dict:
    """The sweeps of :data:`SWEEP_GRID` and :data:`SMALL_SWEEP_GRID` on 1 and on 2 local workers,
    whole command, s (cache warm): ``rounds`` pairs of runs each, the median of each and of the
    pairs' speed-ups.  Keys ``sweep_*`` are the users' sweep's, ``small_sweep_*`` the small one's."""
    cache_dir = work / "cache"
    report: dict = {"cores": os.cpu_count()}

    def base(grid: tuple[str, ...]) -> list[str]:
        return ["sweep", "grasp", *(arg for g in grid for arg in ("--grid", g)), "--no-plot"]

    # The set-up tables of every sensor design on disk, as after a user's first sweep.
    _timed_command([*base(SWEEP_GRID), "--workers", "2", "--out", str(work / "sweep-warmup")], _env(cache_dir))
    for prefix, grid in (("small_sweep", SMALL_SWEEP_GRID), ("sweep", SWEEP_GRID)):

        def time_one(workers: int, k: int, grid=grid, prefix=prefix) -> float:
            out = work / f"{prefix}-{workers}-{k}"
            return _timed_command([*base(grid), "--workers", str(workers), "--out", str(out)], _env(cache_dir))

        ones, twos, speedups = _paired_rounds(time_one, rounds)
        report |= {
            f"{prefix}_points": grid_points_count(grid),
            f"{prefix}_1_worker_s": statistics.median(ones),
            f"{prefix}_2_workers_s": statistics.median(twos),
            f"{prefix}_speedup_2_vs_1": statistics.median(speedups),
            f"{prefix}_1_worker_runs_s": ones,
            f"{prefix}_2_workers_runs_s": twos,
            f"{prefix}_speedups": speedups,
        }
    return report


#: The long hold is judged window by window, s simulated (2000 control steps at 5 ms; each window
#: holds several of the recorder's chunk writes, so a per-chunk cost is in every window's mean).
HOLD_WINDOW_S = 10.0


def window_rt_factors(step_wall_s: list[float], dt_s: float, per_window: int) -> list[float]:
    """The real-time factor of each window of ``per_window`` consecutive steps (simulated time
    over wall time: ``dt_s`` s simulated per step, ``step_wall_s`` each step's wall s); a tail
    shorter than half a window joins the window before it."""
    windows = [step_wall_s[i : i + per_window] for i in range(0, len(step_wall_s), per_window)]
    if len(windows) > 1 and len(windows[-1]) < per_window // 2:
        windows[-2] = windows[-2] + windows.pop()
    return [len(w) * dt_s / sum(w) for w in windows if sum(w) > 0]


def long_run_times(work: Path, long_hold_s: float = 300.0, short_hold_s: float = 10.0) -> dict:
    """The loop's real-time factor (recorder included) of a grasp held ``long_hold_s`` against
    one held ``short_hold_s``: over the hold phase alone (``hold_rt_ratio``), and
    over the whole runs (``long_run_rt_ratio``).

    The whole runs differ in what they simulate, not only in length: the long one is 98 % hold
    (contacts on every step, MuJoCo's dearest), the short one 60 % approach, closing and release
    (cheap free stepping), so their ratio falls below 1 with a recording of perfectly linear
    cost.  The hold against the hold compares like with like: a recorder whose cost grew with
    the run's length shows there.  The short run is timed before and after the long one, and
    the faster kept (the machine's speed drifts; noise only ever adds time).

    The long hold is cut into windows of HOLD_WINDOW_S simulated seconds, each timed whole (its
    mean step, chunk writes included), and its factor is the median window's
    (``long_hold_rt_factor``; every window's in ``long_hold_window_rt_factors``): this machine is
    a shared VM that runs everything 1.3 to 1.6x slower for tens of seconds at a time (measured:
    mj_step, the readout and the recorder alike, in the same windows), which a 300 s mean takes
    in and a 10 s run mostly escapes.  A cost that grew with the run's length would slow the
    later half of the windows and so the median; a periodic one is in every window.  The plain
    mean over the whole hold is ``long_hold_rt_factor_mean`` (``hold_rt_ratio_mean``)."""
    from piezotip import scenarios
    from piezotip.cosim.control import Phase
    from piezotip.cosim.loop import CoSimulation
    from piezotip.cosim.recorder import Recorder

    def factors(hold_s: float, name: str) -> tuple[float, float, float, list[float]]:
        # The grasp's other phases take about 7 s; the duration leaves room for them.
        config = scenarios.get("grasp", [f"controller.hold_s={hold_s}", f"duration_s={hold_s + 20.0}"])
        sim = CoSimulation(config)
        per_window = max(round(HOLD_WINDOW_S / sim.dt), 1)  # control steps
        hold = {"last": None, "steps": []}

        def time_hold(sim: CoSimulation) -> None:
            # The wall time since the last step's end is this step's, recorder included.
            now = time.perf_counter()
            if hold["last"] is not None and sim.controller.phase is Phase.HOLD:
                hold["steps"].append(now - hold["last"])
            hold["last"] = now

        result = sim.run(Recorder(work / name / "run"), on_step=time_hold)
        steps = hold["steps"]
        hold_rt = len(steps) * sim.dt / sum(steps) if steps and sum(steps) > 0 else math.nan
        return result.sim_time_s / result.wall_time_s, result.sim_time_s, hold_rt, window_rt_factors(steps, sim.dt, per_window)

    first = factors(short_hold_s, f"hold-{short_hold_s:g}")
    long_rt, long_sim, long_hold_mean_rt, long_windows = factors(long_hold_s, f"hold-{long_hold_s:g}")
    again = factors(short_hold_s, f"hold-{short_hold_s:g}-again")
    short_rt, short_sim, _, _ = max(first, again, key=lambda f: f[0])
    short_hold_rt = max(first[2], again[2])
    long_hold_rt = statistics.median(long_windows) if long_windows else math.nan
    return {
        "short_run_sim_s": short_sim,
        "short_run_rt_factor": short_rt,
        "long_run_sim_s": long_sim,
        "long_run_rt_factor": long_rt,
        "long_run_rt_ratio": long_rt / short_rt,
        "short_hold_s": short_hold_s,
        "long_hold_s": long_hold_s,
        "short_hold_rt_factor": short_hold_rt,
        "long_hold_rt_factor": long_hold_rt,
        "long_hold_window_s": HOLD_WINDOW_S,
        "long_hold_window_rt_factors": long_windows,
        "long_hold_rt_factor_mean": long_hold_mean_rt,
        "hold_rt_ratio": long_hold_rt / short_hold_rt,
        "hold_rt_ratio_mean": long_hold_mean_rt / short_hold_rt,
    }


def baseline_times(rev: str, work: Path, repo: Path = REPO) -> dict:
    """``experiment grasp-range`` as revision ``rev`` runs it, and as this code runs it by default
    (its figure too, as the revision's does), whole commands, s."""
    run_from, env = revision_tree(rev, work / "baseline", repo)  # its Python references (not built)
    compile_bytecode(work / "baseline")  # its tree and its installed layout, as this checkout's
    baseline = _timed_command(["experiment", "grasp-range", "--out", str(work / "baseline-out")], env, script="run_sim.py", cwd=run_from)
    now = _timed_command(["experiment", "grasp-range", "--out", str(work / "baseline-now")], _env(work / "cache"))
    return {"baseline_rev": rev, "baseline_experiment_s": baseline, "experiment_with_plot_s": now, "baseline_speedup": baseline / now}


def throughput_report(progress=None, baseline: str | None = None) -> dict:
    """All three (and the baseline's, when asked), in one run (the ratios compare numbers taken
    minutes apart on one machine)."""
    report = {}
    measures = [("experiment", experiment_times), ("sweep", sweep_times), ("long run", long_run_times)]
    if baseline is not None:
        resolve_revision(baseline)  # a bad revision fails before minutes of measuring, not after
        measures.append((f"experiment at {baseline}", lambda work: baseline_times(baseline, work)))
    compile_bytecode(*source_folders())
    with tempfile.TemporaryDirectory(prefix="piezotip-throughput-") as tmp:
        work = Path(tmp)
        for name, measure in measures:
            if progress is not None:
                progress(f"throughput: {name}")
            report.update(measure(work))
    return report


def format_throughput(report: dict) -> str:
    """The throughput figures as text, each ratio with what it compares."""
    lines = [
        "throughput (whole commands in fresh processes; ratios from this run)",
        f"  experiment grasp-range, serial, no caches      {report['experiment_serial_uncached_s']:7.1f} s",
        f"  experiment grasp-range, default, cold cache    {report['experiment_default_cold_cache_s']:7.1f} s"
        f"   {report['experiment_speedup_cold_cache']:.2f}x",
        f"  experiment grasp-range, default, warm cache    {report['experiment_default_s']:7.1f} s"
        f"   {report['experiment_speedup']:.2f}x  (the caches' and workers' share: the same loop in both)",
    ]
    for prefix, what in (("small_sweep", "the objects alone"), ("sweep", "objects x controllers x sensor designs")):
        if f"{prefix}_points" not in report:
            continue
        ratio = report[f"{prefix}_speedup_2_vs_1"]
        note = f"(on {report['cores']} cores)" if prefix == "sweep" else "(about 1 s of each command is start-up)"
        name = f"  sweep of {report[f'{prefix}_points']} grasps"
        lines += [
            f"{name + ', 1 worker':<49}{report[f'{prefix}_1_worker_s']:7.1f} s",
            f"{name + ', 2 workers':<49}{report[f'{prefix}_2_workers_s']:7.1f} s   {ratio:.2f}x  {note}",
        ]
        speedups = report.get(f"{prefix}_speedups") or []
        if len(speedups) > 1:
            pairs = zip(report[f"{prefix}_1_worker_runs_s"], report[f"{prefix}_2_workers_runs_s"], speedups, strict=True)
            runs = ", ".join(f"{one:.1f} s / {two:.1f} s = {x:.2f}x" for one, two, x in pairs)
            what += f"; the median of {len(speedups)} pairs of runs: {runs}"
        lines.append(f"    ({what})")
    lines += [
        f"  real-time factor, {report['short_run_sim_s']:.0f} s run                     {report['short_run_rt_factor']:7.1f}x",
        f"  real-time factor, {report['long_run_sim_s']:.0f} s run                    {report['long_run_rt_factor']:7.1f}x"
        f"   ratio {report['long_run_rt_ratio']:.2f}  (mostly hold against mostly free motion)",
    ]
    if "hold_rt_ratio" in report:
        lines += [
            f"  real-time factor of the hold, {report['short_hold_s']:g} s held         {report['short_hold_rt_factor']:7.1f}x",
            f"  real-time factor of the hold, {report['long_hold_s']:g} s held        {report['long_hold_rt_factor']:7.1f}x"
            f"   ratio {report['hold_rt_ratio']:.2f}  (hold against hold: a cost growing with the run's length shows here)",
        ]
        windows = report.get("long_hold_window_rt_factors") or []
        if len(windows) > 1:
            lines.append(
                f"    (the median of {len(windows)} windows of {report['long_hold_window_s']:g} s: slowest {min(windows):.1f}x,"
                f" fastest {max(windows):.1f}x; the whole hold's mean {report['long_hold_rt_factor_mean']:.1f}x,"
                f" ratio {report['hold_rt_ratio_mean']:.2f})"
            )
    if "baseline_speedup" in report:
        lines += [
            f"  experiment grasp-range at {report['baseline_rev']:<12}      {report['baseline_experiment_s']:7.1f} s"
            "  (as that revision ran it)",
            f"  experiment grasp-range now, with its figure    {report['experiment_with_plot_s']:7.1f} s"
            f"   {report['baseline_speedup']:.2f}x  (the whole speed-up since {report['baseline_rev']})",
        ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", metavar="REV", help="also time experiment grasp-range as git revision REV of this repository runs it")
    parser.add_argument("--json", action="store_true", help="print the report as JSON")
    args = parser.parse_args(argv)
    progress = None if args.json else (lambda name: print(f"timing {name} ...", file=sys.stderr, flush=True))
    try:
        report = throughput_report(progress=progress, baseline=args.baseline)
    except ValueError as err:  # a revision git does not know
        parser.error(f"--baseline: {err}")
    print(json.dumps(report, indent=2) if args.json else format_throughput(report))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
