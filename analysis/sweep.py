"""Many runs at once on Dask: ``run_sim.py sweep`` and ``experiment grasp-range`` share this.

A sweep is a list of points (:mod:`analysis.sweep_grid`), each a list of ``key=value`` overrides
of one scenario.  Every point runs in a Dask worker process (:func:`run_point`), which sends back
one row of numbers (:mod:`analysis.sweep_rows`), never the recording.  By default the work goes
to a local cluster over this machine's cores, started and stopped here; ``scheduler="tcp://host:8786"``
sends it to a cluster someone started (``dask scheduler`` on one machine, ``dask worker
tcp://host:8786`` on each machine with piezotip installed); see :mod:`analysis.sweep_cluster`.
``workers=0`` runs in this process, one point after the other (no Dask), which is what the tests
compare the parallel rows against; a single point to run on a local cluster runs here too
(:func:`runs_in_this_process`: the cluster would only add its start-up, the rows are the same).

Resume: each finished point's row is appended at once to the output folder's journal
(:mod:`analysis.sweep_journal`); a sweep run again with the same folder skips the points already
there.  A point that raises is recorded with its error (``outcome`` ``error``) and the sweep goes
on.  The files: :mod:`analysis.sweep_output`.

Worker processes keep their caches (mode bands, gel tables) across the points they run, and
the on-disk cache (:mod:`piezotip.sensor.cache`) shares them across processes and runs.
"""

from __future__ import annotations

import os
import signal
import time
import traceback
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from .sweep_cluster import dask_client, raise_if_scheduler_lost
from .sweep_grid import Point, check_points, grid_points
from .sweep_journal import JOURNAL_NAME, append_row, load_done, normalized
from .sweep_output import write_sweep
from .sweep_rows import error_row, point_row


def run_point(
    scenario: str, overrides: Sequence[str], preset: str | None, run_dir: str | None = None, options: Mapping | None = None
) -> dict:
    """Run one point (in a worker) and return its row; an exception becomes an error row.

    ``run_dir``: where the run's own files go (``run.npz``, ``summary.json``), or None to keep
    the recording in memory only.  ``options``: more keywords of ``run_scenario`` (e.g. video).
    The row's ``wall_time_s`` is the whole point (set-up, loop, summary), as the user waits.
    A run a signal interrupted (Ctrl-C or SIGTERM in this process's main thread: the sweep run
    one point after the other) raises the signal's exception (:func:`piezotip.interrupts.interruption`),
    and so does an error the signal caused (an import it cut short): the point is not done,
    nothing is journaled for it, and the sweep stops.
    """
    options = dict(options or {})
    import tempfile

    from piezotip.runtime.interrupts import interruption, signal_in

    from .runner import run_scenario

    start = time.perf_counter()
    try:
        if run_dir is None:
            with tempfile.TemporaryDirectory(prefix="piezotip-point-") as tmp:
                summary, data = run_scenario(scenario, list(overrides), Path(tmp), plot=False, quiet=True, preset=preset, **options)
        else:
            summary, data = run_scenario(scenario, list(overrides), Path(run_dir), plot=False, quiet=True, preset=preset, **options)
        if summary.get("interrupted"):  # Ctrl-C or SIGTERM cut the run short: not a row to journal, the sweep stops
            raise interruption(signal.Signals[summary.get("signal") or "SIGINT"])
        row = point_row(summary, data)
    except Exception as err:  # recorded, and the sweep goes on
        if signal_in(err) is not None:  # not the point's failure: the signal's, and the sweep stops
            raise interruption(signal_in(err)) from None
        last = traceback.extract_tb(err.__traceback__)[-1]
        row = error_row(f"{type(err).__name__}: {err} ({Path(last.filename).name}:{last.lineno})")
    row["wall_time_s"] = time.perf_counter() - start
    row["pid"] = os.getpid()
    return row


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


def runs_in_this_process(points_to_run: int, workers: int | None, scheduler: str | None) -> bool:
    """Whether :func:`run_points` runs its points here, one after the other, rather than on Dask:
    with ``workers=0``, and with a single point to run on a local cluster.

    Why one point: ``N`` points of ``c`` s each take ``N c`` here and ``S + ceil(N / W) c`` on
    ``W`` local workers, ``S`` the cluster's start and close (about 1 s: its workers spawned or
    forked, Dask imported here, the close; profiled on a one-point ``piezotip.sweep``).  Here is
    never slower when ``c (N - ceil(N / W)) <= S``: for ``N = 1`` whatever the point costs; for
    ``N = 2`` only when ``c <= S``, which a 7 s grasp meets at the fast preset (0.2 s) but not
    every run does (the accurate preset's is about 1 s, longer scenarios and the reference
    preset more).  The rows are the same either way (tests/test_sweep.py).  A scheduler's
    address always gets the work: the user sent it there.
    """
    return scheduler is None and (workers == 0 or points_to_run <= 1)


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
    points in this process, as does a single point to run (:func:`runs_in_this_process`).
    ``scheduler``: the address of a running Dask scheduler (then ``workers`` is ignored).
    ``keep_runs``: each point's ``run.npz`` and ``summary.json`` in ``out/runs/NN`` (NN the
    point's index).  ``options``: more keywords of ``run_scenario``.
    """
    from tqdm import tqdm

    from .runner import check_out_dir

    start = time.perf_counter()
    journal = None
    done: dict[str, dict] = {}
    if out is not None:
        out = check_out_dir(Path(out))
        journal = out / JOURNAL_NAME
        done = load_done(journal)
    keys = [p.key(scenario, preset) for p in points]
    todo = [i for i, k in enumerate(keys) if k not in done]
    results: dict[int, dict] = {}

    def run_dir(i: int) -> str | None:
        return str(out / "runs" / f"{i:02d}") if keep_runs and out is not None else None

    def finish(i: int, row: dict) -> None:
        results[i] = row = normalized(row)
        if journal is not None:  # one line per point, appended at once: a kill loses only runs in flight
            append_row(journal, keys[i], row)
        bar.update(1)

    n_workers = 0
    with tqdm(total=len(points), initial=len(points) - len(todo), desc=desc, unit="run", disable=not progress, leave=False) as bar:
        if todo and runs_in_this_process(len(todo), workers, scheduler):
            for i in todo:
                finish(i, run_point(scenario, points[i].overrides, preset, run_dir(i), options))
        elif todo:
            with dask_client(workers, scheduler) as client:
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
                        # ... or the scheduler: every point left is cancelled, none failed; the sweep stops
                        raise_if_scheduler_lost(client, err, scheduler, len(results), len(todo), journal)
                        row = error_row(f"{type(err).__name__}: {err}")
                    finish(i, row)
    rows = []
    for i, point in enumerate(points):
        row = done.get(keys[i]) if i not in results else results[i]
        rows.append({**point.values, **row})
    return SweepRun(rows, len(points) - len(todo), n_workers, time.perf_counter() - start)


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
    Dask and return a row per point (see :data:`analysis.sweep_rows.RESULT_COLUMNS`); with ``out``, write
    ``sweep.csv``, ``sweep.parquet`` (and ``sweep.png`` with ``plot``) there and resume from it.
    ``overrides`` apply to every point, before the grid's values.

    Ctrl-C raises KeyboardInterrupt out of the call, SIGTERM :class:`piezotip.interrupts.Terminated`
    (a KeyboardInterrupt, and uncaught an exit with status 143), once the cluster is closed; the
    points finished are in ``out``'s journal, from which the same call resumes."""
    from piezotip import scenarios
    from piezotip.runtime import interrupts

    base = scenarios.override_strings(overrides)
    points = grid_points(grid, base)
    check_points(scenario, points, preset)
    with interrupts.raised():  # SIGTERM as Ctrl-C (its default would end the process, the cluster left behind)
        try:
            result = run_points(scenario, points, preset, Path(out) if out is not None else None, workers, scheduler, progress)
            if out is not None:
                write_sweep(result.rows, list(grid), Path(out), plot=plot, provenance=sweep_provenance(scenario, grid, base, preset))
            signum = interrupts.noted()  # a signal a library swallowed: the caller stops all the same
        except BaseException as err:
            signum = interrupts.signal_in(err)
            if signum is None:
                raise
        if signum is not None:
            kept = f"the points finished are journaled in {Path(out) / JOURNAL_NAME}" if out is not None else "nothing was kept (no out)"
            message = f"piezotip.sweep({scenario!r}) interrupted ({signal.Signals(signum).name}); {kept}"
            raise interrupts.caller_error(signum, message) from None
    return result.rows


def sweep_provenance(scenario: str, grid: Mapping[str, Sequence[object]], overrides: Sequence[str], preset: str | None) -> dict:
    """What a sweep's files carry (:mod:`piezotip.provenance`): the scenario, preset, overrides and
    grid; the versions; the seeds and the config every point starts from (the preset and
    ``overrides`` applied), each point then setting the grid's keys to its row's values."""
    from piezotip import scenarios
    from piezotip.runtime.provenance import config_provenance

    base = scenarios.get(scenario, list(overrides), preset)
    grid = {key: list(values) for key, values in grid.items()}
    return {"scenario": scenario, "preset": preset, "overrides": list(overrides), "grid": grid, **config_provenance(base)}
