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
- ``overhead_ratio`` = cosim_step_us / bare_step_us over the whole run (the issue's target:
  at most 1.35, on the way to 1.2), and the same per controller phase in ``by_phase`` (``overhead_ratio_hold``:
  during the held grasp, where the contacts make mj_step dearest);
- ``stages_us``: the time of each stage of a control step (physics incl. gel forces, of
  which gel forces, pressure, sensor, readout, controller, actuators, record, other), from
  ``repeats`` more runs with a timer around each stage method (``CoSimulation.wrap_stages``:
  CoSimulation.advance calls one method per stage), the timers' own cost subtracted.

The runs are deterministic (seeded noise, single-threaded MuJoCo), so every run passes
through the same states.  Performance claims come from here, never from a timed unit test.
"""

from __future__ import annotations

import dataclasses
import math
import os
import statistics
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from piezotip.cosim.loop import STAGE_METHODS
from piezotip.scenarios.config import ScenarioConfig

#: The issue's targets.
TARGET_OVERHEAD_RATIO = 1.35
TARGET_REALTIME_FACTOR = 20.0

#: Stage names, in the order of a control step (the gel forces, timed too, run inside physics).
STAGES = tuple(stage for stage in STAGE_METHODS if stage != "gel_forces")


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
# Stage timing.
# ---------------------------------------------------------------------------------------


def _noop(*args) -> None:
    return None


def _wrapper_costs(samples: int = 20000) -> tuple[float, float]:
    """What a stage timer costs, s: (inside the region it measures, in all).

    Measured on an empty function: the first is what the timer reports for it (two clock
    reads and the call), the second the whole wrapped call less a direct one; a stage's total
    is corrected by the first per call, an enclosing stage (physics, around the gel forces)
    by the second per nested call.
    """
    clock = time.perf_counter
    inside, whole = math.inf, math.inf
    for _ in range(5):
        stage = _StageClock.__new__(_StageClock)
        stage.totals, stage.calls = {"x": 0.0}, {"x": 0}
        timed = stage._timed("x", _noop)
        t0 = clock()
        for _ in range(samples):
            timed(None)
        t1 = clock()
        for _ in range(samples):
            _noop(None)
        t2 = clock()
        inside = min(inside, stage.totals["x"] / samples)
        whole = min(whole, ((t1 - t0) - (t2 - t1)) / samples)
    return inside, max(whole, inside)


class _StageClock:
    """Timers around each stage of one CoSimulation (:meth:`CoSimulation.wrap_stages`) and the
    recorder's appends (part of the record stage)."""

    def __init__(self, sim, recorder) -> None:
        self.totals = dict.fromkeys((*STAGES, "gel_forces"), 0.0)
        self.calls = dict.fromkeys(self.totals, 0)
        sim.wrap_stages(self._timed)
        for name in ("append_values", "append"):
            setattr(recorder, name, self._timed("record", getattr(recorder, name)))

    def _timed(self, stage: str, fn: Callable) -> Callable:
        totals, calls, clock = self.totals, self.calls, time.perf_counter

        def timed(*args, **kwargs):
            t0 = clock()
            try:
                return fn(*args, **kwargs)
            finally:
                totals[stage] += clock() - t0
                calls[stage] += 1

        return timed


def _stage_times(config: ScenarioConfig, repeats: int) -> dict[str, float]:
    """Each stage's wall time per control step, us, from ``repeats`` instrumented runs (each
    stage's fastest), the timers' own cost removed; "other" is the rest of the instrumented
    step (the loop's bookkeeping).  Timers disturb what they measure (caches, a few hundred
    ns each): the stages are shares of the cost, the totals come from the plain runs."""
    from piezotip.cosim.recorder import Recorder

    inside, whole = _wrapper_costs()
    best: dict[str, float] = {}
    for _ in range(repeats):
        sim = _new_sim(config)
        with tempfile.TemporaryDirectory(prefix="piezotip-bench-") as tmp:
            recorder = Recorder(Path(tmp) / "run")
            clock = _StageClock(sim, recorder)
            result = sim.run(recorder)
        if result.error:
            raise RuntimeError(f"benchmark run stopped: {result.error}")
        steps = max(result.steps, 1)
        stages = {stage: max(total - clock.calls[stage] * inside, 0.0) / steps * 1e6 for stage, total in clock.totals.items()}
        # The gel forces are timed inside physics: their whole timers are in physics' total.
        stages["physics"] = max(stages["physics"] - clock.calls["gel_forces"] * whole / steps * 1e6, 0.0)
        step = (result.wall_time_s - sum(clock.calls.values()) * whole) / steps * 1e6
        stages["other"] = max(step - sum(stages[s] for s in STAGES), 0.0)
        best = {k: min(v, best.get(k, math.inf)) for k, v in stages.items()}
    return best


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
    config = case.config
    if duration_s is not None:
        if not (math.isfinite(duration_s) and duration_s > 0):
            raise ValueError(f"duration must be a positive number of seconds, got {duration_s!r}")
        config = dataclasses.replace(config, duration_s=float(duration_s)).validate()
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
    stages = _stage_times(config, repeats)
    wall_per_sim = wall_min / sim_time
    ratio = overall["overhead_ratio"]
    stage_sum = sum(v for k, v in stages.items() if k != "gel_forces")  # gel forces are part of physics
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
        "overhead_ratio": ratio,
        "overhead_ratio_hold": by_phase["hold"]["overhead_ratio"] if "hold" in by_phase else None,
        "by_phase": by_phase,
        "median": {
            "wall_s_per_sim_s": wall_median / sim_time,
            "cosim_step_us": float(np.median(step_times, axis=0).sum()) / physics_steps * 1e6,
            "bare_step_us": float(np.median(bare_times, axis=0).sum()) / physics_steps * 1e6,
            "overhead_ratio": float(np.median(step_times, axis=0).sum() / np.median(bare_times, axis=0).sum()),
        },
        "stages_unit": "us per control step",
        "stages_us": {k: stages[k] for k in ("physics", "gel_forces", *STAGES[1:], "other")},
        "stages_share": {k: v / stage_sum for k, v in stages.items()} if stage_sum > 0 else {},
        "stages_note": "physics includes gel_forces; other = step time not in a stage (loop bookkeeping)",
        "meets_targets": bool(ratio <= TARGET_OVERHEAD_RATIO and 1.0 / wall_per_sim >= TARGET_REALTIME_FACTOR),
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
        "stages_us",
        "stages_unit",
    )
    return {
        "scene": first["name"],
        **{k: first[k] for k in keys},
        "targets": {"overhead_ratio_max": TARGET_OVERHEAD_RATIO, "realtime_factor_min": TARGET_REALTIME_FACTOR},
        "meets_targets": first["meets_targets"],
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
    """A readable table: one line per case, then the stage breakdown of the first."""
    lines = [
        f"co-simulation cost (fastest of {report['scenes'][0]['repeats']} runs; targets: overhead <= "
        f"{report['targets']['overhead_ratio_max']:g}x bare mj_step, >= {report['targets']['realtime_factor_min']:g}x real time)",
        "",
        f"{'case':<16} {'dt ms':>6} {'ctrl ms':>7} {'sim s':>6} {'wall s/sim s':>12} {'RT factor':>9} "
        f"{'cosim us':>9} {'bare us':>8} {'ratio':>6}  ok",
    ]
    for entries in (report["scenes"],):
        for e in entries:
            lines.append(
                f"{e['name']:<16} {1e3 * e['timestep_s']:>6.3g} {1e3 * e['control_period_s']:>7.3g} {e['sim_time_s']:>6.2f} "
                f"{e['wall_s_per_sim_s']:>12.4f} {e['realtime_factor']:>9.1f} {e['cosim_step_us']:>9.1f} "
                f"{e['bare_step_us']:>8.1f} {e['overhead_ratio']:>6.2f}  {'yes' if e['meets_targets'] else 'NO'}"
            )
    first = report["scenes"][0]
    lines += ["", f"by controller phase ({first['name']}): control steps, us per physics step, ratio"]
    for phase, e in first["by_phase"].items():
        us = f"{e['cosim_step_us']:>9.1f} {e['bare_step_us']:>8.1f}"
        lines.append(f"  {phase:<10} {e['control_steps']:>6} {us} {e['overhead_ratio']:>6.2f}")
    stages = first["stages_us"]
    total = sum(v for k, v in stages.items() if k != "gel_forces")
    lines += ["", f"stages of one control step ({first['name']}, {first['substeps']} physics steps), us:"]
    for name, us in stages.items():
        label = "  of which gel forces" if name == "gel_forces" else name
        lines.append(f"  {label:<22} {us:>8.1f}  {100 * us / total:>5.1f} %")
    lines.append(f"  {'bare mj_step x ' + str(first['substeps']):<22} {first['bare_step_us'] * first['substeps']:>8.1f}")
    return "\n".join(lines)


def plot_report(report: dict, path: Path) -> Path:
    """Stage bars of the first case against bare mj_step, and each case's cost (Pareto-ready:
    one point per case at its wall time per simulated second)."""
    from .plotting import new_figure, save_figure

    fig, axes = new_figure(1, 2, figsize=(11, 4.2))
    first = report["scenes"][0]
    per_physics = {k: v / first["substeps"] for k, v in first["stages_us"].items() if k != "gel_forces"}
    ax = axes[0][0]
    left = 0.0
    for name, us in per_physics.items():
        ax.barh(["co-simulation"], [us], left=left, label=name)
        left += us
    ax.barh(["bare mj_step"], [first["bare_step_us"]], color="0.5")
    ax.axvline(first["bare_step_us"] * TARGET_OVERHEAD_RATIO, color="k", ls="--", lw=1, label=f"{TARGET_OVERHEAD_RATIO:g}x bare")
    ax.set_xlabel("time per physics step [us]")
    ax.set_title(f"{first['name']}: overhead {first['overhead_ratio']:.2f}x")
    ax.legend(fontsize=7, loc="lower right")

    ax = axes[0][1]
    entries = report["scenes"]
    for e in entries:
        ax.scatter(e["wall_s_per_sim_s"], e["realtime_factor"], s=30)
        ax.annotate(e["name"], (e["wall_s_per_sim_s"], e["realtime_factor"]), fontsize=7, xytext=(3, 3), textcoords="offset points")
    ax.axhline(TARGET_REALTIME_FACTOR, color="k", ls="--", lw=1, label=f"{TARGET_REALTIME_FACTOR:g}x real time")
    ax.set_xlabel("wall time per simulated second [s]")
    ax.set_ylabel("real-time factor")
    ax.set_title("cost per configuration")
    ax.legend(fontsize=7)
    return save_figure(fig, path)


def write_report(report: dict, out_dir: Path) -> list[Path]:
    """bench.json and bench.png into ``out_dir``."""
    import json

    from .runner import json_safe  # NaN and inf are not JSON

    out_dir.mkdir(parents=True, exist_ok=True)
    json_path = out_dir / "bench.json"
    json_path.write_text(json.dumps(json_safe(report), indent=2) + "\n")
    return [json_path, plot_report(report, out_dir / "bench.png")]
