"""A sweep's fixed cost: a one-point sweep against the same single run, timed side by side in one
run (``python -m benchmarks.sweep_cost [--command] [--pairs N] [--json]`` from the repository root).

Each call is timed in a fresh Python process, as a script that calls the API pays it: the call
and the imports it makes (not the interpreter's own start).  ``--command`` times the command
lines instead, whole processes as a shell waits for them: ``sweep --grid KEY=VALUE`` against
``run --set KEY=VALUE``, both ``--no-plot`` (their figures differ).  The two alternate, after an
untimed pair that fills the disk cache of set-up tables (a temporary folder, never the user's),
so that a load on the machine falls on both; the report is the median of the pairs' differences
(the fixed cost) and of their ratios.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

#: What is timed: the grasp at the fast preset (the cheapest run, so the fixed cost shows most),
#: its object's default mass as the one point.
SCENARIO, PRESET, POINT = "grasp", "fast", "object.mass_kg=0.1"

#: The child that times an API call: the seconds on its last line.
_TIMED_CALL = "import time\nstart = time.perf_counter()\nimport piezotip\n{call}\nprint(time.perf_counter() - start)\n"


def _api_seconds(call: str, env: dict[str, str]) -> float:
    proc = subprocess.run([sys.executable, "-c", _TIMED_CALL.format(call=call)], env=env, capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"{call} failed: {proc.stderr.strip()[-500:]}")
    return float(proc.stdout.splitlines()[-1])


def _command_seconds(args: list[str], env: dict[str, str]) -> float:
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "piezotip.cli", *args], env=env, capture_output=True, text=True)
    seconds = time.perf_counter() - start
    if proc.returncode not in (0, 1):  # 1: the run's outcome was not a success, which costs the same
        raise RuntimeError(f"run_sim.py {' '.join(args)} failed ({proc.returncode}): {proc.stderr.strip()[-500:]}")
    return seconds


def measure(pairs: int = 5, command: bool = False) -> dict:
    """Seconds of ``pairs`` alternating one-point sweeps and single runs, and their medians."""
    if pairs < 1:
        raise ValueError(f"--pairs must be at least 1, got {pairs}")
    key, _, value = POINT.partition("=")
    with tempfile.TemporaryDirectory(prefix="piezotip-sweep-cost-") as tmp:
        env = {**os.environ, "PIEZOTIP_CACHE_DIR": str(Path(tmp) / "cache"), "MPLBACKEND": "Agg"}
        env.pop("PIEZOTIP_CACHE", None)

        def sweep(i: int) -> float:
            if command:  # a fresh --out each time: a folder with the point done would skip it
                args = ["sweep", SCENARIO, "--grid", POINT, "--preset", PRESET, "--no-plot", "--json", "--out", f"{tmp}/sweep{i}"]
                return _command_seconds(args, env)
            return _api_seconds(f"piezotip.sweep({SCENARIO!r}, {{{key!r}: [{value!r}]}}, preset={PRESET!r})", env)

        def run(i: int) -> float:
            if command:
                args = ["run", SCENARIO, "--set", POINT, "--preset", PRESET, "--no-plot", "--json", "--out", f"{tmp}/run{i}"]
                return _command_seconds(args, env)
            return _api_seconds(f"piezotip.run({SCENARIO!r}, [{POINT!r}], preset={PRESET!r})", env)

        sweep(-1), run(-1)  # untimed: the cache of set-up tables filled
        times = [(sweep(i), run(i)) for i in range(pairs)]
    sweeps, runs = [s for s, _ in times], [r for _, r in times]
    return {
        "what": "commands" if command else "API calls",
        "point": f"{SCENARIO}, preset {PRESET}, {POINT}",
        "sweep_s": sweeps,
        "run_s": runs,
        "fixed_cost_s": statistics.median(s - r for s, r in times),
        "ratio": statistics.median(s / r for s, r in times),
    }


def format_cost(report: dict) -> str:
    """The report as a few lines of text."""
    lines = [f"one-point sweep against the same run ({report['point']}), {report['what']}, {len(report['sweep_s'])} pairs:"]
    for name in ("sweep", "run"):
        seconds = report[f"{name}_s"]
        lines.append(f"  {name:<5}  median {statistics.median(seconds):.2f} s  ({min(seconds):.2f} .. {max(seconds):.2f})")
    lines.append(f"  fixed cost (sweep - run) {report['fixed_cost_s']:.2f} s, ratio {report['ratio']:.2f} (medians of the pairs')")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.sweep_cost", description=__doc__.split("\n\n")[0])
    parser.add_argument("--command", action="store_true", help="time the command lines (sweep, run), not the API calls")
    parser.add_argument("--pairs", type=int, default=5, help="alternating pairs timed (default 5)")
    parser.add_argument("--json", action="store_true", help="print the report as JSON")
    args = parser.parse_args(argv)
    report = measure(args.pairs, args.command)
    print(json.dumps(report, indent=2) if args.json else format_cost(report))
    return 0


if __name__ == "__main__":
    sys.exit(main())
