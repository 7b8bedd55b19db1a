"""Video of a run (analysis/video.py, ``run_sim.py run SCENARIO --video``, issue 12).

* the MP4 decodes to the expected frame count (one frame per 1/fps of simulated time) and size;
* a run without --video imports nothing of it and creates no renderer;
* bad --video-fps / --video-size, and no display or no usable OpenGL, end in one line (the
  latter naming MUJOCO_GL) with exit status 2;
* the live strip draws a pressure where the log axis puts it.

Rendering runs in processes of their own: MuJoCo picks its OpenGL backend (MUJOCO_GL) on its
first import, which in the test process happened long before.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import imageio_ffmpeg
import numpy as np
import pytest

from piezotip import cli
from piezotip.analysis.video import LiveStrip, check_fps, parse_size

ROOT = Path(__file__).resolve().parent.parent


def _run(args: list[str], **env) -> subprocess.CompletedProcess:
    base = {k: v for k, v in os.environ.items() if k != "MUJOCO_GL"}  # the command line's own default
    return subprocess.run([sys.executable, *args], cwd=ROOT, capture_output=True, text=True, timeout=300, env={**base, **env})


def test_run_video_decodes_to_the_expected_frames_and_size(tmp_path):
    fps, width, height = 20.0, 320, 240
    args = ["run_sim.py", "run", "grasp", "--preset", "fast", "--set", "duration_s=1.0", "--no-plot", "--json"]
    result = _run([*args, "--out", str(tmp_path), "--video", "--video-fps", str(fps), "--video-size", f"{width}x{height}"])
    if result.returncode == 2 and "MUJOCO_GL" in result.stderr:
        pytest.skip(f"no OpenGL for MuJoCo here: {result.stderr.strip()}")
    assert result.returncode in (0, 1), result.stderr
    summary = json.loads(result.stdout)
    mp4 = tmp_path / "run.mp4"
    assert str(mp4) in summary["files"]
    with np.load(tmp_path / "run.npz") as f:
        t_last = float(f["time_s"][-1])
    # Frame n shows simulated time n / fps: n = 0 .. floor(t_last fps).
    expected = len(np.arange(0.0, t_last + 1e-9, 1.0 / fps))
    assert expected == 21  # 1 s at 20 fps, both ends
    reader = imageio_ffmpeg.read_frames(str(mp4))
    meta = next(reader)
    frames = [np.frombuffer(f, np.uint8) for f in reader]
    assert meta["size"] == (width, height)
    assert meta["fps"] == pytest.approx(fps)
    assert "h264" in meta["codec"]
    assert len(frames) == expected
    assert all(f.size == width * height * 3 for f in frames)
    first, last = (f.reshape(height, width, 3) for f in (frames[0], frames[-1]))
    assert np.abs(first.astype(int) - last.astype(int)).mean() > 0.5  # the strip grew, the fingers moved


def test_no_video_no_renderer_no_import(tmp_path):
    code = (
        "import sys, mujoco\n"
        "class NoRenderer:\n"
        "    def __init__(self, *a, **k): raise AssertionError('a renderer was created')\n"
        "mujoco.Renderer = NoRenderer\n"
        "from piezotip import cli\n"
        "argv = ['run', 'grasp', '--preset', 'fast', '--set', 'duration_s=0.2', '--no-plot', '--json']\n"
        f"code = cli.main([*argv, '--out', {str(tmp_path)!r}])\n"
        "print(code, 'piezotip.analysis.video' in sys.modules, 'imageio_ffmpeg' in sys.modules)\n"
    )
    result = _run(["-c", code])
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip().splitlines()[-1] == "1 False False"  # 0.2 s: a timeout, no renderer, no video module
    assert not (tmp_path / "run.mp4").exists()


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["--video", "--video-size", "321x240"], ["--video-size", "even", "321"]),
        (["--video", "--video-size", "100000x240"], ["--video-size", "160-4096"]),
        (["--video", "--video-size", "big"], ["--video-size", "WIDTHxHEIGHT", "'big'"]),
        (["--video", "--video-fps", "0"], ["--video-fps", "(0, 200]", "0.0"]),
        (["--video", "--video-fps", "1000"], ["--video-fps", "control rate", "1000"]),
        (["--video-fps", "30"], ["need --video"]),
    ],
)
def test_bad_video_options_are_one_line(capsys, tmp_path, argv, words):
    code = cli.main(["run", "grasp", "--preset", "fast", "--set", "duration_s=0.1", "--no-plot", "--out", str(tmp_path), *argv])
    err = capsys.readouterr().err.strip()
    assert code == 2, err
    assert err.startswith("error: ") and "\n" not in err, err
    for word in words:
        assert word in err, (word, err)
    assert not (tmp_path / "run.npz").exists()  # stopped before the run


@pytest.mark.parametrize(
    "env",
    [
        {"MUJOCO_GL": "glfw", "DISPLAY": "", "WAYLAND_DISPLAY": ""},  # no display
        {"MUJOCO_GL": "egl", "PYOPENGL_PLATFORM": "osmesa"},  # EGL cannot load: the backend's import fails
        {"MUJOCO_GL": "osmesa"},  # a backend whose library is missing fails MuJoCo's own import
    ],
)
def test_no_display_or_no_opengl_is_one_line_naming_mujoco_gl(tmp_path, env):
    args = ["run_sim.py", "run", "grasp", "--preset", "fast", "--set", "duration_s=0.1", "--no-plot", "--out", str(tmp_path)]
    result = _run([*args, "--video"], **env)
    if result.returncode == 0:
        pytest.skip(f"MUJOCO_GL={env['MUJOCO_GL']} renders on this machine")
    lines = result.stderr.strip().splitlines()
    assert result.returncode == 2, result.stderr
    assert len(lines) == 1 and lines[0].startswith("error: "), result.stderr
    assert f"MUJOCO_GL={env['MUJOCO_GL']!r}" in lines[0] and "MUJOCO_GL=egl" in lines[0]


def test_size_and_fps_checks():
    assert parse_size("960x540") == (960, 540)
    assert parse_size(" 320 X 180 ") == (320, 180)
    assert check_fps(200, 0.005) == 200.0
    with pytest.raises(ValueError, match="even"):
        parse_size("960x541")
    with pytest.raises(ValueError, match="video-fps"):
        check_fps(float("nan"), 0.005)


def test_live_strip_draws_a_pressure_where_the_log_axis_puts_it():
    width, height = 480, 540
    strip = LiveStrip(width, height, ("left",), (1, 2, 3, 4), duration_s=2.0, pressure_range_pa=(0.1, 1e6))
    t = np.arange(1, 201) * 0.005
    data = {
        "time_s": t,
        "phase": np.full(t.size, 3.0),
        "left_true_pressure_pa": np.full(t.size, 1e3),
        "left_estimate_pa": np.full(t.size, np.nan),
        "left_mode": np.full(t.size, 2.0),
    }
    image = strip.draw(data)
    assert image.shape == (height, width, 3) and image.dtype == np.uint8
    blue = np.array([31, 119, 180])  # tab:blue, the left pad's colour
    ax = strip.fig.axes[0]
    _, y_top = ax.transData.transform((0.5, 1e3))  # display y of 1 kPa, from the bottom
    x0, _ = ax.transData.transform((0.0, 1e3))
    x1, _ = ax.transData.transform((1.0, 1e3))
    rows = np.nonzero(np.all(np.abs(image[:, int(x0) + 5 : int(x1) - 5].astype(int) - blue) < 40, axis=2))[0]
    pressure_rows = rows[rows < height * 0.55]  # the pressure axes are the strip's top half
    assert pressure_rows.size > 0
    # 1 kPa is 4 of the axis's 7 decades up: the line sits there, to within its width.
    assert abs(np.median(pressure_rows) - (height - y_top)) <= 2.0
    expected_fraction = (math.log10(1e3) - math.log10(0.1)) / (math.log10(1e6) - math.log10(0.1))
    bottom, top = ax.get_window_extent().y0, ax.get_window_extent().y1
    assert (y_top - bottom) / (top - bottom) == pytest.approx(expected_fraction, abs=1e-6)
    # A run that outlasts the axis (the recording's tail after the controller) widens it.
    longer = {k: np.concatenate([v, v[-1:]]) for k, v in data.items()}
    longer["time_s"][-1] = 3.0
    strip.draw(longer)
    assert ax.get_xlim()[1] >= 3.0


def _long_strip_data(n: int, seed: int = 1) -> dict[str, np.ndarray]:
    """A pad's record over n readings (5 ms): a wandering pressure with a one-reading spike and
    gaps (no estimate, no contact), a mode switching often, the phases in turn."""
    rng = np.random.default_rng(seed)
    t = np.arange(1, n + 1) * 0.005
    p = 10.0 ** (2.0 + np.cumsum(rng.normal(0.0, 0.02, n)))
    p[n // 2] = 1e5
    p[int(0.6 * n) : int(0.63 * n)] = 0.0
    est = p * (1.0 + 0.1 * rng.normal(size=n))
    est[int(0.2 * n) : int(0.25 * n)] = np.nan
    mode = np.round(np.cumsum(rng.normal(0.0, 0.05, n))) % 4 + 1
    # The strip draws the sensing patch's truth (the coverage's pressure; the pad's mean in rows made before it).
    return {"time_s": t, "phase": np.floor(t / (t[-1] / 8)) % 8, "left_coverage_pressure_pa": p, "left_estimate_pa": est, "left_mode": mode}


def test_m4_keeps_each_buckets_extremes_ends_and_gaps():
    from piezotip.analysis.video import m4_decimate

    rng = np.random.default_rng(3)
    t = np.sort(rng.uniform(0.0, 10.0, 5000))
    y = rng.normal(size=t.size)
    y[rng.integers(0, t.size, 200)] = np.nan
    y[1000:1300] = np.nan  # a gap over whole buckets
    bucket = np.floor(t / 0.05).astype(np.int64)
    kept_t, kept_y = m4_decimate(t, y, bucket)
    assert np.all(np.diff(kept_t) > 0)
    kept_bucket = np.floor(kept_t / 0.05).astype(np.int64)

    def same(a, b):
        return a == b or (np.isnan(a) and np.isnan(b))

    for b in np.unique(bucket):
        raw, kept = y[bucket == b], kept_y[kept_bucket == b]
        assert 1 <= kept.size <= 5
        assert same(kept[0], raw[0]) and same(kept[-1], raw[-1])
        if np.isfinite(raw).any():
            assert np.nanmin(kept) == np.nanmin(raw) and np.nanmax(kept) == np.nanmax(raw)
        assert np.isnan(kept).any() == np.isnan(raw).any()  # a gap stays a gap


def test_live_strip_draws_a_long_run_as_all_its_points_do_with_bounded_points():
    """Fed a frame's rows at a time, the strip keeps a bounded number of points per line (its
    cost per frame does not grow with the run) and draws what all the points draw: the spike, the
    gaps, the mode's switches."""
    width, height = 480, 540

    def strip():
        return LiveStrip(width, height, ("left",), (1, 2, 3, 4), duration_s=60.0, pressure_range_pa=(0.1, 1e6))

    def fed(data, rng):
        s = strip()
        n, i = data["time_s"].size, 0
        while i < n:
            k = int(rng.integers(1, 40))
            s.extend({c: v[i : i + k] for c, v in data.items()})
            i += k
        return s

    data = _long_strip_data(12000)
    full = strip()
    for column, line in full.lines:  # every point, as a plot of the whole record draws them
        y = data[column]
        line.set_data(data["time_s"], np.where(y > 0, y, np.nan) if column.endswith("_pa") else y)
    full._last = {c: float(v[-1]) for c, v in data.items()}
    rng = np.random.default_rng(0)
    live = fed(data, rng)
    differ = np.abs(full.render().astype(int) - live.render().astype(int)).max(axis=2) > 64
    assert differ.mean() < 0.015  # antialiasing at the lines' edges, nothing more
    t_drawn, p_drawn = (np.asarray(a) for a in live.lines[0][1].get_data())
    assert np.nanmax(p_drawn) == 1e5  # the one-reading spike
    in_gap = (t_drawn > data["time_s"][7230]) & (t_drawn < data["time_s"][7530])
    assert in_gap.any() and np.isnan(p_drawn[in_gap]).all()  # no contact: a gap, not a line
    pixels = full.fig.axes[0].get_window_extent().width
    points = [len(line.get_xdata()) for _, line in live.lines]
    assert max(points) <= 4 * pixels + 100  # M4's four per pixel column, plus the open one
    # Four times as long a run on a four times longer axis: about as many points.
    longer = _long_strip_data(48000, seed=2)
    s = LiveStrip(width, height, ("left",), (1, 2, 3, 4), duration_s=240.0, pressure_range_pa=(0.1, 1e6))
    for i in range(0, 48000, 7):
        s.extend({c: v[i : i + 7] for c, v in longer.items()})
    assert max(len(line.get_xdata()) for _, line in s.lines) <= 4 * pixels + 300


def test_an_out_folder_that_reads_as_an_option_is_a_folder_to_ffmpeg(tmp_path):
    """``--video --out=-x`` used to hand ffmpeg "-x/run.mp4", which it reads as an option: the
    writer hands it the absolute path, and the video lands in the folder named "-x"."""
    args = ["run", "grasp", "--preset", "fast", "--set", "duration_s=0.3", "--no-plot", "--json", "--video", "--video-size", "320x240"]
    base = {k: v for k, v in os.environ.items() if k != "MUJOCO_GL"}
    result = subprocess.run(
        [sys.executable, str(ROOT / "run_sim.py"), *args, "--out=-x"], cwd=tmp_path, capture_output=True, text=True, timeout=300, env=base
    )
    if result.returncode == 2 and "MUJOCO_GL" in result.stderr:
        pytest.skip(f"no OpenGL for MuJoCo here: {result.stderr.strip()}")
    assert result.returncode in (0, 1), result.stderr
    mp4 = tmp_path / "-x" / "run.mp4"
    assert mp4.stat().st_size > 0
    meta = next(imageio_ffmpeg.read_frames(str(mp4)))
    assert meta["size"] == (320, 240)
