"""Seeded random command lines: every ``--set`` key with hostile and plausible values.

Whatever the values, :func:`piezotip.cli.main` returns (no exception leaves it), with exit code
0 or 1 (the config was valid and the run ended with an outcome) or 2 (bad input: exactly one
line on stderr naming the key or the value), never 3: an internal error is a bug, which the
config's validation must turn into a clear ValueError first.  Runs that validate are kept short
(``duration_s=0.05`` comes first, so a fuzzed duration still replaces it).
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import random
import time

from piezotip import cli, scenarios
from piezotip.scenarios.config import valid_keys

#: Invocations, and the seed of the first.
CASES = 300
SEED = 30

KEYS = valid_keys(scenarios.get("grasp"))

#: Values no key should take quietly, and some that several keys take.
HOSTILE = [
    "0",
    "-0.0",
    "-1",
    "1e-300",
    "5e-324",
    "1e300",
    "1.7976931348623157e308",
    "1e400",
    "-1e400",
    "nan",
    "inf",
    "-inf",
    "10**400",
    "1" + "0" * 400,  # an integer beyond any float
    "9" * 5000,  # beyond Python's integer-text limit
    "9" * 100_000,  # beyond the value length limit
    "1+" * 60_000,
    "1+" * 3000 + "1",
    "-" * 5000 + "1",
    "x" * 20_000,
    "x" * 9_000,
    "",
    " ",
    "[]",
    "()",
    "[[]]",
    "[1]",
    "[1, 1]",
    "[1] * 3",
    "[" + "1, " * 60_000 + "1]",
    "[" + "1, " * 3000 + "1]",
    "[[[[[[1]]]]]]",
    "(" * 300 + "1" + ")" * 300,
    "{}",
    "{{}}",
    "{[1]: 2}",
    "{1: 2}",
    "{1, 2}",
    "None",
    "True",
    "False",
    "true",
    "1j",
    "b'x'",
    "'1'",
    '"text"',
    "--out=x",
    "--help",
    "-h",
    "key=value",
    "\x00",
    "lambda: 0",
    "__import__('os')",
    "(0, 1e-9)",
    "(0, 1)",
    "(7.4, 7.5)",
    "(3, 3.5)",
    "(1, 2, 3)",
    "['left', 'left']",
    "['left']",
    "[1, 2, 3, 4, 5]",
    "[30]",
    "[0]",
    "[1.5]",
    "[4, 3, 2, 1]",
    "0.5",
    "1",
    "2",
    "3",
    "100",
    "1e6",
    "1e-3",
    "1e12",
    "70",
]


def typed_value(key: str, rng: random.Random) -> str:
    """A value of the key's own type near its default (many of these validate and run)."""
    default = scenarios.get("grasp")
    for part in key.split("."):
        default = getattr(default, part)
    if isinstance(default, bool):
        return rng.choice(["True", "False"])
    if isinstance(default, int):
        return str(default + rng.choice([-1, 0, 1, 2, 10**6]))
    if isinstance(default, float):
        return repr(default * rng.choice([0.0, 0.5, 1.0, 1.0001, 2.0, 1e-3, 1e3, -1.0]))
    if isinstance(default, tuple) and default and isinstance(default[0], (int, float)):
        items = list(default)
        rng.shuffle(items)
        return repr(items[: rng.randint(0, len(items))] + rng.choice([[], [items[0]] if items else []]))
    if isinstance(default, str):
        return rng.choice([default, default.upper(), default + "x", "none"])
    return rng.choice(["None", "1", "70", "0.5"])


def invocation(case: int, out: str) -> tuple[list[str], list[tuple[str, str]]]:
    """Case ``case``'s argv and its (key, value) assignments."""
    rng = random.Random(SEED * 1_000_003 + case)
    sets = []
    for _ in range(rng.choice([1, 1, 1, 2, 3])):
        key = rng.choice(KEYS)
        value = rng.choice(HOSTILE) if rng.random() < 0.6 else typed_value(key, rng)
        sets.append((key, value))
    scenario = rng.choice(scenarios.names())
    preset = ["--preset", rng.choice(cli.PRESET_NAMES)] if rng.random() < 0.15 else []
    base = ["--set", "duration_s=0.05"]
    if rng.random() < 0.1 and "," not in sets[0][1]:  # a sweep over the first key, run in this process
        key, value = sets[0]
        argv = ["sweep", scenario, "--grid", f"{key}={value},{typed_value(key, rng)}", "--workers", "0", "--no-plot", "--json"]
        argv += [*base, *preset, "--out", out]
        for k, v in sets[1:]:
            argv += ["--set", f"{k}={v}"]
        return argv, sets
    argv = ["run", scenario, "--no-plot", "--json", "--out", out, *preset, *base]
    for k, v in sets:
        argv += ["--set", f"{k}={v}"]
    return argv, sets


def names_it(err: str, sets: list[tuple[str, str]]) -> bool:
    """Whether the error line names one of the assigned keys or values."""
    for key, value in sets:
        if key in err:
            return True
        shown = value.strip()[:12]
        if (shown and shown in err) or (not shown and "empty" in err):
            return True
    return False


def check(case: int, tmp_path) -> str | None:
    """Run case ``case``; None if it behaved, else what went wrong."""
    out = tmp_path / f"case{case}"
    argv, sets = invocation(case, str(out))
    stdout, stderr = io.StringIO(), io.StringIO()
    try:
        with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
            code = cli.main(argv)
    except BaseException as exc:  # that is the finding
        return f"case {case}: {type(exc).__name__} escaped main: {exc!s:.200} <- {sets!r:.300}"
    err = stderr.getvalue().strip()
    if code not in (0, 1, 2):
        return f"case {case}: exit {code}: {err[-400:]} <- {sets!r:.300}"
    if "Traceback" in err:
        return f"case {case}: a traceback on stderr with exit {code} <- {sets!r:.300}"
    if code == 2:
        if "\n" in err or not err.startswith("error: "):
            return f"case {case}: exit 2 without exactly one error line: {err[:400]!r} <- {sets!r:.300}"
        if not names_it(err, sets):
            return f"case {case}: exit 2 naming neither key nor value: {err[:300]!r} <- {sets!r:.300}"
    else:
        report = json.loads(stdout.getvalue())
        if argv[0] == "run" and code != (0 if report["success"] else 1):
            return f"case {case}: exit {code} for outcome {report['outcome']} <- {sets!r:.300}"
    return None


def test_random_command_lines_end_in_an_outcome_or_one_line_never_a_crash(tmp_path, monkeypatch):
    monkeypatch.setenv("PIEZOTIP_CACHE_DIR", str(tmp_path / "cache"))  # the fuzzed sensors' tables stay out of the user's cache
    start = time.perf_counter()
    failures = [f for f in (check(case, tmp_path) for case in range(CASES)) if f is not None]
    assert not failures, f"{len(failures)} of {CASES} invocations misbehaved:\n" + "\n".join(failures[:20])
    assert time.perf_counter() - start < 90  # seconds (about 5 here): a value that slips past validation into a long run shows


def test_the_fuzzer_reaches_runs_and_refusals():
    """The generated cases are not all refused: a good share validates and runs."""
    valid = refused = 0
    for case in range(CASES):
        _, sets = invocation(case, "unused")
        try:
            scenarios.get("grasp", [f"{k}={v}" for k, v in sets])
            valid += 1
        except ValueError:
            refused += 1
    assert valid >= CASES // 10 and refused >= CASES // 2, (valid, refused)
    assert len({k for case in range(CASES) for k, _ in invocation(case, "unused")[1]}) >= math.ceil(0.9 * len(KEYS))
