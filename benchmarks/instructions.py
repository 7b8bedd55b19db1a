"""The loop's own cost in instructions: a measure no neighbour on a shared machine disturbs.

    python -m benchmarks.instructions [--scenario NAME] [--set KEY=VALUE ...] [--preset NAME] [--steps N] [--json]

Timed ratios on a shared VM swing by several percent from one run to the next, more than a
change to the loop's Python moves them.  Counted instructions do not: valgrind's callgrind
counts every instruction a process executes, and how many of them ran inside ``mj_step``
(inclusive of everything it calls).  Two runs of the same scenario, ``warmup_steps`` and
``warmup_steps + steps`` control steps (the set-up, imports and first steps identical in
both), differ by ``steps`` control steps of the loop alone:

- ``mj_step_per_step``: instructions inside ``mj_step`` per control step (all its substeps);
- ``loop_per_step``: instructions outside it per control step (the co-simulation's Python,
  its compiled parts, the recorder is not run);
- ``instruction_ratio`` = (loop + mj_step) / mj_step: the overhead ratio's instruction-count
  counterpart (lower than the timed one: Python's instructions run slower than MuJoCo's, and
  the cache misses each causes the other are not instructions).

Repeated, the counts agree to about ten thousand instructions a run (a few per step over the
default 1000 steps): one hash seed and one BLAS thread make the rest the same.

About a minute (valgrind runs Python some 50x slower); needs valgrind on the PATH.  The disk
cache of set-up tables is filled first by a plain run, so that neither counted run computes
them, and the project's bytecode compiled, so that neither compiles a module.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Mapping
from pathlib import Path

if not __package__:  # run as a file (python benchmarks/instructions.py): its siblings by their package's name
    sys.path.append(str(Path(__file__).resolve().parents[1]))  # last: the installed piezotip comes first

from benchmarks.revisions import compile_bytecode, source_folders

#: The counted runs' script: the scenario's simulation, stepped ``n`` control steps (argv: n,
#: scenario, overrides...).
_SCRIPT = (
    "import sys\n"
    "from piezotip import scenarios\n"
    "from piezotip.cosim.loop import CoSimulation\n"
    "sim = CoSimulation(scenarios.get(sys.argv[2], sys.argv[3:]))\n"
    "for _ in range(int(sys.argv[1])):\n"
    "    sim.advance()\n"
)

_TOTAL = re.compile(r"^\s*([\d,]+)\s.*PROGRAM TOTALS", re.MULTILINE)
_MJ_STEP = re.compile(r"^\s*([\d,]+)\s.*[:\s]mj_step\s+\[", re.MULTILINE)


def parse_annotation(text: str) -> tuple[int, int]:
    """(all instructions, instructions inside ``mj_step``) from ``callgrind_annotate
    --inclusive=yes`` output; 0 for ``mj_step`` when it never ran.  Raises ValueError when the
    text has no program total (not an annotation)."""
    total = _TOTAL.search(text)
    if total is None:
        raise ValueError("no 'PROGRAM TOTALS' line: not callgrind_annotate output")
    step = _MJ_STEP.search(text)
    return int(total.group(1).replace(",", "")), int(step.group(1).replace(",", "")) if step else 0


#: glibc's heap padding for the counted runs, in bytes: past valgrind's cap on a client's brk
#: segment (8 MiB, valgrind 3.x's initimg), so that the heap's first growth is refused once, at
#: start-up, and glibc takes one mapping this large in its place, which the run never outgrows.
HEAP_TOP_PAD_BYTES = 1 << 30


def counted_env(base: Mapping[str, str]) -> dict[str, str]:
    """The environment of a counted run: ``base`` with one hash seed, one BLAS thread, the Agg
    backend and glibc's heap padded by :data:`HEAP_TOP_PAD_BYTES`.

    - One hash seed: string hashes, and so dict and set probing, differ from process to process
      otherwise (a few thousand instructions a step).
    - One BLAS thread: an idle OpenBLAS thread spins, and what it counts depends on timing.
    - The padded heap: under valgrind, every growth of glibc's heap past the 8 MiB brk cap is
      refused (glibc then maps the memory instead) and leaves ``errno`` at ENOMEM.  MuJoCo's XML
      reader takes any ``errno`` left after it parses a number as that number's error, so a
      growth that falls inside it fails the model with "unknown error in attribute 'pos'".
      Where the growths fall depends on the environment's size and paths: it passed on one
      machine and failed on the CI's.  Padded, the heap grows once, at start-up, before any model.
    """
    tunables = [t for t in base.get("GLIBC_TUNABLES", "").split(":") if t and not t.startswith("glibc.malloc.top_pad=")]
    blas = dict.fromkeys(("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"), "1")
    return {
        **base,
        "MPLBACKEND": "Agg",
        "PYTHONHASHSEED": "0",
        **blas,
        "GLIBC_TUNABLES": ":".join([*tunables, f"glibc.malloc.top_pad={HEAP_TOP_PAD_BYTES}"]),
    }


def _start_count(steps: int, scenario: str, overrides: list[str], work: Path, env: dict[str, str]) -> tuple[subprocess.Popen, Path, int]:
    """A counted run of ``steps`` control steps, started: (its process, its callgrind file, steps)."""
    out = work / f"callgrind.{steps}"
    cmd = ["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", sys.executable, "-c", _SCRIPT, str(steps), scenario, *overrides]
    return subprocess.Popen(cmd, env=env, cwd=work, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True), out, steps


def _counted(run: tuple[subprocess.Popen, Path, int]) -> tuple[int, int]:
    """A started counted run (:func:`_start_count`) waited for: (all instructions, those inside mj_step)."""
    proc, out, steps = run
    _, stderr = proc.communicate()
    if proc.returncode != 0:
        raise RuntimeError(f"the counted run of {steps} steps failed ({proc.returncode}): {stderr.strip()[-500:]}")
    # Every function listed (the default lists only those that make 99 % of the total).
    annotated = subprocess.run(
        ["callgrind_annotate", "--inclusive=yes", "--threshold=100", str(out)], capture_output=True, text=True, check=True
    )
    return parse_annotation(annotated.stdout)


def instruction_counts(
    scenario: str = "grasp", overrides: list[str] | None = None, steps: int = 1000, warmup_steps: int = 200, side_by_side: bool = False
) -> dict:
    """Instructions per control step of ``scenario``'s loop, inside and outside ``mj_step``
    (the module docstring).  ``side_by_side`` runs the two counted runs at once, in the time of
    one on two cores; ``mj_step``'s count is the same, but the loop's comes out about 3 % higher
    (113,000 against 110,000 instructions a step over 20 steps of the grasp, each way repeated
    within 0.2 %), so the command line counts them one after the other.  Raises RuntimeError
    naming what is missing when valgrind or callgrind_annotate is not on the PATH, or when a
    run fails."""
    if steps < 1 or warmup_steps < 1:
        raise ValueError(f"steps and warmup_steps must be at least 1, got {steps} and {warmup_steps}")
    missing = [tool for tool in ("valgrind", "callgrind_annotate") if shutil.which(tool) is None]
    if missing:
        raise RuntimeError(f"counting instructions needs {' and '.join(missing)} on the PATH (valgrind's package)")
    overrides = list(overrides or [])
    env = counted_env(os.environ)
    # Bytecode compiled first: a module imported between the two runs' ends would otherwise be
    # compiled inside the counted steps (under PYTHONDONTWRITEBYTECODE, by every run).
    compile_bytecode(*source_folders())
    with tempfile.TemporaryDirectory(prefix="piezotip-instructions-") as tmp:
        work = Path(tmp)
        # The set-up tables on disk first: neither counted run computes them.
        # (Run from the temporary folder: the current one could hold a folder named piezotip.)
        warm = subprocess.run([sys.executable, "-c", _SCRIPT, "1", scenario, *overrides], env=env, cwd=work, capture_output=True, text=True)
        if warm.returncode != 0:
            raise RuntimeError(f"{scenario} with {overrides} does not run: {warm.stderr.strip()[-500:]}")
        runs, counts = [], []
        try:
            for n in (warmup_steps, warmup_steps + steps):
                runs.append(_start_count(n, scenario, overrides, work, env))
                if not side_by_side:
                    counts.append(_counted(runs[-1]))
            counts = counts or [_counted(run) for run in runs]
            (short_total, short_step), (long_total, long_step) = counts
        finally:
            for proc, *_ in runs:
                if proc.poll() is None:
                    proc.kill()
                    proc.wait()
    mj_step = (long_step - short_step) / steps
    loop = ((long_total - long_step) - (short_total - short_step)) / steps
    return {
        "scenario": scenario,
        "overrides": overrides,
        "steps": steps,
        "warmup_steps": warmup_steps,
        "mj_step_per_step": mj_step,
        "loop_per_step": loop,
        "instruction_ratio": (loop + mj_step) / mj_step if mj_step > 0 else float("nan"),
    }


def format_instructions(report: dict) -> str:
    """The counts as text."""
    return "\n".join(
        [
            f"instructions per control step ({report['scenario']}, control steps {report['warmup_steps']} to "
            f"{report['warmup_steps'] + report['steps']}, callgrind):",
            f"  inside mj_step      {report['mj_step_per_step']:>12,.0f}",
            f"  the loop's own      {report['loop_per_step']:>12,.0f}",
            f"  ratio (loop + mj_step) / mj_step  {report['instruction_ratio']:.3f}",
        ]
    )


def main(argv: list[str] | None = None) -> int:
    from piezotip.scenarios.presets import PRESETS, preset_overrides

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="grasp", help="the scenario whose loop is counted (default grasp)")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="override a config value (repeatable)")
    parser.add_argument("--preset", choices=tuple(PRESETS), help="fidelity preset (default: the scenario's own settings)")
    parser.add_argument("--steps", type=int, default=1000, help="control steps counted (default 1000)")
    parser.add_argument("--warmup-steps", type=int, default=200, help="control steps before the counted ones (default 200)")
    parser.add_argument("--json", action="store_true", help="print the counts as JSON")
    args = parser.parse_args(argv)
    overrides = [*preset_overrides(args.preset), *args.set]
    try:
        counts = instruction_counts(args.scenario, overrides, steps=args.steps, warmup_steps=args.warmup_steps)
    except ValueError as err:
        parser.error(str(err))
    except RuntimeError as err:  # valgrind missing, or a counted run failed
        print(f"error: {err}", file=sys.stderr)
        return 1
    print(json.dumps(counts, indent=2) if args.json else format_instructions(counts))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
