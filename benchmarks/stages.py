"""Where a control step's time goes: each stage's wall time per control step, beside bare mj_step.

    python -m benchmarks.stages [--scenario NAME] [--set KEY=VALUE ...] [--preset NAME] [--repeats N] [--duration S] [--json]

A control step's stages (physics, of which the gel forces; pressure, sensor, readout,
controller, actuators, record; "other" is what the step spends outside them, the loop's own
bookkeeping) are timed in ``repeats`` runs of the scenario as ``run_sim.py run`` runs it
(recorder included, into a temporary folder), a timer around each stage method
(``CoSimulation.wrap_stages``: ``CoSimulation.advance`` calls one method per stage, nothing
patched) and around the recorder's appends, the timers' own cost subtracted; each stage's
fastest run is kept (noise only ever adds time).  Timers disturb what they measure (caches, a
few hundred ns each): the stages are shares of the cost, the totals come from the plain runs,
which are the product's own ``bench`` (:func:`piezotip.reports.bench.bench_case`: the step's
time, bare ``mj_step``'s in the same states, their ratio), run first on the same config.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from piezotip.cosim.loop import STAGE_METHODS

#: Stage names, in the order of a control step (the gel forces, timed too, run inside physics).
STAGES = tuple(stage for stage in STAGE_METHODS if stage != "gel_forces")


def _noop(*args) -> None:
    return None


def wrapper_costs(samples: int = 20000) -> tuple[float, float]:
    """What a stage timer costs, s: (inside the region it measures, in all).

    Measured on an empty function: the first is what the timer reports for it (two clock
    reads and the call), the second the whole wrapped call less a direct one; a stage's total
    is corrected by the first per call, an enclosing stage (physics, around the gel forces)
    by the second per nested call.
    """
    clock = time.perf_counter
    inside, whole = math.inf, math.inf
    for _ in range(5):
        stage = StageClock.__new__(StageClock)
        stage.totals, stage.calls = {"x": 0.0}, {"x": 0}
        timed = stage.timed("x", _noop)
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


class StageClock:
    """Timers around each stage of one CoSimulation (:meth:`CoSimulation.wrap_stages`) and the
    recorder's appends (part of the record stage)."""

    def __init__(self, sim, recorder) -> None:
        self.totals = dict.fromkeys((*STAGES, "gel_forces"), 0.0)
        self.calls = dict.fromkeys(self.totals, 0)
        sim.wrap_stages(self.timed)
        for name in ("append_values", "append"):
            setattr(recorder, name, self.timed("record", getattr(recorder, name)))

    def timed(self, stage: str, fn: Callable) -> Callable:
        totals, calls, clock = self.totals, self.calls, time.perf_counter

        def timed(*args, **kwargs):
            t0 = clock()
            try:
                return fn(*args, **kwargs)
            finally:
                totals[stage] += clock() - t0
                calls[stage] += 1

        return timed


def stage_times(config, repeats: int) -> dict[str, float]:
    """Each stage's wall time per control step, us, from ``repeats`` instrumented runs of
    ``config`` (a ScenarioConfig; each stage's fastest), the timers' own cost removed; "other"
    is the rest of the instrumented step (the loop's bookkeeping).  Keys: physics, gel_forces
    (a part of physics), the other stages in their order, other."""
    from piezotip.cosim.loop import CoSimulation
    from piezotip.cosim.recorder import Recorder

    if repeats < 1:
        raise ValueError(f"repeats must be at least 1, got {repeats!r}")
    inside, whole = wrapper_costs()
    best: dict[str, float] = {}
    for _ in range(repeats):
        sim = CoSimulation(config)
        with tempfile.TemporaryDirectory(prefix="piezotip-stages-") as tmp:
            recorder = Recorder(Path(tmp) / "run")
            clock = StageClock(sim, recorder)
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
    return {k: best[k] for k in ("physics", "gel_forces", *STAGES[1:], "other")}


def stages_report(name: str, config, repeats: int = 5, duration_s: float | None = None) -> dict:
    """The product's bench entry of ``config`` (its step time, bare mj_step's, their ratio) and
    the stage times of the same config, ``duration_s`` simulated seconds a run (None: the
    config's): ``stages_us`` (us per control step), ``stages_share`` (each stage's share of the
    step, gel forces inside physics)."""
    from piezotip.reports.bench import BenchCase, bench_case

    entry = bench_case(BenchCase(name, config), repeats=repeats, duration_s=duration_s)  # checks the duration
    if duration_s is not None:
        config = dataclasses.replace(config, duration_s=float(duration_s)).validate()
    stages = stage_times(config, repeats)
    total = sum(v for k, v in stages.items() if k != "gel_forces")  # gel forces are part of physics
    keep = ("name", "scenario", "substeps", "control_steps", "repeats", "cosim_step_us", "bare_step_us", "overhead_ratio")
    return {
        **{k: entry[k] for k in keep},
        "stages_unit": "us per control step",
        "stages_us": stages,
        "stages_share": {k: v / total for k, v in stages.items()} if total > 0 else {},
        "stages_note": "physics includes gel_forces; other = step time not in a stage (loop bookkeeping)",
    }


def format_stages(report: dict) -> str:
    """The stages as a table, bare mj_step's share beside them."""
    stages, substeps = report["stages_us"], report["substeps"]
    total = sum(v for k, v in stages.items() if k != "gel_forces")
    lines = [
        f"stages of one control step ({report['name']}, {substeps} physics steps; fastest of {report['repeats']} runs), us:",
    ]
    for name, us in stages.items():
        label = "  of which gel forces" if name == "gel_forces" else name
        share = f"{100 * us / total:>5.1f} %" if total > 0 else ""
        lines.append(f"  {label:<22} {us:>8.1f}  {share}")
    lines.append(f"  {'bare mj_step x ' + str(substeps):<22} {report['bare_step_us'] * substeps:>8.1f}")
    lines.append(f"  (the plain runs: {report['cosim_step_us'] * substeps:.1f} us a control step, ratio {report['overhead_ratio']:.2f})")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    from piezotip import scenarios
    from piezotip.scenarios.presets import PRESETS, preset_overrides

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="grasp", help="the scenario timed (default grasp)")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="override a config value (repeatable)")
    parser.add_argument("--preset", choices=tuple(PRESETS), help="fidelity preset (default: the scenario's own settings)")
    parser.add_argument("--repeats", type=int, default=5, help="timed runs of each kind; the fastest is kept (default 5)")
    parser.add_argument("--duration", type=float, metavar="SECONDS", help="simulated seconds per run (default: the scenario's)")
    parser.add_argument("--json", action="store_true", help="print the report as JSON")
    args = parser.parse_args(argv)
    try:
        config = scenarios.get(args.scenario, [*preset_overrides(args.preset), *args.set])
        report = stages_report(args.scenario, config, repeats=args.repeats, duration_s=args.duration)
    except ValueError as err:  # a bad scenario, override, repeat count or duration
        parser.error(str(err))
    except RuntimeError as err:  # a run diverged or was not deterministic
        print(f"error: {err}", file=sys.stderr)
        return 1
    print(json.dumps(report, indent=2) if args.json else format_stages(report))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
