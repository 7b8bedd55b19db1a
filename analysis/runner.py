"""Running one scenario headless: the recording, the plot, the frames and the summary.

A run's folder holds one run.  ``summary.json`` is the mark of a finished one: a run removes it
before it writes anything else, and writes it last (beside, then renamed), so a folder whose run
was killed has no summary, never an old one beside a new recording.  A rerun removes the files a
run writes, by name (:data:`RUN_FILES` and the recording's own, :mod:`piezotip.cosim.recorder`),
whether or not it will write them again; anything else in the folder stays, and a
``run.chunks/`` holding files no recording wrote stops the run before it removes anything.

Signals: during a run (in the main thread) SIGINT and SIGTERM both end it as Ctrl-C does: the
first stops the loop, the recording so far is kept, the plot and a summary marked
``"interrupted": true`` are written, its ``"signal"`` naming which (:class:`_Signals`).  Signals
that come after the first (a second Ctrl-C) are held until the summary is written: they do not
cut the close of the recording or the summary short.  The exit status (130 for SIGINT, 143 for
SIGTERM, :func:`exit_status`) is the command line's to return; :func:`piezotip.run` raises the
signal's exception after the summary is written (:mod:`piezotip.interrupts`).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import signal
from collections.abc import Mapping
from dataclasses import asdict
from pathlib import Path

import numpy as np

from piezotip.runtime.interrupts import RunInterrupted, in_main_thread, interruption, note, raise_interruption, replaceable
from piezotip.runtime.provenance import json_safe

#: The files a run writes in its folder besides the recording (``run.npz``, ``run.csv``,
#: ``run.chunks/``): a rerun removes them, ``summary.json`` first (and its temporary).
RUN_FILES = ("summary.json", "summary.json.tmp", "run.png", "frames.png", "run.mp4")

#: The handler that raises a signal as Ctrl-C (piezotip.interrupts.raise_interruption), by the name
#: it had here; :class:`RunInterrupted` is imported from there too.
sigterm_as_interrupt = raise_interruption


def exit_status(report: dict) -> int | None:
    """The exit status of an interrupted run's command (130 after SIGINT, 143 after SIGTERM: 128 +
    the signal's number, from the summary's ``"signal"``), or None when it was not interrupted."""
    if not report.get("interrupted"):
        return None
    return 128 + signal.Signals[report.get("signal") or "SIGINT"]


class _Signals:
    """SIGINT and SIGTERM during a run (main thread only; elsewhere nothing changes).

    The first signal is remembered (``signum``) and, while ``armed`` and the recorder (when
    given) has not begun closing, raised as :class:`RunInterrupted` (the loop catches it as
    Ctrl-C); any later signal, or one that comes once disarmed, is held (remembered if first,
    never raised).  The handlers Python started with come back on leaving."""

    def __init__(self) -> None:
        self.signum: int | None = None
        self.armed = True
        self.recorder = None
        self._previous: dict[int, object] = {}

    def __enter__(self) -> _Signals:
        if in_main_thread():
            for signum in (signal.SIGINT, signal.SIGTERM):
                if replaceable(signum, signal.getsignal(signum)):
                    self._previous[signum] = signal.signal(signum, self._handle)
        return self

    def _handle(self, signum, frame) -> None:
        note(signum)
        if self.signum is None:
            self.signum = signum
            if self.armed and not (self.recorder is not None and self.recorder.closing):
                self.armed = False
                raise interruption(signum)

    def __exit__(self, *exc) -> None:
        for signum, previous in self._previous.items():
            signal.signal(signum, previous)
        self._previous.clear()


def default_out_dir(name: str, overrides: list[str] | tuple[str, ...] = (), preset: str | None = None) -> Path:
    """Where a run writes by default: ``out/NAME``, or ``out/NAME-<hash>`` when overrides or a
    preset change it, so a run with overrides never overwrites another run's folder (the
    folder's summary.json lists the overrides)."""
    if not overrides and preset is None:
        return Path("out") / name
    key = json.dumps([list(overrides), preset])
    return Path("out") / f"{name}-{hashlib.sha1(key.encode()).hexdigest()[:8]}"


def check_out_dir(out: Path) -> Path:
    """``out`` as a folder that can be written, or a ValueError naming it and why not."""
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {str(out)!r} is an existing file, not a folder")
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / ".write-test"
        probe.touch()
        probe.unlink()
    except OSError as err:
        raise ValueError(f"--out {str(out)!r} cannot be written: {err.strerror or err}") from None
    return out


def run_scenario(
    name: str,
    overrides: list[str],
    out: Path,
    csv: bool = False,
    render: bool = False,
    plot: bool = True,
    quiet: bool = False,
    preset: str | None = None,
    video: bool = False,
    video_fps: float | None = None,
    video_size: tuple[int, int] | None = None,
) -> tuple[dict, Mapping[str, np.ndarray]]:
    """Run scenario ``name`` with ``overrides``; write into ``out``; return (summary, recorded data).

    Files: ``run.npz`` (every control step, units in the column names), ``run.csv`` with
    ``csv``, ``run.png`` with ``plot``, ``frames.png`` with ``render``, ``run.mp4`` with
    ``video`` (``video_fps`` frames per simulated second, ``video_size`` (width, height):
    analysis.video's defaults when None), ``summary.json`` (last: see the module's notes).
    A divergence stops the run with the recording kept; the summary's ``error`` says why.
    SIGINT (Ctrl-C) or SIGTERM stops it too, the summary then ``"interrupted": true`` with the
    signal's name in ``"signal"``; one before the loop starts raises :class:`RunInterrupted`
    (:class:`~piezotip.interrupts.Terminated` for SIGTERM).

    The recorded data is ``run.npz``'s columns, each read from the file when asked for
    (:class:`piezotip.cosim.recorder.Columns`: a long run's recording is never in memory whole;
    ``dict(data)`` loads it), readable after ``out`` is removed.
    """
    with _Signals() as signals, MujocoWarnings() as warned:
        return _run(name, overrides, out, csv, render, plot, quiet, preset, video, video_fps, video_size, signals, warned)


class MujocoWarnings:
    """MuJoCo's text warnings while a run lasts, counted by message, instead of MuJoCo's default
    (printed and appended to ``MUJOCO_LOG.TXT`` in the current directory, where a user's script
    or a batch of runs leaves them unread).  A context manager: MuJoCo's handler is process-wide,
    so the one in place before is put back on leaving (a handler of the user's own, too)."""

    def __init__(self) -> None:
        self.counts: dict[str, int] = {}
        self._previous = None

    def _warned(self, message: str) -> None:
        self.counts[message] = self.counts.get(message, 0) + 1

    def __enter__(self) -> MujocoWarnings:
        import mujoco

        self._previous = mujoco.get_mju_user_warning()
        mujoco.set_mju_user_warning(self._warned)
        return self

    def __exit__(self, *exc) -> None:
        import mujoco

        mujoco.set_mju_user_warning(self._previous)

    def listed(self) -> list[dict]:
        """[{"message": ..., "count": n}], in the order first seen."""
        return [{"message": message, "count": count} for message, count in self.counts.items()]


def _start_folder(out: Path) -> None:
    """Mark ``out`` as holding a run in progress: no summary (removed first), no file of an old run
    (removed by name); a ``run.chunks/`` with files no recording wrote stops here, before any removal."""
    from piezotip.cosim.recorder import check_replaceable

    check_replaceable(out / "run")
    for name in RUN_FILES:
        (out / name).unlink(missing_ok=True)


def _run(name, overrides, out, csv, render, plot, quiet, preset, video, video_fps, video_size, signals: _Signals, warned: MujocoWarnings):
    from piezotip import scenarios
    from piezotip.cosim.loop import CoSimulation, RunResult
    from piezotip.cosim.recorder import Recorder
    from piezotip.runtime.provenance import config_provenance

    from .run_report import object_disturbance, object_friction, object_needed_grip_n, plot_run, summary

    config = scenarios.get(name, overrides, preset)
    # what made it: piezotip, mujoco, numpy, scipy, python, the commit; the seeds and the whole config
    # as run (defaults and preset included).  Known now: after the run, it would widen the time in
    # which a signal comes too late to be reported (its first call asks git)
    provenance = config_provenance(config)
    out = check_out_dir(Path(out))
    _start_folder(out)
    sim = CoSimulation(config)
    from piezotip.cosim.control import PHASES
    from piezotip.cosim.rows import STATUS_CODES

    meta = {
        "scenario": name,
        "preset": preset,
        "overrides": list(overrides),
        "units": "in column names (_s, _m, _n, _pa; v1 and modes dimensionless)",
        "phase_codes": list(PHASES),
        "status_codes": list(STATUS_CODES),
    }
    recorder = Recorder(out / "run", csv=csv, metadata=meta)
    signals.recorder = recorder  # a signal once the recorder closes is held, not raised into its close
    total = math.ceil(config.duration_s / config.physics.control_period_s - 1e-9)
    strip = None
    if render:
        from .render import FrameStrip

        strip = FrameStrip(sim.model, total)
    on_step, movie = strip, None
    if video:  # imported and created only when asked for (the renderer starts before the run)
        from .video import DEFAULT_FPS, DEFAULT_SIZE, VideoWriter

        fps, size = DEFAULT_FPS if video_fps is None else video_fps, DEFAULT_SIZE if video_size is None else video_size
        movie = VideoWriter(sim, out / "run.mp4", recorder.rows_from, config.duration_s, fps, size, not quiet)
        on_step = movie if strip is None else (lambda s: (strip(s), movie(s)))
    from tqdm import tqdm

    try:
        with tqdm(total=total, desc=name, unit="step", disable=quiet, leave=False) as bar:
            try:
                result = sim.run(recorder, progress=bar, on_step=on_step)
            except RunInterrupted:  # the signal came between the loop's own catch and the recorder's close
                signals.armed = False
                result = RunResult(sim.steps, sim.time_s, math.nan, recorder.close(), None, True)
            signals.armed = False  # from here on every signal is held until the summary is written
            if not result.interrupted and result.error is None:  # ended (early, once at rest): done
                bar.total = bar.n
                bar.refresh()
    finally:
        signals.armed = False
        if movie is not None:
            movie.close()
    data = recorder.data()
    if data and not len(data["time_s"]):  # a signal between the first row's columns and its values: no row
        data = {}
    files = [str(f) for f in result.files]
    events = [asdict(e) for e in sim.controller.events]
    needed = object_needed_grip_n(sim.model)
    disturbance = object_disturbance(config, sim.model)
    friction = object_friction(sim.model)
    report = summary(config, data, result.wall_time_s, files, result.error, events, sim.controller.finished, needed, disturbance, friction)
    if data and plot:
        files.append(str(plot_run(config, sim.fingertip, data, out, report)))
    if strip is not None and strip.images:
        files.append(str(strip.save(out / "frames.png")))
    if movie is not None and movie.frames:
        files.append(str(movie.path))
    report["events"] = events
    report["interrupted"] = report["signal"] = None  # their place; decided as late as can be (below)
    report["mujoco_warnings"] = warned.listed()  # MuJoCo's own text warnings during the run, counted
    report["touch_time_s"] = getattr(sim.controller, "touch_time_s", math.nan)
    report["overrides"] = list(overrides)
    report["preset"] = preset
    report.update(provenance)  # last: what repeats it
    summary_path = out / "summary.json"
    report["files"].append(str(summary_path))
    _mark_interrupted(report, result.interrupted, signals.signum, result.sim_time_s)
    _write_summary(summary_path, report)
    if signals.signum is not None and not report["interrupted"]:  # the first signal came as it was written:
        _mark_interrupted(report, True, signals.signum, result.sim_time_s)  # reported, as one a moment earlier is
        _write_summary(summary_path, report)
    return report, data


def _mark_interrupted(report: dict, stopped: bool, signum: int | None, sim_time_s: float) -> None:
    """The summary's ``interrupted`` and ``signal``, and the reason's prefix, when the loop was
    ``stopped`` or a signal (``signum``) came before the summary was written."""
    interrupted = stopped or signum is not None
    report["interrupted"] = interrupted
    report["signal"] = signal.Signals(signum or signal.SIGINT).name if interrupted else None
    if interrupted:
        how = "Ctrl-C" if report["signal"] == "SIGINT" else report["signal"]
        report["reason"] = f"interrupted ({how}) at t = {sim_time_s:.2f} s; {report['reason']}"


def _write_summary(path: Path, report: dict) -> None:
    """``summary.json``, whole or not at all: written beside, then renamed (the module's notes)."""
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(json_safe(report), indent=2) + "\n")
    os.replace(tmp, path)
