"""Running one scenario headless: the recording, the plot, the frames and the summary."""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import asdict
from pathlib import Path

import numpy as np


def json_safe(value):
    """Replace non-finite floats by None (strict JSON) and numpy scalars by Python ones."""
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, (np.integer, np.bool_)):
        return value.item()
    if isinstance(value, dict):
        return {k: json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    return value


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
) -> tuple[dict, dict[str, np.ndarray]]:
    """Run scenario ``name`` with ``overrides``; write into ``out``; return (summary, recorded data).

    Files: ``run.npz`` (every control step, units in the column names), ``run.csv`` with
    ``csv``, ``run.png`` with ``plot``, ``frames.png`` with ``render``, ``run.mp4`` with
    ``video`` (``video_fps`` frames per simulated second, ``video_size`` (width, height):
    analysis.video's defaults when None), ``summary.json``.
    A divergence stops the run with the recording kept; the summary's ``error`` says why.
    """
    from piezotip import scenarios
    from piezotip.cosim.loop import CoSimulation
    from piezotip.cosim.recorder import Recorder

    from .run_report import object_needed_grip_n, plot_run, summary

    config = scenarios.get(name, overrides, preset)
    out = check_out_dir(Path(out))
    sim = CoSimulation(config)
    from piezotip.cosim.control import PHASES
    from piezotip.cosim.loop import STATUS_CODES

    meta = {
        "scenario": name,
        "preset": preset,
        "overrides": list(overrides),
        "units": "in column names (_s, _m, _n, _pa; v1 and modes dimensionless)",
        "phase_codes": list(PHASES),
        "status_codes": list(STATUS_CODES),
    }
    recorder = Recorder(out / "run", csv=csv, metadata=meta)
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
            result = sim.run(recorder, progress=bar, on_step=on_step)
            if not result.interrupted and result.error is None:  # ended (early, once at rest): done
                bar.total = bar.n
                bar.refresh()
    finally:
        if movie is not None:
            movie.close()
    data = recorder.data()
    files = [str(f) for f in result.files]
    events = [asdict(e) for e in sim.controller.events]
    needed = object_needed_grip_n(sim.model)
    report = summary(config, data, result.wall_time_s, files, result.error, events, sim.controller.finished, needed)
    if data and plot:
        files.append(str(plot_run(config, sim.fingertip, data, out, report)))
    if strip is not None and strip.images:
        files.append(str(strip.save(out / "frames.png")))
    if movie is not None and movie.frames:
        files.append(str(movie.path))
    report["events"] = events
    report["interrupted"] = result.interrupted
    if result.interrupted:
        report["reason"] = f"interrupted (Ctrl-C) at t = {result.sim_time_s:.2f} s; {report['reason']}"
    report["touch_time_s"] = getattr(sim.controller, "touch_time_s", math.nan)
    report["overrides"] = list(overrides)
    report["preset"] = preset
    summary_path = out / "summary.json"
    report["files"].append(str(summary_path))
    summary_path.write_text(json.dumps(json_safe(report), indent=2) + "\n")
    return report, data
