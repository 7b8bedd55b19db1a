"""The loop's own cost in instructions: a measure no neighbour on a shared machine disturbs.

    python -m benchmarks.instructions [--scenario NAME] [--set KEY=VALUE ...] [--preset NAME] [--steps N] [--json]

Timed ratios on a shared VM swing by several percent from one run to the next, more than a
change to the loop's Python moves them.  Counted instructions do not: valgrind's callgrind
counts every instruction a process executes, and how many of them ran inside ``mj_step``
(inclusive of everything it calls).  One counted run steps the scenario ``warmup_steps``
control steps, calls a marker, steps ``steps`` more and calls the marker again; callgrind dumps
its counts at each call of the marker (``--dump-before``), so the part between the two holds the
counted steps alone, the set-up, imports, first steps and the interpreter's exit outside it:

- ``mj_step_per_step``: instructions inside ``mj_step`` per control step (all its substeps);
- ``loop_per_step``: instructions outside it per control step (the co-simulation's Python,
  its compiled parts, the recorder is not run);
- ``instruction_ratio`` = (loop + mj_step) / mj_step: the overhead ratio's instruction-count
  counterpart (lower than the timed one: Python's instructions run slower than MuJoCo's, and
  the cache misses each causes the other are not instructions).

The marker is MuJoCo's ``mj_version``, which neither MuJoCo nor the loop calls; a count whose
marker fired other than twice is refused.  Repeated, the loop's count agrees to about ten thousand
instructions a run (12,000 over 20 steps of the grasp, checked by hand), ``mj_step``'s exactly:
one hash seed and one BLAS thread make the rest the same.

About a minute (valgrind runs Python some 50x slower); needs valgrind on the PATH.  The disk
cache of set-up tables is filled first by a plain run, so that the counted run computes none
of them, and the project's bytecode compiled, so that it compiles no module.
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

#: The marker whose calls split the counted run (callgrind's ``--dump-before``): a MuJoCo
#: function that neither MuJoCo nor the loop calls.
MARKER = "mj_version"

#: The counted run's script: the scenario's simulation, stepped ``warmup`` control steps, the
#: marker, ``steps`` more, the marker (argv: warmup, steps, scenario, overrides...).
_SCRIPT = (
    "import sys\n"
    "import mujoco\n"
    "from piezotip import scenarios\n"
    "from piezotip.cosim.loop import CoSimulation\n"
    "sim = CoSimulation(scenarios.get(sys.argv[3], sys.argv[4:]))\n"
    "for n in map(int, sys.argv[1:3]):\n"
    "    for _ in range(n):\n"
    "        sim.advance()\n"
    f"    mujoco.{MARKER}()\n"
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


def _counted_part(steps: int, warmup_steps: int, scenario: str, overrides: list[str], work: Path, env: dict[str, str]) -> Path:
    """The counted run's callgrind file of its counted steps: the part between the marker's two
    calls.  Raises RuntimeError when the run fails or the marker fired other than twice."""
    out = work / "callgrind.out"
    cmd = [
        "valgrind", "--tool=callgrind", f"--dump-before={MARKER}", f"--callgrind-out-file={out}",
        sys.executable, "-c", _SCRIPT, str(warmup_steps), str(steps), scenario, *overrides,
    ]  # fmt: skip
    run = subprocess.run(cmd, env=env, cwd=work, capture_output=True, text=True)
    if run.returncode != 0:
        raise RuntimeError(f"the counted run of {steps} steps failed ({run.returncode}): {run.stderr.strip()[-500:]}")
    # callgrind writes out.1 up to the first call, out.2 up to the second, and out to the exit.
    fired = len(list(work.glob("callgrind.out.*")))
    if fired != 2:
        raise RuntimeError(f"the marker {MARKER} fired {fired} times, not twice: the counted steps are not one part")
    return work / "callgrind.out.2"


def instruction_counts(scenario: str = "grasp", overrides: list[str] | None = None, steps: int = 1000, warmup_steps: int = 200) -> dict:
    """Instructions per control step of ``scenario``'s loop, inside and outside ``mj_step``
    (the module docstring).  Raises RuntimeError naming what is missing when valgrind or
    callgrind_annotate is not on the PATH, or when the run fails."""
    if steps < 1 or warmup_steps < 1:
        raise ValueError(f"steps and warmup_steps must be at least 1, got {steps} and {warmup_steps}")
    missing = [tool for tool in ("valgrind", "callgrind_annotate") if shutil.which(tool) is None]
    if missing:
        raise RuntimeError(f"counting instructions needs {' and '.join(missing)} on the PATH (valgrind's package)")
    overrides = list(overrides or [])
    env = counted_env(os.environ)
    # Bytecode compiled first: a module imported in the counted steps would otherwise be compiled
    # there (under PYTHONDONTWRITEBYTECODE, by every run).
    compile_bytecode(*source_folders())
    with tempfile.TemporaryDirectory(prefix="piezotip-instructions-") as tmp:
        work = Path(tmp)
        # The set-up tables on disk first: a table made lazily in the counted steps is not counted.
        # (Run from the temporary folder: the current one could hold a folder named piezotip.)
        plain = [sys.executable, "-c", _SCRIPT, "1", "0", scenario, *overrides]
        warm = subprocess.run(plain, env=env, cwd=work, capture_output=True, text=True)
        if warm.returncode != 0:
            raise RuntimeError(f"{scenario} with {overrides} does not run: {warm.stderr.strip()[-500:]}")
        part = _counted_part(steps, warmup_steps, scenario, overrides, work, env)
        # Every function listed (the default lists only those that make 99 % of the total).
        annotated = subprocess.run(
            ["callgrind_annotate", "--inclusive=yes", "--threshold=100", str(part)], capture_output=True, text=True, check=True
        )
        total, in_mj_step = parse_annotation(annotated.stdout)
    mj_step = in_mj_step / steps
    loop = (total - in_mj_step) / steps
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
