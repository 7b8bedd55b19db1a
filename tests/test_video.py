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
