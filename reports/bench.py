"""What the co-simulation costs: wall time per simulated second, and its overhead over bare MuJoCo.

For each benchmarked configuration (a :class:`BenchCase`: a name and a ScenarioConfig; the
default grasp scene first, optionally the other registered grasp scenes, later fidelity
presets), :func:`bench_case` runs the scenario as ``run_sim.py run`` does (recorder
included, writing into a temporary directory) and measures:

- ``wall_s_per_sim_s`` and ``realtime_factor``: the run's wall time over its simulated time
  (the fastest of ``repeats`` identical runs: noise only ever adds time);
- ``cosim_step_us``: the co-simulation's time per physics step, all stages included: every
  control step of the runs is stamped, and each step's fastest time over the runs is kept;
- ``bare_step_us``: ``mujoco.mj_step`` alone on the same model in the same states.  One extra
  run captures the full integration state (``mjSTATE_INTEGRATION``: qpos, qvel, warm start,
  controls, applied forces) and the model values the loop changes (the pad joints'
  stiffness, the fingers' force range, the disable flags: the loop computes MuJoCo's sensors
  in a period's last substep only) just before every physics step, through the
  simulation's own hook (``CoSimulation.watch_mj_step``, nothing patched); each state is then
  restored and one ``mj_step`` timed, ``repeats`` passes (alternating with the timed runs,
  so that both sides see the machine alike), each state's fastest time kept;
- ``overhead_ratio`` = cosim_step_us / bare_step_us over the whole run, and the same per
  controller phase in ``by_phase`` (``overhead_ratio_hold``: during the held grasp, where the
  contacts make mj_step dearest).

The runs are deterministic (seeded noise, single-threaded MuJoCo), so every run passes
through the same states.  Performance claims come from here, never from a timed unit test.
What each stage of a control step costs, whole commands' times and instruction counts are the
developers' benchmarks (``benchmarks/`` in the repository, not installed).
"""

from __future__ import annotations

import dataclasses
import math
import os
import statistics
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from piezotip.scenarios.config import ScenarioConfig


@dataclass(frozen=True)
class BenchCase:
    """One configuration to benchmark: a name (scene or preset) and its whole config."""

    name: str
    config: ScenarioConfig


def grasp_cases(all_scenes: bool = False, overrides: Sequence[str] = ()) -> list[BenchCase]:
    """The default grasp scene, or every registered grasp scene (default first)."""
    from piezotip import scenarios

    names = ["grasp"]
    if all_scenes:
        names += [n for n in scenarios.names() if n.startswith("grasp") and n != "grasp"]
    return [BenchCase(n, scenarios.get(n, list(overrides))) for n in names]


def with_duration(config: ScenarioConfig, duration_s: float | None) -> ScenarioConfig:
    """``config`` with ``duration_s`` simulated seconds a run (the run also ends when the
    controller finishes); ``config`` itself for None.  ValueError naming a duration that is not
    a positive number of seconds."""
    if duration_s is None:
        return config
    if not (math.isfinite(duration_s) and duration_s > 0):
        raise ValueError(f"duration must be a positive number of seconds, got {duration_s!r}")
    return dataclasses.replace(config, duration_s=float(duration_s)).validate()


def _new_sim(config: ScenarioConfig):
    from piezotip.cosim.loop import CoSimulation

    return CoSimulation(config)


def _run(sim, on_step=None) -> float:
    """One full run with its recorder (as ``run_sim.py run``), in a temporary directory; wall s."""
    from piezotip.cosim.recorder import Recorder

    with tempfile.TemporaryDirectory(prefix="piezotip-bench-") as tmp:
        result = sim.run(Recorder(Path(tmp) / "run"), on_step=on_step)
    if result.error:
        raise RuntimeError(f"benchmark run stopped: {result.error}")
    return result.wall_time_s


def _timed_run(config: ScenarioConfig) -> tuple[float, np.ndarray, list[str], object]:
    """One run: (wall s, the wall time of each control step s, the phase each step ran in, sim).

    A step's phase is the controller's phase when it began (the one whose command it runs).
    Each step's time includes the stamp's own cost (a clock read and two appends, ~0.2 us);
    the first step's is what the run's wall time leaves after the others.
    """
    sim = _new_sim(config)
    clock = time.perf_counter
    stamps: list[float] = []
    phases: list[str] = [sim.controller.phase.label]

    def stamp(s) -> None:
        stamps.append(clock())
        phases.append(s.controller.phase.label)

    wall = _run(sim, on_step=stamp)
    # The first step runs from the run's own start (its wall time counts from there).
    return wall, np.diff([stamps[-1] - wall, *stamps]), phases[: len(stamps)], sim


# ---------------------------------------------------------------------------------------
# Bare mj_step in the co-simulation's own states.
# ---------------------------------------------------------------------------------------

_STATE = mujoco.mjtState.mjSTATE_INTEGRATION


class _StateLog:
    """Captures the integration state and the model values the loop sets before every mj_step
    (through the simulation's own instrument hook, :meth:`CoSimulation.watch_mj_step`)."""

    def __init__(self, sim) -> None:
        self.sim = sim
        self.size = mujoco.mj_stateSize(sim.model, _STATE)
        self.states: list[np.ndarray] = []
        self.settings: list[tuple] = []
        sim.watch_mj_step(self._capture)

    def _capture(self, model, data) -> None:  # the state the step starts from
        state = np.empty(self.size)
        mujoco.mj_getState(model, data, state, _STATE)
        self.states.append(state)
        self.settings.append(self.sim.model_settings())

    def time_bare(self, repeats: int) -> np.ndarray:
        """Time of one mj_step from each captured state, s, shape (repeats, states): the same
        state, the same model values (the gel's tangent stiffness, the force limit, the disable
        flags: MuJoCo's sensors where the loop computes them), nothing else."""
        sim = self.sim
        m = sim.model
        d = mujoco.MjData(m)
        clock, step = time.perf_counter, mujoco.mj_step
        times = np.empty((repeats, len(self.states)))
        for r in range(repeats):
            for i, (state, settings) in enumerate(zip(self.states, self.settings, strict=True)):
                mujoco.mj_setState(m, d, state, _STATE)
                sim.apply_model_settings(settings)
                t0 = clock()
                step(m, d)
                times[r, i] = clock() - t0
        return times


# ---------------------------------------------------------------------------------------
# One case, many cases.
# ---------------------------------------------------------------------------------------


def bench_case(case: BenchCase, repeats: int = 5, duration_s: float | None = None) -> dict:
    """Benchmark one configuration; returns the entry described in the module docstring.

    ``duration_s`` shortens (or lengthens) the simulated time of each run (the run also ends
    when the controller finishes); ``repeats`` is the number of timed runs and of bare passes.
    """
    if repeats < 1:
        raise ValueError(f"repeats must be at least 1, got {repeats!r}")
    config = with_duration(case.config, duration_s)
    phys = config.physics

    capture = _new_sim(config)
    log = _StateLog(capture)
    _run(capture)
    # Timed runs and bare passes alternate, so that both see the machine in the same moods.
    walls, step_times, bare_passes = [], [], []
    for _ in range(repeats):
        wall, per_step, phases, sim = _timed_run(config)
        walls.append(wall)
        step_times.append(per_step)
        bare_passes.append(log.time_bare(1)[0])
    sim_time, steps = sim.time_s, sim.steps
    physics_steps = steps * phys.substeps
    if len({len(t) for t in step_times}) != 1 or len(log.states) != physics_steps:
        raise RuntimeError("the benchmark's runs took different numbers of steps: the scenario is not deterministic")
    wall_min, wall_median = min(walls), statistics.median(walls)
    cosim = np.min(step_times, axis=0)  # per control step, s: the fastest of the runs
    bare_times = np.array(bare_passes)
    bare = bare_times.min(axis=0).reshape(steps, phys.substeps).sum(axis=1)  # per control step, s

    def compare(mask: np.ndarray) -> dict:
        n = int(mask.sum()) * phys.substeps
        c, b = float(cosim[mask].sum()), float(bare[mask].sum())
        return {"control_steps": int(mask.sum()), "cosim_step_us": c / n * 1e6, "bare_step_us": b / n * 1e6, "overhead_ratio": c / b}

    overall = compare(np.ones(steps, bool))
    labels = np.array(phases)
    by_phase = {ph: compare(labels == ph) for ph in dict.fromkeys(phases) if ph}
    wall_per_sim = wall_min / sim_time
    return {
        "name": case.name,
        "scenario": config.name,
        "timestep_s": phys.timestep_s,
        "control_period_s": phys.control_period_s,
        "substeps": phys.substeps,
        "integrator": phys.integrator,
        "pad_segments": phys.pad_segments,
        "dynamics": config.sensor.dynamics,
        "controller": config.controller.kind,
        "sim_time_s": sim_time,
        "control_steps": steps,
        "physics_steps": physics_steps,
        "repeats": repeats,
        "wall_s": wall_min,
        "wall_s_per_sim_s": wall_per_sim,
        "realtime_factor": 1.0 / wall_per_sim,
        "cosim_step_us": overall["cosim_step_us"],
        "bare_step_us": overall["bare_step_us"],
        "overhead_ratio": overall["overhead_ratio"],
        "overhead_ratio_hold": by_phase["hold"]["overhead_ratio"] if "hold" in by_phase else None,
        "by_phase": by_phase,
        "median": {
            "wall_s_per_sim_s": wall_median / sim_time,
            "cosim_step_us": float(np.median(step_times, axis=0).sum()) / physics_steps * 1e6,
            "bare_step_us": float(np.median(bare_times, axis=0).sum()) / physics_steps * 1e6,
            "overhead_ratio": float(np.median(step_times, axis=0).sum() / np.median(bare_times, axis=0).sum()),
        },
    }


def bench_cases(cases: Sequence[BenchCase], repeats: int = 5, duration_s: float | None = None, progress=None) -> list[dict]:
    """:func:`bench_case` for each case, in order (``progress(name)`` is called before each)."""
    out = []
    for case in cases:
        if progress is not None:
            progress(case.name)
        out.append(bench_case(case, repeats=repeats, duration_s=duration_s))
    return out


def bench_report(cases: Sequence[BenchCase], repeats: int = 5, duration_s: float | None = None, progress=None) -> dict:
    """The benchmark report: the first case's numbers at the top level, every case in ``scenes``."""
    if not cases:
        raise ValueError("nothing to benchmark")
    entries = bench_cases(cases, repeats=repeats, duration_s=duration_s, progress=progress)
    first = entries[0]
    keys = (
        "overhead_ratio",
        "overhead_ratio_hold",
        "realtime_factor",
        "wall_s_per_sim_s",
        "bare_step_us",
        "cosim_step_us",
    )
    return {
        "scene": first["name"],
        **{k: first[k] for k in keys},
        "machine": {
            "mujoco": mujoco.__version__,
            "numpy": np.__version__,
            "cpus": os.cpu_count(),
            "load_avg_1min": os.getloadavg()[0] if hasattr(os, "getloadavg") else None,
        },
        "scenes": entries,
    }


# ---------------------------------------------------------------------------------------
# Output.
# ---------------------------------------------------------------------------------------


def format_report(report: dict) -> str:
    """A readable table: one line per case, then the first case's overhead by controller phase."""
    lines = [
        f"co-simulation cost (fastest of {report['scenes'][0]['repeats']} runs; ratio = co-simulation time per physics step"
        " over bare mj_step's in the same states)",
        "",
        f"{'case':<16} {'dt ms':>6} {'ctrl ms':>7} {'sim s':>6} {'wall s/sim s':>12} {'RT factor':>9} "
        f"{'cosim us':>9} {'bare us':>8} {'ratio':>6}",
    ]
    for e in report["scenes"]:
        lines.append(
            f"{e['name']:<16} {1e3 * e['timestep_s']:>6.3g} {1e3 * e['control_period_s']:>7.3g} {e['sim_time_s']:>6.2f} "
            f"{e['wall_s_per_sim_s']:>12.4f} {e['realtime_factor']:>9.1f} {e['cosim_step_us']:>9.1f} "
            f"{e['bare_step_us']:>8.1f} {e['overhead_ratio']:>6.2f}"
        )
    first = report["scenes"][0]
    lines += ["", f"by controller phase ({first['name']}): control steps, us per physics step, ratio"]
    for phase, e in first["by_phase"].items():
        us = f"{e['cosim_step_us']:>9.1f} {e['bare_step_us']:>8.1f}"
        lines.append(f"  {phase:<10} {e['control_steps']:>6} {us} {e['overhead_ratio']:>6.2f}")
    return "\n".join(lines)


def plot_report(report: dict, path: Path) -> Path:
    """The first case's time per physics step against bare mj_step's, by controller phase, and
    each case's cost (Pareto-ready: one point per case at its wall time per simulated second)."""
    from piezotip.analysis.plotting import new_figure, save_figure

    fig, axes = new_figure(1, 2, figsize=(11, 4.2))
    first = report["scenes"][0]
    ax = axes[0][0]
    phases = ["whole run", *first["by_phase"]]
    entries = [first, *first["by_phase"].values()]
    rows = np.arange(len(phases))
    ax.barh(rows - 0.2, [e["cosim_step_us"] for e in entries], height=0.4, label="co-simulation")
    ax.barh(rows + 0.2, [e["bare_step_us"] for e in entries], height=0.4, color="0.5", label="bare mj_step")
    ax.set_yticks(rows, phases)
    ax.invert_yaxis()
    ax.set_xlabel("time per physics step [us]")
    ax.set_title(f"{first['name']}: overhead {first['overhead_ratio']:.2f}x")
    ax.legend(fontsize=7, loc="best")

    ax = axes[0][1]
    for e in report["scenes"]:
        ax.scatter(e["wall_s_per_sim_s"], e["realtime_factor"], s=30)
        ax.annotate(e["name"], (e["wall_s_per_sim_s"], e["realtime_factor"]), fontsize=7, xytext=(3, 3), textcoords="offset points")
    ax.set_xlabel("wall time per simulated second [s]")
    ax.set_ylabel("real-time factor")
    ax.set_title("cost per configuration")
    return save_figure(fig, path)


def write_report(report: dict, out_dir: Path) -> list[Path]:
    """bench.json and bench.png into ``out_dir``."""
    import json

    from piezotip.analysis.runner import json_safe  # NaN and inf are not JSON

    out_dir.mkdir(parents=True, exist_ok=True)
    json_path = out_dir / "bench.json"
    json_path.write_text(json.dumps(json_safe(report), indent=2) + "\n")
    return [json_path, plot_report(report, out_dir / "bench.png")]
