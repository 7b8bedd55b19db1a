"""The golden record: a hash of every recorded column of every scenario, to hold a refactor to.

    python -m benchmarks.golden out/golden-before.json            # before the change
    python -m benchmarks.golden out/golden-after.json             # after it
    python -m benchmarks.golden --compare out/golden-before.json out/golden-after.json

Runs every registered scenario at the three presets under its own controller, the default grasp
under each built-in controller, and the default grasp on each third-party gripper whose package
is installed (:func:`reports.gripper_tables.grippers`; the fast preset), and writes, per run,
the SHA-256 of each recorded column's bytes and the referee's outcome (CONTRIBUTING.md,
"Refactoring: the golden record").  ``--compare`` prints every run and column that differs and
exits 1 if any does (a run only one file has counts as a difference).  Progress on stderr.

For a change meant to alter a run only from some point on (an earlier end of its release, say),
each run also keeps running hashes of the whole record at every :data:`CHECKPOINT_S` of it
(``prefix``): ``--compare`` says how far two runs that differ still agree ("the first 7.75 s,
into the release phase"), which the columns' hashes alone cannot.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
from pathlib import Path

import numpy as np

#: The presets every scenario runs at.
PRESETS = ("fast", "balanced", "accurate")


def cases(quick: bool = False) -> list[tuple[str, str, dict]]:
    """(scenario, preset, overrides) of every run; ``quick``: the fast preset only."""
    import piezotip
    from piezotip.reports.gripper_tables import grippers

    presets = PRESETS[:1] if quick else PRESETS
    out = [(name, preset, {}) for name in piezotip.scenario_names() for preset in presets]
    out += [("grasp", preset, {"controller.kind": kind}) for kind in piezotip.controllers.names() for preset in presets]
    for keys in grippers().values():
        out += [("grasp", "fast", {**keys, "controller.kind": kind}) for kind in ("gentle", "multimode")]
    return out


#: The summary's keys that say how and when a run was made, not what it did.
VOLATILE_SUMMARY_KEYS = ("wall_time_s", "realtime_factor", "files", "versions")


#: How often along a record its running hash is kept, s of simulated time (:func:`prefix_hashes`).
CHECKPOINT_S = 0.1


def _sha(text: bytes) -> str:
    return hashlib.sha256(text).hexdigest()


def prefix_hashes(data, every_s: float = CHECKPOINT_S) -> list[list]:
    """``[time_s, phase, hash]`` at every ``every_s`` (s) of a record ``data`` (columns of equal
    length, ``time_s`` and ``phase`` among them) and at its end: one SHA-256 running over every
    column's rows up to there (blocks of rows in order, each block's columns in sorted order).
    Two records that agree row for row up to a time share every hash up to it."""
    columns = [np.ascontiguousarray(np.asarray(data[column])) for column in sorted(data)]
    t, phase = np.asarray(data["time_s"]), np.asarray(data["phase"])
    step = max(1, round(every_s / (t[1] - t[0]))) if t.size > 1 else 1
    running, out = hashlib.sha256(), []
    for start in range(0, t.size, step):
        stop = min(t.size, start + step)
        for column in columns:
            running.update(column[start:stop].tobytes())
        out.append([float(t[stop - 1]), int(phase[stop - 1]), running.hexdigest()])
    return out


def agreement(before: list[list], after: list[list]) -> tuple[float, int] | None:
    """(time_s, phase) of the last checkpoint two :func:`prefix_hashes` share, or None where they
    differ from the first."""
    shared = None
    for (t_s, phase, h_before), (_, _, h_after) in zip(before, after, strict=False):  # the shorter record's length
        if h_before != h_after:
            break
        shared = (t_s, phase)
    return shared


def record_hashes(result) -> dict[str, str]:
    """Each recorded column's SHA-256 (its bytes, C order), the events', the summary's (less
    :data:`VOLATILE_SUMMARY_KEYS`, as sorted JSON) and the outcome."""
    hashes = {column: _sha(np.ascontiguousarray(result.data[column]).tobytes()) for column in sorted(result.data)}
    summary = {k: v for k, v in result.summary.items() if k not in VOLATILE_SUMMARY_KEYS}
    hashes["events"] = _sha(json.dumps([dict(e) for e in result.events], sort_keys=True, default=repr).encode())
    hashes["summary"] = _sha(json.dumps(summary, sort_keys=True, default=repr).encode())
    return hashes | {"outcome": result.outcome, "prefix": prefix_hashes(result.data)}


def golden(quick: bool = False) -> dict[str, dict[str, str]]:
    """Every case's hashes, keyed by ``"scenario preset {overrides as sorted JSON}"``."""
    import piezotip

    runs = {}
    todo = cases(quick)
    for k, (name, preset, overrides) in enumerate(todo, 1):
        key = f"{name} {preset} {json.dumps(overrides, sort_keys=True)}"
        print(f"[{k}/{len(todo)}] {key}", file=sys.stderr, flush=True)
        runs[key] = record_hashes(piezotip.run(name, overrides=overrides, preset=preset))
    return runs


def differences(before: dict, after: dict) -> list[str]:
    """Every run and column that differs between two golden files (a run in one only, too)."""
    out = []
    for key in sorted(set(before) | set(after)):
        if key not in before or key not in after:
            out.append(f"{key}: only {'after' if key not in before else 'before'}")
            continue
        changed = sorted(c for c in (set(before[key]) | set(after[key])) - {"prefix"} if before[key].get(c) != after[key].get(c))
        if changed:
            line = f"{key}: {len(changed)} columns differ ({', '.join(changed[:6])}{', ...' if len(changed) > 6 else ''})"
            if "prefix" in before[key] and "prefix" in after[key]:
                shared = agreement(before[key]["prefix"], after[key]["prefix"])
                if shared is None:
                    line += "; the records differ from their start"
                else:
                    line += f"; they agree for their first {shared[0]:.3f} s (into {_phase(shared[1])})"
            out.append(line)
    return out


def _phase(code: int) -> str:
    from piezotip.cosim.control.phases import Phase

    return f"the {Phase(code).label} phase"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, nargs="?", help="where to write the hashes (JSON)")
    parser.add_argument("--quick", action="store_true", help="the fast preset only")
    parser.add_argument("--compare", nargs=2, type=Path, metavar=("BEFORE", "AFTER"), help="compare two golden files")
    args = parser.parse_args(argv)
    if args.compare:
        before, after = (json.loads(p.read_text()) for p in args.compare)
        diffs = differences(before, after)
        print("\n".join(diffs) if diffs else f"identical: {len(before)} runs")
        return 1 if diffs else 0
    if args.out is None:
        parser.error("give the file to write (or --compare BEFORE AFTER)")
    runs = golden(args.quick)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(runs, indent=1, sort_keys=True))
    print(f"wrote {len(runs)} runs to {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
