"""Many grasps, fast: what a user waits for, as ratios measured in one run (``bench --throughput``).

Each figure times whole commands as a user runs them (a fresh Python process: imports, set-up,
the runs, the files), so start-up and Dask's cluster are in the numbers:

- ``experiment_speedup``: ``experiment grasp-range`` as it runs by default (a local Dask
  cluster over this machine's cores, the disk cache of set-up tables warm from an earlier
  run) against the same experiment run serially with every cache off (``--workers 0``,
  ``PIEZOTIP_CACHE=off``: each run computes its own mode bands and tables, as before the
  caches existed).  Also the cold-cache default run (a fresh cache folder).
- ``sweep_speedup_2_vs_1``: one sweep on a local cluster of 2 workers against 1 worker.
- ``long_run_rt_ratio``: the loop's real-time factor of a grasp held 300 s against one held
  10 s, recorder included (a recorder whose cost grew with the run's length shows here).

The caches used are in a temporary folder (``PIEZOTIP_CACHE_DIR``), never the user's.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

#: The issue's targets.
TARGET_EXPERIMENT_SPEEDUP = 4.0
TARGET_SWEEP_SPEEDUP = 1.7
TARGET_LONG_RUN_RT_RATIO = 0.9

#: The sweep timed for the worker speed-up: 24 grasps of different objects at the default
#: fidelity, about 8 s of work on one core: a small sweep as users run them (dozens of
#: points), so a worker's start-up (imports, about 1 s) is part of it but not the whole.
SWEEP_GRID = ("object.mass_kg=0.02,0.1,0.4,1.0", "object.friction=0.5,0.8,1.1", "object.size_m=0.03,0.05")

def _timed_command(args: list[str], env: dict[str, str]) -> float:
    """Wall time of ``python run_sim.py ARGS`` in a fresh process, s (it must succeed or exit 1)."""
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "piezotip.cli", *args], env=env, capture_output=True, text=True)
    wall = time.perf_counter() - start
    if proc.returncode not in (0, 1):
        raise RuntimeError(f"run_sim.py {' '.join(args)} failed ({proc.returncode}): {proc.stderr.strip()[-500:]}")
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
        "target_experiment_speedup": TARGET_EXPERIMENT_SPEEDUP,
    }


def sweep_times(work: Path) -> dict:
    """One sweep on 1 and on 2 local workers, whole command, s (cache warm)."""
    cache_dir = work / "cache"
    grid = [arg for g in SWEEP_GRID for arg in ("--grid", g)]
    base = ["sweep", "grasp", *grid, "--no-plot"]
    _timed_command([*base, "--workers", "0", "--out", str(work / "sweep-warmup")], _env(cache_dir))  # tables on disk
    one = _timed_command([*base, "--workers", "1", "--out", str(work / "sweep-1")], _env(cache_dir))
    two = _timed_command([*base, "--workers", "2", "--out", str(work / "sweep-2")], _env(cache_dir))
    return {
        "sweep_points": math.prod(len(g.split("=", 1)[1].split(",")) for g in SWEEP_GRID),
        "sweep_1_worker_s": one,
        "sweep_2_workers_s": two,
        "sweep_speedup_2_vs_1": one / two,
        "target_sweep_speedup": TARGET_SWEEP_SPEEDUP,
        "cores": os.cpu_count(),
    }


def long_run_times(work: Path, long_hold_s: float = 300.0, short_hold_s: float = 10.0) -> dict:
    """The loop's real-time factor (recorder included) of a grasp held ``long_hold_s`` against
    one held ``short_hold_s``."""
    from piezotip import scenarios
    from piezotip.cosim.loop import CoSimulation
    from piezotip.cosim.recorder import Recorder

    def factor(hold_s: float) -> tuple[float, float]:
        # The grasp's other phases take about 7 s; the duration leaves room for them.
        config = scenarios.get("grasp", [f"controller.hold_s={hold_s}", f"duration_s={hold_s + 20.0}"])
        sim = CoSimulation(config)
        result = sim.run(Recorder(work / f"hold-{hold_s:g}" / "run"))
        return result.sim_time_s / result.wall_time_s, result.sim_time_s

    short_rt, short_sim = factor(short_hold_s)
    long_rt, long_sim = factor(long_hold_s)
    return {
        "short_run_sim_s": short_sim,
        "short_run_rt_factor": short_rt,
        "long_run_sim_s": long_sim,
        "long_run_rt_factor": long_rt,
        "long_run_rt_ratio": long_rt / short_rt,
        "target_long_run_rt_ratio": TARGET_LONG_RUN_RT_RATIO,
    }


def throughput_report(progress=None) -> dict:
    """All three, in one run (the ratios compare numbers taken minutes apart on one machine)."""
    report = {}
    with tempfile.TemporaryDirectory(prefix="piezotip-throughput-") as tmp:
        work = Path(tmp)
        for name, measure in (("experiment", experiment_times), ("sweep", sweep_times), ("long run", long_run_times)):
            if progress is not None:
                progress(f"throughput: {name}")
            report.update(measure(work))
    return report


def format_throughput(report: dict) -> str:
    """The throughput figures as text, each against its target."""

    def mark(ok: bool) -> str:
        return "ok" if ok else "NO"

    lines = [
        "throughput (whole commands in fresh processes; ratios from this run)",
        f"  experiment grasp-range, serial, no caches      {report['experiment_serial_uncached_s']:7.1f} s",
        f"  experiment grasp-range, default, cold cache    {report['experiment_default_cold_cache_s']:7.1f} s"
        f"   {report['experiment_speedup_cold_cache']:.2f}x",
        f"  experiment grasp-range, default, warm cache    {report['experiment_default_s']:7.1f} s"
        f"   {report['experiment_speedup']:.2f}x  (target >= {TARGET_EXPERIMENT_SPEEDUP:g}x)"
        f"  {mark(report['experiment_speedup'] >= TARGET_EXPERIMENT_SPEEDUP)}",
        f"  sweep of {report['sweep_points']} grasps, 1 worker                  {report['sweep_1_worker_s']:7.1f} s",
        f"  sweep of {report['sweep_points']} grasps, 2 workers                 {report['sweep_2_workers_s']:7.1f} s"
        f"   {report['sweep_speedup_2_vs_1']:.2f}x  (target >= {TARGET_SWEEP_SPEEDUP:g}x on {report['cores']} cores)"
        f"  {mark(report['sweep_speedup_2_vs_1'] >= TARGET_SWEEP_SPEEDUP)}",
        f"  real-time factor, {report['short_run_sim_s']:.0f} s run                     {report['short_run_rt_factor']:7.1f}x",
        f"  real-time factor, {report['long_run_sim_s']:.0f} s run                    {report['long_run_rt_factor']:7.1f}x"
        f"   ratio {report['long_run_rt_ratio']:.2f}  (target >= {TARGET_LONG_RUN_RT_RATIO:g})"
        f"  {mark(report['long_run_rt_ratio'] >= TARGET_LONG_RUN_RT_RATIO)}",
    ]
    return "\n".join(lines)
