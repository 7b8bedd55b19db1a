"""Many runs at once on Dask: ``run_sim.py sweep`` and ``experiment grasp-range`` share this.

A sweep is a list of points, each a list of ``key=value`` overrides of one scenario.  Every
point runs in a Dask worker process (:func:`run_point`), which sends back one row of numbers
(:func:`point_row`), never the recording.  By default the work goes to a local cluster over
this machine's cores, started and stopped here; ``scheduler="tcp://host:8786"`` sends it to a
cluster someone started (``dask scheduler`` on one machine, ``dask worker tcp://host:8786`` on
each machine with piezotip installed).  ``workers=0`` runs in this process, one point after the
other (no Dask), which is what the tests compare the parallel rows against.

Resume: each finished point's row is appended at once to ``points.jsonl`` in the output
folder, keyed by the scenario, preset and the point's overrides, on a line of its own (after a
newline when a kill tore the last line); a sweep run again with the same folder skips the
points already there (a point that raised is run again).  A line that is not a row (torn,
garbage, not UTF-8) is skipped with a warning naming the file and line, and its point runs
again: a resumed sweep has the rows an uninterrupted one has.  A point that
raises is recorded with its error (``outcome`` ``error``) and the sweep goes on.

Worker processes keep their caches (mode bands, gel tables) across the points they run, and
the on-disk cache (:mod:`piezotip.sensor.cache`) shares them across processes and runs.  The
command line starts the local cluster's worker server first (:func:`start_worker_server`): its
workers are forked from a process that has their imports done, which it did while the command
imported and checked the points.
"""

from __future__ import annotations

import atexit
import csv
import itertools
import json
import logging
import math
import os
import signal
import sys
import time
import traceback
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np

#: A sweep row's result columns, after the grid's keys (units in the names; modes_used is a list
#: written "1 2 3").
RESULT_COLUMNS = ("outcome", "reason", "success", "max_pressure_pa", "held_pressure_pa", "modes_used", "wall_time_s")

#: More numbers every row carries, after the result columns (the experiment's table uses them).
EXTRA_COLUMNS = (
    "crushed",
    "slipped",
    "lifted",
    "touch_latency_s",
    "touch_sense",
    "mode_switches",
    "peak_grip_force_n",
    "hold_grip_n",
    "needed_grip_n",
    "grip_margin",
    "peak_contact_n",
    "outside_model",
    "sim_time_s",
    "error",
)

#: The referee's grip economy (analysis.referee.Verdict): grip held, needed, their ratio, peak contact.
GRIP_ECONOMY_COLUMNS = ("hold_grip_n", "needed_grip_n", "grip_margin", "peak_contact_n")

#: The outcome of a point whose run raised.
ERROR_OUTCOME = "error"

#: The phase code of holding in the record (cosim.control.Phase.HOLD).
_HOLD_PHASE = 4.0

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Point:
    """One run of a sweep.

    Attributes
    ----------
    values : the point's coordinates, column name -> value (the grid's keys, or labels such as
        the experiment's object and controller).
    overrides : the run's ``key=value`` overrides, in the order applied.
    """

    values: Mapping[str, object]
    overrides: tuple[str, ...]
    label: str = field(default="")

    def key(self, scenario: str, preset: str | None) -> str:
        """What identifies the run (resume): scenario, preset and every override, in order."""
        return json.dumps([scenario, preset, list(self.overrides)])


def split_values(text: str) -> list[str]:
    """``"0.1,0.4,[1, 2]"`` -> ``["0.1", "0.4", "[1, 2]"]``: commas inside brackets or quotes stay."""
    items, depth, quote, current = [], 0, "", []
    for ch in text:
        if quote:
            quote = "" if ch == quote else quote
        elif ch in "'\"":
            quote = ch
        elif ch in "([{":
            depth += 1
        elif ch in ")]}":
            depth -= 1
        elif ch == "," and depth == 0:
            items.append("".join(current).strip())
            current = []
            continue
        current.append(ch)
    items.append("".join(current).strip())
    if depth != 0 or quote:
        raise ValueError(f"--grid values {text!r}: unbalanced brackets or quotes")
    if any(not item for item in items):
        raise ValueError(f"--grid values {text!r}: an empty value")
    return items


def parse_grid(specs: Sequence[str]) -> dict[str, list[str]]:
    """``["object.mass_kg=0.1,0.4", ...]`` -> ``{"object.mass_kg": ["0.1", "0.4"], ...}``."""
    grid: dict[str, list[str]] = {}
    for spec in specs:
        key, sep, values = spec.partition("=")
        key = key.strip()
        if not sep or not key or not values.strip():
            raise ValueError(f"--grid takes key=v1,v2,..., got {spec!r}")
        if key in grid:
            raise ValueError(f"--grid {key!r} given twice")
        grid[key] = split_values(values)
    if not grid:
        raise ValueError("a sweep needs at least one --grid key=v1,v2,...")
    return grid


def grid_points(grid: Mapping[str, Sequence[object]], base_overrides: Sequence[str] = ()) -> list[Point]:
    """Every combination of the grid's values (the last key varies fastest); ``base_overrides``
    (the user's ``--set``) apply first, the point's own values after them."""
    from piezotip.scenarios import override_strings
    from piezotip.scenarios.config import parse_value

    keys = list(grid)
    points = []
    for combo in itertools.product(*(grid[k] for k in keys)):
        values, own = {}, []
        for key, value in zip(keys, combo, strict=True):
            # Text is the command line's (``0.1``, ``[1, 2]``): used as typed, read as --set reads it.
            values[key] = parse_value(value) if isinstance(value, str) else value
            own += [f"{key}={value}"] if isinstance(value, str) else override_strings({key: value})
        points.append(Point(values, (*base_overrides, *own), label=", ".join(own)))
    return points


def touch_sense(events: Sequence[Mapping]) -> str:
    """Which sense felt the touch the squeeze began on: "fingertip" (every fingertip's touch
    detector: "squeeze: touch on left, right (CUSUM)"), "joints" (the finger drive met a
    resistance first: "squeeze: touch felt by the joints (...)"), or "" with no touch.  The
    last squeeze counts (a false touch is closed on from, and the touch time is the last one's)."""
    sense = ""
    for event in events:
        message = event.get("message", "")
        if event.get("kind") == "phase" and message.startswith("squeeze: touch"):
            sense = "joints" if message.startswith("squeeze: touch felt by the joints") else "fingertip"
    return sense


def point_row(summary: Mapping, data: Mapping[str, np.ndarray]) -> dict:
    """A finished run's row: the result columns and the extras, from its summary and record."""
    import numpy as np

    held = data["phase"] == _HOLD_PHASE if data else np.zeros(0, bool)
    pads = [k.removesuffix("_true_pressure_pa") for k in data if k.endswith("_true_pressure_pa")] if data else []
    true_p = np.max([data[f"{p}_true_pressure_pa"] for p in pads], axis=0) if pads else np.zeros(0)
    # First contact: a finger touches the object (ground truth), not a pressure reading (the
    # pads' own inertia presses a fraction of a pascal as the fingers start).
    if data:
        touching = np.maximum(data["left_finger_force_n"], data["right_finger_force_n"]) > 0
        contact = np.nonzero(touching)[0]
        contact_t = float(data["time_s"][contact[0]]) if contact.size else math.nan
    else:
        contact_t = math.nan
    touch_t = summary.get("touch_time_s", math.nan)
    touch_t = math.nan if touch_t is None else touch_t
    return {
        "outcome": summary["outcome"],
        "reason": summary["reason"],
        "success": bool(summary["success"]),
        "max_pressure_pa": summary["max_pressure_pa"],
        "held_pressure_pa": float(np.mean(true_p[held])) if held.any() else math.nan,
        "modes_used": " ".join(str(m) for m in summary.get("modes_used", [])),
        "wall_time_s": summary["wall_time_s"],
        "crushed": summary["crushed"],
        "slipped": summary["slipped"],
        "lifted": summary["lifted"],
        "touch_latency_s": touch_t - contact_t if math.isfinite(touch_t) and math.isfinite(contact_t) else math.nan,
        "touch_sense": touch_sense(summary.get("events") or []),
        "mode_switches": summary["mode_switches"],
        "peak_grip_force_n": summary["peak_grip_force_n"],
        **{key: summary.get(key, math.nan) for key in GRIP_ECONOMY_COLUMNS},
        "outside_model": "; ".join(summary.get("outside_model", [])),
        "sim_time_s": summary["sim_time_s"],
        "error": summary.get("error") or "",
        "object_config": summary.get("object"),
    }


def error_row(message: str) -> dict:
    """The row of a point whose run raised: its error, NaN numbers, ``success`` False."""
    row = {c: math.nan for c in (*RESULT_COLUMNS, *EXTRA_COLUMNS)}
    row.update(outcome=ERROR_OUTCOME, reason=message, success=False, modes_used="", outside_model="", error=message)
    row.update(crushed=False, slipped=False, lifted=False, touch_sense="", object_config=None)
    return row


def run_point(
    scenario: str, overrides: Sequence[str], preset: str | None, run_dir: str | None = None, options: Mapping | None = None
) -> dict:
    """Run one point (in a worker) and return its row; an exception becomes an error row.

    ``run_dir``: where the run's own files go (``run.npz``, ``summary.json``), or None to keep
    the recording in memory only.  ``options``: more keywords of ``run_scenario`` (e.g. video).
    The row's ``wall_time_s`` is the whole point (set-up, loop, summary), as the user waits.
    A run a signal interrupted (Ctrl-C or SIGTERM in this process's main thread: the sweep run
    one point after the other) raises :class:`~piezotip.analysis.runner.RunInterrupted`: the
    point is not done, nothing is journaled for it, and the sweep stops.
    """
    options = dict(options or {})
    import tempfile

    from .runner import RunInterrupted, run_scenario

    start = time.perf_counter()
    try:
        if run_dir is None:
            with tempfile.TemporaryDirectory(prefix="piezotip-point-") as tmp:
                summary, data = run_scenario(scenario, list(overrides), Path(tmp), plot=False, quiet=True, preset=preset, **options)
        else:
            summary, data = run_scenario(scenario, list(overrides), Path(run_dir), plot=False, quiet=True, preset=preset, **options)
        if summary.get("interrupted"):  # Ctrl-C or SIGTERM cut the run short: not a row to journal, the sweep stops
            raise RunInterrupted(signal.Signals[summary.get("signal") or "SIGINT"])
        row = point_row(summary, data)
    except Exception as err:  # recorded, and the sweep goes on
        last = traceback.extract_tb(err.__traceback__)[-1]
        row = error_row(f"{type(err).__name__}: {err} ({Path(last.filename).name}:{last.lineno})")
    row["wall_time_s"] = time.perf_counter() - start
    row["pid"] = os.getpid()
    return row


#: The row's number columns (NaN where there is no value; JSON writes it null).
_NUMBER_COLUMNS = (
    "max_pressure_pa",
    "held_pressure_pa",
    "wall_time_s",
    "touch_latency_s",
    "mode_switches",
    "peak_grip_force_n",
    "hold_grip_n",
    "needed_grip_n",
    "grip_margin",
    "peak_contact_n",
    "sim_time_s",
)


def _normalized(row: dict) -> dict:
    """The row as it reads back from ``points.jsonl`` (JSON types, NaN for null numbers): a fresh
    row and a resumed one are then the same values."""
    from .runner import json_safe

    row = json.loads(json.dumps(json_safe(row)))
    for key in _NUMBER_COLUMNS:
        if row.get(key, None) is None and (key in row or key in GRIP_ECONOMY_COLUMNS):
            row[key] = math.nan  # null, or a journal written before the grip-economy columns
    return row


def _load_done(path: Path) -> dict[str, dict]:
    """The rows already in ``points.jsonl`` by key, the last one of a key winning (a point that
    raised is not done).

    A line that is not a row (not UTF-8, not JSON, JSON that is not ``{"key": str, "row": {...}}``,
    a torn line a kill left) is skipped with a warning naming the file and the line number, on
    the ``piezotip.analysis.sweep`` logger; its point, if any, runs again."""
    done: dict[str, dict] = {}
    if not path.exists():
        return done
    text = path.read_bytes()
    lines = text.split(b"\n")
    if lines[-1] == b"":
        lines.pop()  # the newline that ends the last line
    for number, raw in enumerate(lines, 1):
        if not raw.strip():
            continue
        problem, entry = None, None
        try:
            entry = json.loads(raw.decode("utf-8"))
        except UnicodeDecodeError:
            problem = "not UTF-8"
        except ValueError:
            problem = "not JSON (torn: the file ends inside it)" if number == len(lines) and not text.endswith(b"\n") else "not JSON"
        if problem is None and not (isinstance(entry, dict) and isinstance(entry.get("key"), str) and isinstance(entry.get("row"), dict)):
            problem = 'not a row ({"key": ..., "row": {...}})'
        if problem is not None:
            log.warning("%s:%d: skipped a line that is %s", path, number, problem)
            continue
        if entry["row"].get("outcome") != ERROR_OUTCOME:
            done[entry["key"]] = _normalized(entry["row"])
    return done


def _append_line(path: Path, line: str) -> None:
    """Append ``line`` (and a newline) to the journal as one write, on a line of its own: a file
    that does not end with a newline (a line torn by a kill or a full disk) gets one first, so
    the torn fragment stays a line of its own (skipped on reading) and this row is whole."""
    with path.open("a+b") as fh:
        size = fh.seek(0, os.SEEK_END)
        lead = b""
        if size:
            fh.seek(size - 1)
            lead = b"" if fh.read(1) == b"\n" else b"\n"
        fh.write(lead + line.encode("utf-8") + b"\n")  # "a": written at the end, wherever the read left off


@dataclass(frozen=True)
class SweepRun:
    """What :func:`run_points` did.

    Attributes
    ----------
    rows : one row per point, in the points' order (the point's values, then the results).
    skipped : points found done in the output folder and not run again.
    workers : the Dask workers used (0: run in this process).
    wall_time_s : the whole sweep, cluster start included, s.
    """

    rows: list[dict]
    skipped: int
    workers: int
    wall_time_s: float


def run_points(
    scenario: str,
    points: Sequence[Point],
    preset: str | None = None,
    out: Path | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: bool = True,
    keep_runs: bool = False,
    desc: str = "sweep",
    options: Mapping | None = None,
) -> SweepRun:
    """Run every point (skipping those done in ``out``) and return the rows in the points' order.

    ``workers``: processes of the local Dask cluster (default: this machine's cores); 0 runs the
    points in this process.  ``scheduler``: the address of a running Dask scheduler (then
    ``workers`` is ignored).  ``keep_runs``: each point's ``run.npz`` and ``summary.json`` in
    ``out/runs/NN`` (NN the point's index).  ``options``: more keywords of ``run_scenario``.
    """
    from tqdm import tqdm

    from .runner import check_out_dir, json_safe

    start = time.perf_counter()
    journal = None
    done: dict[str, dict] = {}
    if out is not None:
        out = check_out_dir(Path(out))
        journal = out / "points.jsonl"
        done = _load_done(journal)
    keys = [p.key(scenario, preset) for p in points]
    todo = [i for i, k in enumerate(keys) if k not in done]
    results: dict[int, dict] = {}

    def run_dir(i: int) -> str | None:
        return str(out / "runs" / f"{i:02d}") if keep_runs and out is not None else None

    def finish(i: int, row: dict) -> None:
        results[i] = row = _normalized(row)
        if journal is not None:  # one line per point, appended at once: a kill loses only runs in flight
            _append_line(journal, json.dumps(json_safe({"key": keys[i], "row": row})))
        bar.update(1)

    n_workers = 0
    with tqdm(total=len(points), initial=len(points) - len(todo), desc=desc, unit="run", disable=not progress, leave=False) as bar:
        if todo and scheduler is None and workers == 0:
            for i in todo:
                finish(i, run_point(scenario, points[i].overrides, preset, run_dir(i), options))
        elif todo:
            with _client(workers, scheduler) as client:
                n_workers = len(client.scheduler_info()["workers"])
                futures = {
                    client.submit(run_point, scenario, points[i].overrides, preset, run_dir(i), options, pure=False): i for i in todo
                }
                from dask.distributed import as_completed

                for future in as_completed(futures):
                    i = futures[future]
                    try:
                        row = future.result()
                    except Exception as err:  # a worker lost, not the run itself
                        row = error_row(f"{type(err).__name__}: {err}")
                    finish(i, row)
    rows = []
    for i, point in enumerate(points):
        row = done.get(keys[i]) if i not in results else results[i]
        rows.append({**point.values, **row})
    return SweepRun(rows, len(points) - len(todo), n_workers, time.perf_counter() - start)


#: What a point imports in its worker process, its first point paying for them otherwise (about
#: 0.5 s: Dask, MuJoCo, the sensor's modules).
#: The worker server imports them once, before any worker exists (:func:`start_worker_server`).
WORKER_MODULES = (
    "piezotip.analysis.sweep",  # first: in the server it sets the import path (see below)
    "distributed",
    "tqdm",
    "piezotip.analysis.runner",
    "piezotip.analysis.run_report",
    "piezotip.cosim.loop",
)

#: What Dask's nanny puts in the environment before it starts a worker process (its
#: ``distributed.nanny.pre-spawn-environ`` defaults and its hash seed).  A worker forked from the
#: worker server has the server's environment, so the server starts with these; a value already
#: in this process's environment wins, as with Dask.
WORKER_ENV = {
    "MALLOC_TRIM_THRESHOLD_": "65536",
    "OMP_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
    "OPENBLAS_NUM_THREADS": "1",
    "PYTHONHASHSEED": "6640",
}

_worker_server = False

#: Set in the worker server's environment alone (this process's id and import path, as JSON):
#: the server's import of this module sees it (below) and takes it out (the workers forked later
#: do not have it).
_SERVER_FLAG = "PIEZOTIP_WORKER_SERVER_OF"


def _exit_now() -> None:
    """The worker server's exit (when the process that started it is gone; the workers are
    gone too, each watches that process): at once, without the clean-up of an interpreter
    that has Dask and MuJoCo loaded (0.15 s, which the command's caller waits for: the server
    holds its output pipes too)."""
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (AttributeError, OSError, ValueError):
            pass
    os._exit(0)


def _in_worker_server() -> bool:
    """Whether this process is the worker server that this module's parent process started."""
    try:
        parent = json.loads(os.environ.pop(_SERVER_FLAG, "null"))
    except ValueError:
        return False
    if not isinstance(parent, dict) or parent.get("pid") != os.getppid():
        return False
    # Python 3.11's forkserver ignores the import path it is given: the parent's, as a spawned
    # worker has it (the server's own would put the current folder first), before any other import.
    sys.path[:] = parent["path"]
    global _command_pid
    _command_pid = parent["pid"]
    atexit.register(_exit_now)
    # A Ctrl-C while it imports, or a worker it forks failing because the command is gone:
    # the command says "interrupted", once.  The forkserver reports a fork's error through
    # sys.excepthook.
    sys.excepthook = _quiet_interrupt
    return True


#: In the worker server (and the workers it forks): the process id of the command that started it.
_command_pid: int | None = None


def _command_gone() -> bool:
    """Whether the command that started this worker server has exited."""
    if _command_pid is None:
        return False
    try:
        os.kill(_command_pid, 0)
    except ProcessLookupError:
        return True
    except OSError:  # it exists (and belongs to another user: not ours, but alive)
        return False
    return False


def _quiet_interrupt(kind, value, tb) -> None:
    """The worker server's last word on an exception: none for Ctrl-C or once the command is
    gone (a worker forked as it was interrupted cannot reach it), the usual otherwise."""
    if not (issubclass(kind, KeyboardInterrupt) or _command_gone()):
        sys.__excepthook__(kind, value, tb)


_in_worker_server()


def start_worker_server() -> bool:
    """Start, in the background, the process this process's local clusters fork their workers
    from (multiprocessing's forkserver, :data:`WORKER_MODULES` imported), and return whether
    they will (False where there is no forkserver: they then start workers as Dask does, each
    a fresh interpreter that imports everything itself).

    Call it as early as possible (the command line does, before its own imports and checks):
    the server's imports then run beside this process's work, and each worker starts in
    milliseconds, imports done, instead of a second; it also exits without an interpreter's
    clean-up.  The server is single-threaded when it forks (the point of a forkserver: this
    process has threads, a fork of it could deadlock); it exits when this process does.
    Without this call the local cluster spawns its workers (Dask's default), which leaves
    multiprocessing's global forkserver alone for a program that uses the API."""
    global _worker_server
    if _worker_server:
        return True
    import multiprocessing
    from multiprocessing import forkserver

    if "forkserver" not in multiprocessing.get_all_start_methods():
        return False
    multiprocessing.get_context("forkserver").set_forkserver_preload(list(WORKER_MODULES))
    parent = json.dumps({"pid": os.getpid(), "path": sys.path})
    server_env = {**{key: os.environ.get(key, value) for key, value in WORKER_ENV.items()}, _SERVER_FLAG: parent}
    saved = {key: os.environ.get(key) for key in server_env}
    os.environ.update(server_env)
    try:
        forkserver.ensure_running()  # starts it and returns; the server imports while we go on
    except OSError:
        return False
    finally:
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value
    _worker_server = True
    return True


class _interrupts_deferred:
    """Inside, Ctrl-C (SIGINT) is held: it raises KeyboardInterrupt on leaving the block, not in
    the middle of it.  Only in the main thread with Python's own SIGINT handler (elsewhere,
    or with a handler a program set, nothing changes)."""

    def __enter__(self):
        import signal
        import threading

        self.caught, self.previous = False, None
        if threading.current_thread() is threading.main_thread() and signal.getsignal(signal.SIGINT) is signal.default_int_handler:
            self.previous = signal.signal(signal.SIGINT, self._hold)
        return self

    def _hold(self, signum, frame) -> None:
        self.caught = True

    def __exit__(self, kind, value, tb) -> None:
        if self.previous is not None:
            import signal

            signal.signal(signal.SIGINT, self.previous)
            if self.caught and kind is None:
                raise KeyboardInterrupt


#: Dask settings of the local cluster, each as (Dask's default, this cluster's): the servers'
#: periodic wake-ups, which in a worker take the GIL from the run in its thread (the event
#: loop's lag measured every 20 ms, a statistical profiler sampling every 10 ms, the system
#: monitor's resource readings every 0.5 s), feed only Dask's dashboard and its "event loop
#: was unresponsive" warning; this cluster has neither.  Measured on the 96-grasp sweep of
#: ``bench --throughput``, 2 workers, three alternating pairs: 3-5 % less wall time, the runs
#: 5-6 % less.  A setting a user has changed from Dask's default stays theirs.
LOCAL_CLUSTER_CONFIG = {
    "distributed.admin.tick.interval": ("20ms", "1s"),
    "distributed.worker.profile.enabled": (True, False),
    "distributed.admin.system-monitor.interval": ("500ms", "5s"),
}


def local_cluster_config() -> dict:
    """The settings of :data:`LOCAL_CLUSTER_CONFIG` to set now: those still at Dask's default,
    and the multiprocessing method (a fork from the worker server, when this process started
    one and the method is Dask's default, "spawn")."""
    import dask
    import distributed  # noqa: F401  (its defaults join dask.config on import)

    config = {key: ours for key, (default, ours) in LOCAL_CLUSTER_CONFIG.items() if dask.config.get(key, None) == default}
    method = "distributed.worker.multiprocessing-method"
    if _worker_server and dask.config.get(method) == "spawn":
        config[method] = "forkserver"
    return config


class _client:
    """A Dask client on a local cluster of ``workers`` processes (closed on exit), or on the
    scheduler at ``address``.  The local cluster's workers are forked from the worker server
    when this process started one (:func:`start_worker_server`), with the settings of
    :func:`local_cluster_config` (held while the cluster lives: its workers get them from their
    nanny, and a worker the nanny restarts starts the same way)."""

    def __init__(self, workers: int | None, address: str | None) -> None:
        self.workers, self.address = workers, address
        self.cluster = self.client = self.config = None

    def __enter__(self):
        import dask
        from dask.distributed import Client, LocalCluster

        if self.address is not None:
            try:
                self.client = Client(self.address, timeout="10s")
            except OSError as err:
                raise ValueError(f"--scheduler {self.address}: cannot reach a Dask scheduler there ({err})") from None
            return self.client
        n = self.workers if self.workers is not None else (os.cpu_count() or 1)
        self.config = dask.config.set(local_cluster_config())
        try:
            # A cluster interrupted half-started cannot be closed (Dask's own close at exit then
            # fails with a traceback): a Ctrl-C waits until it is up (well under a second), then
            # closes it.
            with _interrupts_deferred():
                # One thread per process: the loop holds the GIL; processes run side by side.
                self.cluster = LocalCluster(
                    n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None, silence_logs=50, memory_limit=0
                )
                self.client = Client(self.cluster)
        except BaseException:
            self.__exit__(None, None, None)
            raise
        return self.client

    def __exit__(self, *exc) -> None:
        try:
            if self.client is not None:
                self.client.close()
            if self.cluster is not None:
                self.cluster.close()
        finally:
            if self.config is not None:
                self.config.__exit__(None, None, None)
                self.config = None


# -- the command's files ---------------------------------------------------------------------


def sweep_columns(grid_keys: Sequence[str]) -> list[str]:
    """The columns of ``sweep.csv``: the grid's keys as given, the results, then the extras."""
    return [*grid_keys, *RESULT_COLUMNS, *EXTRA_COLUMNS]


def _cell(value):
    if isinstance(value, (list, tuple)):
        return json.dumps(value)
    return value


def write_sweep(rows: list[dict], grid_keys: Sequence[str], out: Path, plot: bool = True) -> list[Path]:
    """``sweep.csv``, ``sweep.parquet`` (units in the column names) and ``sweep.png``."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    out = Path(out)
    columns = sweep_columns(grid_keys)
    csv_path = out / "sweep.csv"
    with csv_path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=columns, extrasaction="ignore")
        writer.writeheader()
        writer.writerows([{c: _cell(r.get(c)) for c in columns} for r in rows])
    table = pa.table({c: _arrow_column([r.get(c) for r in rows]) for c in columns})
    parquet_path = out / "sweep.parquet"
    pq.write_table(table, parquet_path)
    files = [csv_path, parquet_path]
    if plot:
        files.append(plot_sweep(rows, grid_keys, out / "sweep.png"))
    return files


def _arrow_column(values: list):
    """A column's values for Arrow: numbers stay numbers (NaN for missing), lists as JSON text."""
    import pyarrow as pa

    if all(isinstance(v, bool) for v in values):
        return pa.array(values, pa.bool_())
    if all((isinstance(v, (int, float)) and not isinstance(v, bool)) or v is None for v in values):
        return pa.array([math.nan if v is None else float(v) for v in values], pa.float64())
    return pa.array([json.dumps(v) if isinstance(v, (list, tuple)) else ("" if v is None else str(v)) for v in values], pa.string())


#: Colour per outcome in the plots.
OUTCOME_COLOUR = {
    "success": "#4caf50",
    "never_lifted": "#bdbdbd",
    "blind": "#ffb74d",
    "timeout": "#ffe082",
    "slipped": "#ff8a65",
    "dropped": "#e57373",
    "crushed": "#b71c1c",
    "fault": "#7e57c2",
    ERROR_OUTCOME: "#212121",
}


def plot_sweep(rows: list[dict], grid_keys: Sequence[str], path: Path) -> Path:
    """The outcome over the grid: a coloured cell per point over the first two keys (the rest
    listed in the cell), and the peak pressure against the first key."""
    from matplotlib.patches import Patch, Rectangle

    from .plotting import new_figure, save_figure

    x_key = grid_keys[0]
    y_key = grid_keys[1] if len(grid_keys) > 1 else None
    xs = list(dict.fromkeys(_label(r[x_key]) for r in rows))
    ys = list(dict.fromkeys(_label(r[y_key]) for r in rows)) if y_key else [""]
    fig, axes = new_figure(1, 2, figsize=(14, 6))
    ax, ax_p = axes[0]
    cells: dict[tuple[int, int], list[dict]] = {}
    for r in rows:
        cells.setdefault((xs.index(_label(r[x_key])), ys.index(_label(r[y_key])) if y_key else 0), []).append(r)
    for (i, j), group in cells.items():
        outcomes = [g["outcome"] for g in group]
        main = max(set(outcomes), key=outcomes.count)
        ax.add_patch(Rectangle((i - 0.5, j - 0.5), 1, 1, facecolor=OUTCOME_COLOUR.get(main, "white"), edgecolor="white"))
        text = main.replace("_", " ") if len(group) == 1 else f"{sum(g['success'] for g in group)}/{len(group)} ok"
        ax.text(i, j, text, ha="center", va="center", fontsize=7)
    ax.set_xlim(-0.5, len(xs) - 0.5)
    ax.set_ylim(-0.5, len(ys) - 0.5)
    ax.set_xticks(range(len(xs)), xs, rotation=30)
    ax.set_yticks(range(len(ys)), ys)
    ax.set(xlabel=x_key, ylabel=y_key or "", title="outcome per point (referee)")
    present = list(dict.fromkeys(r["outcome"] for r in rows))
    ax.legend(handles=[Patch(color=OUTCOME_COLOUR.get(o, "white"), label=o) for o in present], fontsize=7, loc="upper right")
    for y in ys:
        group = [r for r in rows if not y_key or _label(r[y_key]) == y]
        xi = [xs.index(_label(r[x_key])) for r in group]
        ax_p.semilogy(xi, [r["max_pressure_pa"] for r in group], "o-", label=f"{y_key} = {y}" if y_key else "peak")
    ax_p.set_xticks(range(len(xs)), xs, rotation=30)
    ax_p.set(xlabel=x_key, ylabel="peak pressure on the element [Pa]", title="peak pressure per point")
    ax_p.grid(True, which="both", alpha=0.3)
    ax_p.legend(fontsize=7)
    return save_figure(fig, path)


def _label(value) -> str:
    if isinstance(value, (list, tuple)):
        return json.dumps(value)
    return f"{value:g}" if isinstance(value, float) else str(value)


def format_rows(rows: list[dict], grid_keys: Sequence[str]) -> str:
    """The sweep's rows as a text table."""
    head = [*grid_keys, "outcome", "peak P [Pa]", "held P [Pa]", "grip margin", "modes", "wall [s]"]
    lines = []
    for r in rows:
        margin = r.get("grip_margin", math.nan)
        pressures = [f"{r['max_pressure_pa']:.3g}", f"{r['held_pressure_pa']:.3g}"]
        numbers = [*pressures, f"{margin:.2f}", r["modes_used"], f"{r['wall_time_s']:.2f}"]
        lines.append([*(_label(r[k]) for k in grid_keys), r["outcome"], *numbers])
    widths = [max(len(h), *(len(line[i]) for line in lines)) if lines else len(h) for i, h in enumerate(head)]
    text = ["  ".join(h.ljust(w) for h, w in zip(head, widths, strict=True))]
    text += ["  ".join(c.ljust(w) for c, w in zip(line, widths, strict=True)) for line in lines]
    return "\n".join(text)


def sweep(
    scenario: str,
    grid: Mapping[str, Sequence[object]],
    preset: str | None = None,
    overrides: Sequence[str] | Mapping[str, object] | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    out: str | Path | None = None,
    progress: bool = False,
    plot: bool = False,
) -> list[dict]:
    """Run ``scenario`` at every point of ``grid`` (``{"object.mass_kg": [0.1, 0.4], ...}``) on
    Dask and return a row per point (see :data:`RESULT_COLUMNS`); with ``out``, write
    ``sweep.csv``, ``sweep.parquet`` (and ``sweep.png`` with ``plot``) there and resume from it.
    ``overrides`` apply to every point, before the grid's values."""
    from piezotip import scenarios

    base = scenarios.override_strings(overrides)
    points = grid_points(grid, base)
    check_points(scenario, points, preset)
    result = run_points(scenario, points, preset, Path(out) if out is not None else None, workers, scheduler, progress)
    if out is not None:
        write_sweep(result.rows, list(grid), Path(out), plot=plot)
    return result.rows


def check_points(scenario: str, points: Sequence[Point], preset: str | None) -> None:
    """Every point's config validated before any run (a bad value stops the sweep at once)."""
    from piezotip import scenarios

    for point in points:
        scenarios.get(scenario, list(point.overrides), preset)
