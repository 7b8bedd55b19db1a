"""Video of a run: the gripper and object from the scene's camera, with a live strip beside it.

``run_sim.py run SCENARIO --video`` writes ``run.mp4`` (H.264, yuv420p, through imageio-ffmpeg's
ffmpeg): each frame is the scene's ``grasp_camera`` (models/scene_grasp.xml) beside a strip of
the run so far: each instrumented pad's true and estimated pressure on a log scale, the mode
each pad drives, the controller's phase, and the time.  :class:`VideoWriter` is an ``on_step``
of :meth:`piezotip.cosim.loop.CoSimulation.run`, as :class:`~piezotip.analysis.render.FrameStrip`
is; nothing here is imported or created unless a video is asked for.

Frames are taken in simulated time: frame ``n`` shows the first control step at or after
``n / fps`` seconds (the control period, 5 ms, is the jitter), so a run of T simulated seconds
gives ``floor(T fps) + 1`` frames and plays in real time.  The strip's axes are drawn once; a
frame redraws only its lines onto the saved background (matplotlib's blitting), reads only the
rows recorded since the last frame, and draws of each line what its pixel columns show
(:func:`m4_decimate`), so a frame's cost does not grow with the run; and the
renderer skips shadows and reflections (a third of the cost in software OpenGL, invisible in a
side view).  Headless machines render through EGL (``MUJOCO_GL=egl``, which the command line
sets for a command that renders unless told otherwise, and the Gymnasium environments where no
display and no ``MUJOCO_GL`` is set: :func:`choose_headless_backend`); without a usable OpenGL
the writer stops before the run with one line naming ``MUJOCO_GL``, and a renderer that failed
once in a process is never tried again (:func:`open_renderer`).
"""

from __future__ import annotations

import ctypes.util
import math
import numbers
import os
import sys
from fractions import Fraction
from pathlib import Path

import numpy as np

#: Frames per second of simulated time.
DEFAULT_FPS = 30.0
#: Frame size (width, height), pixels: the camera on the left half, the strip on the right.
DEFAULT_SIZE = (960, 540)
#: The scene's camera for the video (models/scene_grasp.xml).
CAMERA = "grasp_camera"
#: Smallest and largest frame sides, pixels: below 160 the strip's text cannot be read; 4096 is
#: H.264's level-5.1 limit and far beyond what MuJoCo's offscreen buffer needs.
MIN_SIDE_PX, MAX_SIDE_PX = 160, 4096


class RendererUnavailable(OSError):
    """MuJoCo's offscreen renderer cannot be created (no EGL, no display): one line naming MUJOCO_GL."""


#: The first failure to create MuJoCo's renderer in this process, raised again instead of a second
#: try: MuJoCo's OpenGL set-up (``mjr_makeContext``) fails by unwinding out of a C++ function-local
#: static's initialisation, and the next call re-enters it and aborts the interpreter
#: ("__cxa_guard_acquire detected recursive initialization").
_renderer_failure: RendererUnavailable | None = None


def check_render_side(name: str, side) -> int:
    """``side`` (``width`` or ``height`` as ``name``) as an int if it is a whole number of pixels in
    1..MAX_SIDE_PX, else a ValueError naming it: MuJoCo's renderer hands it to OpenGL unchecked (a
    negative one fails GLFW's assertion, which aborts the interpreter) and enlarges the model's
    offscreen buffer to it (MAX_SIDE_PX: within every OpenGL's renderbuffer limit)."""
    whole = isinstance(side, numbers.Integral) and not isinstance(side, bool)
    if not whole or not 1 <= int(side) <= MAX_SIDE_PX:
        raise ValueError(f"{name} must be a whole number of pixels in 1..{MAX_SIDE_PX}, got {side!r}")
    return int(side)


def _has_display(environ) -> bool:
    return bool(environ.get("DISPLAY") or environ.get("WAYLAND_DISPLAY"))


def headless_backend(environ=os.environ, imported: bool | None = None, find=ctypes.util.find_library) -> str | None:
    """The ``MUJOCO_GL`` to set before MuJoCo's first import so that rendering works without a
    display, or None to leave it as it is.

    None unless all of: Linux (elsewhere MuJoCo's default needs no display), no ``MUJOCO_GL``
    named (a user's choice stays theirs), no display (``DISPLAY``, ``WAYLAND_DISPLAY``: GLFW,
    MuJoCo's default, works there) and MuJoCo not imported yet (it reads ``MUJOCO_GL`` once, on
    its first import).  Then ``egl`` where libEGL and an OpenGL library for PyOpenGL's EGL platform
    are installed, else ``osmesa`` where libOSMesa is, else None (rendering then fails with one
    line naming ``MUJOCO_GL``).  A ``PYOPENGL_PLATFORM`` of ``egl`` or ``osmesa`` picks that one
    (MuJoCo refuses the other with it); any other leaves the choice to the user.

    Parameters
    ----------
    environ : the environment to read.
    imported : whether MuJoCo is imported (None: look in ``sys.modules``).
    find : ``ctypes.util.find_library`` (a library's name without ``lib``) -> path or None.
    """
    if imported is None:
        imported = "mujoco" in sys.modules
    if not sys.platform.startswith("linux") or environ.get("MUJOCO_GL") or _has_display(environ) or imported:
        return None
    platform = (environ.get("PYOPENGL_PLATFORM") or "").strip().lower()
    if platform and platform not in ("egl", "osmesa"):
        return None
    installed = {
        # PyOpenGL's EGL platform loads libEGL and then libOpenGL, libGL or libGLESv2.
        "egl": lambda: find("EGL") and any(find(name) for name in ("OpenGL", "GL", "GLESv2")),
        "osmesa": lambda: find("OSMesa"),
    }
    for backend in (platform,) if platform else ("egl", "osmesa"):
        if installed[backend]():
            return backend
    return None


def choose_headless_backend() -> str | None:
    """Set ``MUJOCO_GL`` to :func:`headless_backend`'s choice, if any, and return it.  Call it
    before MuJoCo's first import (the Gymnasium environments do): without it a machine with no
    display gets GLFW, whose renderer cannot be made there."""
    backend = headless_backend()
    if backend is not None:
        os.environ["MUJOCO_GL"] = backend
    return backend


def parse_size(text: str) -> tuple[int, int]:
    """``"WxH"`` as (width, height) in pixels; both even (yuv420p halves them) and in range."""
    parts = str(text).lower().replace(" ", "").split("x")
    try:
        width, height = (int(p) for p in parts)
    except ValueError:
        raise ValueError(f"--video-size must be WIDTHxHEIGHT in pixels, e.g. 960x540; got {text!r}") from None
    return check_size((width, height))


def check_size(size: tuple[int, int]) -> tuple[int, int]:
    """``size`` (width, height) if both sides are even and within MIN_SIDE_PX..MAX_SIDE_PX, else a ValueError."""
    width, height = (int(s) for s in size)
    for name, side in (("width", width), ("height", height)):
        if not MIN_SIDE_PX <= side <= MAX_SIDE_PX:
            raise ValueError(f"--video-size {name} must be {MIN_SIDE_PX}-{MAX_SIDE_PX} pixels, got {side}")
        if side % 2:
            raise ValueError(f"--video-size {name} must be even (H.264 in yuv420p halves it), got {side}")
    return width, height


def check_fps(fps: float, control_period_s: float) -> float:
    """``fps`` if it is positive and at most the control rate (a frame per control step), else a ValueError."""
    rate = 1.0 / control_period_s
    if isinstance(fps, bool) or not isinstance(fps, (int, float)) or not math.isfinite(fps) or not 0 < fps <= rate * (1 + 1e-9):
        raise ValueError(f"--video-fps must be a number in (0, {rate:g}] (the control rate, one frame per control step), got {fps!r}")
    return float(fps)


def expected_frames(sim_time_s: float, fps: float) -> int:
    """Frames a run of ``sim_time_s`` simulated seconds gives (see the module docstring)."""
    return math.floor(sim_time_s * fps + 1e-9) + 1


def _unavailable(what: str, err: Exception) -> RendererUnavailable:
    gl = os.environ.get("MUJOCO_GL", "")
    text = str(err).strip()
    why = text.splitlines()[0][:200] if text else type(err).__name__
    return RendererUnavailable(
        f"{what} with MUJOCO_GL={gl!r} ({why}); "
        "set MUJOCO_GL=egl (headless, needs libEGL), osmesa (software, needs libOSMesa) or glfw (needs a display)"
    )


def import_mujoco():
    """``import mujoco``, or RendererUnavailable naming MUJOCO_GL: MuJoCo loads the OpenGL backend
    MUJOCO_GL names when it is first imported, and with ``egl`` but no libEGL (or ``osmesa`` but
    no libOSMesa) that import itself fails."""
    try:
        import mujoco
    except Exception as err:  # AttributeError or ImportError from PyOpenGL's platform loading
        raise _unavailable("cannot load MuJoCo's OpenGL backend", err) from None
    return mujoco


def open_renderer(model, width: int, height: int):
    """A ``mujoco.Renderer`` of ``width`` x ``height`` pixels for ``model``, or RendererUnavailable.

    The model's offscreen buffer is enlarged to the frame if needed (a visual setting only).  A
    size that is not a whole number of pixels in 1..MAX_SIDE_PX is a ValueError; GLFW (MuJoCo's
    default backend) without a display, and any renderer after one failed in this process, are
    RendererUnavailable without calling MuJoCo (each would abort the interpreter).
    """
    import warnings

    global _renderer_failure
    width, height = check_render_side("width", width), check_render_side("height", height)
    if _renderer_failure is not None:
        raise _renderer_failure
    mujoco = import_mujoco()
    # The context class MuJoCo's Renderer makes, which MUJOCO_GL chose on MuJoCo's import (``import *``'d to the top).
    context = getattr(mujoco, "GLContext", None) or getattr(getattr(mujoco, "gl_context", None), "GLContext", None)
    glfw = getattr(context, "__module__", "").startswith("mujoco.glfw")
    if glfw and sys.platform.startswith("linux") and not _has_display(os.environ):
        # MuJoCo reads MUJOCO_GL on its first import: set after it, it changes nothing.
        why = OSError("DISPLAY and WAYLAND_DISPLAY are unset; MUJOCO_GL counts only before MuJoCo's first import")
        _renderer_failure = _unavailable("cannot render: MuJoCo's OpenGL backend is GLFW, which needs a display,", why)
        raise _renderer_failure
    vis = model.vis.global_
    vis.offwidth, vis.offheight = max(vis.offwidth, width), max(vis.offheight, height)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # GLFW's own warnings ("failed to open display"): the error says it once
            return mujoco.Renderer(model, height, width)
    except Exception as err:  # FatalError (no display), ImportError (no EGL/OSMesa), AttributeError (a half-loaded GL)
        _renderer_failure = _unavailable("cannot render: MuJoCo's offscreen renderer failed", err)
        raise _renderer_failure from None


class LiveStrip:
    """The strip: pressures (true and estimated, log scale), driven modes and phase against time.

    Parameters
    ----------
    width, height : pixels.
    sides : the instrumented pads' sides ("left", "right"), as the record's column prefixes.
    modes : the modes the sensor can drive (the mode axis's ticks).
    duration_s : the time axis's end, s (the scenario's duration).
    pressure_range_pa : (low, high) of the pressure axis, Pa.
    """

    def __init__(
        self,
        width: int,
        height: int,
        sides: tuple[str, ...],
        modes: tuple[int, ...],
        duration_s: float,
        pressure_range_pa: tuple[float, float],
    ) -> None:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        from piezotip.cosim.control import PHASES

        self.width, self.height, self.sides = width, height, sides
        dpi = 100.0
        fig = Figure(figsize=(width / dpi, height / dpi), dpi=dpi)
        self.canvas = FigureCanvasAgg(fig)
        self.fig = fig
        font = max(6.0, height / 60.0)
        ax_p, ax_m, ax_ph = fig.subplots(3, 1, sharex=True, gridspec_kw={"height_ratios": [3.0, 1.0, 1.6]})
        fig.subplots_adjust(left=0.2, right=0.97, top=0.9, bottom=0.09, hspace=0.12)
        colours = {"left": "tab:blue", "right": "tab:orange"}
        self.lines: list[tuple[str, object]] = []
        for side in sides:
            c = colours.get(side, "tab:green")
            (true,) = ax_p.plot([], [], "-", color=c, lw=1.4, label=f"{side} true (sensing patch)")
            (est,) = ax_p.plot([], [], ":", color=c, lw=1.4, label=f"{side} estimate")
            (mode,) = ax_m.plot([], [], "-", color=c, lw=1.4, drawstyle="steps-post")
            # The truth the estimate answers to: what the sensing patch feels (run_report.sensed_pressure_pa).
            self.lines += [(f"{side}_coverage_pressure_pa", true), (f"{side}_estimate_pa", est), (f"{side}_mode", mode)]
        (phase,) = ax_ph.plot([], [], "-", color="black", lw=1.4, drawstyle="steps-post")
        self.lines.append(("phase", phase))
        ax_p.set_yscale("log")
        ax_p.set_ylim(*pressure_range_pa)
        ax_p.set_xlim(0.0, duration_s)
        ax_p.set_ylabel("pressure [Pa]", fontsize=font)
        ax_p.legend(fontsize=0.8 * font, loc="upper left", ncol=2, framealpha=0.8)
        ax_m.set_ylim(min(modes) - 0.5, max(modes) + 0.5)
        ax_m.set_yticks(list(modes))
        ax_m.set_ylabel("mode", fontsize=font)
        ax_ph.set_ylim(len(PHASES) - 0.5, -0.5)
        ax_ph.set_yticks(range(len(PHASES)), PHASES)
        ax_ph.set_xlabel("time [s]", fontsize=font)
        for ax in (ax_p, ax_m, ax_ph):
            ax.tick_params(labelsize=0.8 * font)
            ax.grid(True, which="major", alpha=0.3)
        self.phases = PHASES
        self.title = fig.text(0.5, 0.955, "", ha="center", va="center", fontsize=1.1 * font)
        self.artists = [line for _, line in self.lines] + [self.title]
        for artist in self.artists:
            artist.set_animated(True)  # left out of the background, drawn per frame
        self.canvas.draw()
        self.background = self.canvas.copy_from_bbox(fig.bbox)
        self._reset()

    def draw(self, data: dict[str, np.ndarray]) -> np.ndarray:
        """The strip for the recorded ``data`` (the whole run so far), as an (height, width, 3) uint8 image."""
        self._reset()
        self.extend(data)
        return self.render()

    def extend(self, rows: dict[str, np.ndarray]) -> None:
        """Add the rows recorded since the last call (column name -> array) to the lines.

        Each line keeps the rows of the pixel columns already passed as their M4 summary
        (:func:`m4_decimate`), so a frame draws a bounded number of points however long the
        run: the cost per frame does not grow with the run's length.
        """
        t = np.asarray(rows["time_s"], dtype=float)
        if not t.size:
            return
        self._last = {column: float(values[-1]) for column, values in rows.items()}
        ax = self.fig.axes[0]
        if t[-1] > ax.get_xlim()[1]:
            # The recording's tail after the controller finishes can outlast the scenario's
            # duration (cosim.loop.REST_MAX_S): a longer axis, drawn again once (its pixel
            # columns narrower than the traces' buckets, which stay as they were).
            ax.set_xlim(0.0, 1.25 * float(t[-1]))
            self.canvas.draw()
            self.background = self.canvas.copy_from_bbox(self.fig.bbox)
        for (column, line), trace in zip(self.lines, self._traces, strict=True):
            if column not in rows and column.endswith("_coverage_pressure_pa"):  # rows made before that column: the pad's mean
                column = column.replace("_coverage_pressure_pa", "_true_pressure_pa")
            y = np.asarray(rows[column], dtype=float)
            if column.endswith("_pa"):
                y = np.where(y > 0.0, y, np.nan)  # nothing to draw on a log axis (and NaN: no estimate)
            trace.extend(t, y)
            line.set_data(*trace.xy())

    def render(self) -> np.ndarray:
        """The strip as it stands, as an (height, width, 3) uint8 image."""
        last = self._last
        t = last.get("time_s", 0.0)
        phase = int(last["phase"]) if last else 0
        label = self.phases[phase] if 0 <= phase < len(self.phases) else str(phase)
        modes = "  ".join(f"{side} mode {int(last[f'{side}_mode'])}" for side in self.sides) if last else ""
        self.title.set_text(f"t = {t:6.2f} s   {label}   {modes}")
        self.canvas.restore_region(self.background)
        for artist in self.artists:
            self.fig.draw_artist(artist)
        image = np.asarray(self.canvas.buffer_rgba())[:, :, :3]
        return _fit(image, self.height, self.width)

    def _reset(self) -> None:
        """Empty lines, bucketed by the time axis's pixel columns as it is drawn now."""
        ax = self.fig.axes[0]
        bucket_s = ax.get_xlim()[1] / max(ax.get_window_extent().width, 1.0)
        self._traces = [_Trace(bucket_s) for _ in self.lines]
        self._last: dict[str, float] = {}
        for _, line in self.lines:
            line.set_data([], [])


def m4_decimate(t: np.ndarray, y: np.ndarray, bucket: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The points of a line that its drawing at one pixel column per bucket needs: in each
    bucket the first, last, lowest and highest points, and its first NaN (a gap), in time order.

    The M4 aggregation (Jugel et al. 2014, "M4: a visualization-oriented time series data
    aggregation", PVLDB 7(10)): a line through these points is drawn with the same pixels as
    one through them all, its extent in every column, where it enters and leaves.  ``t``
    increasing, ``bucket`` the non-decreasing integer bucket of each point; NaNs in ``y`` stay
    gaps (a bucket of NaNs alone keeps one).  Returns (t, y) of the kept points.
    """
    n = t.size
    if n == 0:
        return t, y
    starts = np.flatnonzero(np.r_[True, bucket[1:] != bucket[:-1]])
    ends = np.r_[starts[1:], n] - 1
    finite = np.isfinite(y)
    low = np.lexsort((np.where(finite, y, np.inf), bucket))[starts]  # each bucket's lowest first
    high = np.lexsort((np.where(finite, -y, np.inf), bucket))[starts]
    gaps = np.flatnonzero(~finite)
    first_gap = gaps[np.r_[True, bucket[gaps][1:] != bucket[gaps][:-1]]] if gaps.size else gaps
    keep = np.unique(np.concatenate([starts, ends, low, high, first_gap]))
    return t[keep], y[keep]


class _Trace:
    """One line of the strip as it grows: the closed buckets (``bucket_s`` wide, s) kept as their
    M4 points, the open one (the latest) as its raw points."""

    def __init__(self, bucket_s: float) -> None:
        self.bucket_s = bucket_s
        self._done_t = self._done_y = self._open_t = self._open_y = np.empty(0)

    def extend(self, t: np.ndarray, y: np.ndarray) -> None:
        t, y = np.concatenate([self._open_t, t]), np.concatenate([self._open_y, y])
        bucket = np.floor(t / self.bucket_s).astype(np.int64)
        cut = int(np.searchsorted(bucket, bucket[-1]))  # the open bucket starts here
        if cut:
            kept_t, kept_y = m4_decimate(t[:cut], y[:cut], bucket[:cut])
            self._done_t, self._done_y = np.concatenate([self._done_t, kept_t]), np.concatenate([self._done_y, kept_y])
        self._open_t, self._open_y = t[cut:], y[cut:]

    def xy(self) -> tuple[np.ndarray, np.ndarray]:
        return np.concatenate([self._done_t, self._open_t]), np.concatenate([self._done_y, self._open_y])


def _fit(image: np.ndarray, height: int, width: int) -> np.ndarray:
    """``image`` cropped or padded (white) to exactly height x width (a figure's pixel size can
    round one pixel off its inches times dpi)."""
    if image.shape[0] == height and image.shape[1] == width:
        return image
    out = np.full((height, width, 3), 255, np.uint8)
    h, w = min(height, image.shape[0]), min(width, image.shape[1])
    out[:h, :w] = image[:h, :w]
    return out


class VideoWriter:
    """Writes a run's MP4 as it runs: use as ``on_step`` of ``CoSimulation.run``, then :meth:`close`.

    Parameters
    ----------
    sim : the CoSimulation (its model, pads, channels and control period).
    path : the MP4 to write.
    rows : a callable ``rows(start)`` returning the rows recorded from row ``start`` on (column
        name -> array), e.g. a Recorder's ``rows_from``; it is called once per frame, for the
        rows since the last frame (so a frame costs the same early or late in a long run).
    duration_s : the time axis's end, s (the scenario's duration).
    fps : frames per simulated second (at most the control rate).
    size : (width, height) of a frame, pixels, even; the camera takes the left half of a
        landscape frame and the top half of a portrait one, the strip the rest.
    progress : show a progress bar of the frames written.

    The renderer and the encoder start here, so a missing OpenGL stops before the run.
    """

    def __init__(self, sim, path: str | Path, rows, duration_s: float, fps: float = DEFAULT_FPS, size=DEFAULT_SIZE, progress: bool = True):
        import imageio_ffmpeg
        import mujoco
        from tqdm import tqdm

        self.fps = check_fps(fps, sim.dt)
        self.width, self.height = check_size(size)
        self.path = Path(path)
        self._rows = rows
        self._read = 0  # rows handed to the strip so far
        beside = self.width >= self.height
        # The camera's share, even so that the strip's is too.
        if beside:
            cam_w, cam_h = 2 * round(self.width / 4), self.height
        else:
            cam_w, cam_h = self.width, 2 * round(self.height / 4)
        self._cam_slice = (slice(0, cam_h), slice(0, cam_w))
        self._strip_slice = (slice(0, cam_h), slice(cam_w, self.width)) if beside else (slice(cam_h, self.height), slice(0, cam_w))
        strip_w, strip_h = (self.width - cam_w, cam_h) if beside else (cam_w, self.height - cam_h)
        self.renderer = open_renderer(sim.model, cam_w, cam_h)
        flags = self.renderer.scene.flags
        flags[mujoco.mjtRndFlag.mjRND_SHADOW] = False
        flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = False
        self.option = mujoco.MjvOption()
        self.option.geomgroup[:] = 1  # pads and objects are collision geoms (group 3)
        sides = tuple(pad.removesuffix("_pad") for pad in sim.pads)
        modes = tuple(sim.config.sensor.modes)
        channel = sim.channels[sim.pads[0]]
        p_low = min(channel.inverse(m).p_min_pa for m in modes)
        p_high = max(channel.inverse(m).p_max_pa for m in modes)
        # Whole decades around the fingertip's range, one more below its detection limit for the
        # estimates' scatter there.
        pressure_range = (10.0 ** (math.floor(math.log10(p_low)) - 1), 10.0 ** math.ceil(math.log10(p_high)))
        self.strip = LiveStrip(strip_w, strip_h, sides, modes, duration_s, pressure_range)
        self._frame = np.full((self.height, self.width, 3), 255, np.uint8)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._writer = imageio_ffmpeg.write_frames(
            # Absolute: a relative path such as "-x/run.mp4" would reach ffmpeg as an option.
            str(self.path.resolve()),
            (self.width, self.height),
            fps=Fraction(self.fps).limit_denominator(1000),
            codec="libx264",
            pix_fmt_in="rgb24",
            pix_fmt_out="yuv420p",
            quality=None,
            macro_block_size=2,
            ffmpeg_log_level="error",
            output_params=["-crf", "23", "-preset", "veryfast"],
        )
        self._writer.send(None)  # starts ffmpeg
        self.frames = 0
        self._next_s = 0.0
        self._bar = tqdm(total=expected_frames(duration_s, self.fps), desc=self.path.name, unit="frame", disable=not progress, leave=False)
        self._closed = False

    def __call__(self, sim) -> None:
        if sim.time_s + 1e-9 < self._next_s:
            return
        self.renderer.update_scene(sim.data, camera=CAMERA, scene_option=self.option)
        self._frame[self._cam_slice] = self.renderer.render()
        new = self._rows(self._read)
        self._read += len(new.get("time_s", ()))
        self.strip.extend(new)
        self._frame[self._strip_slice] = self.strip.render()
        self._writer.send(self._frame.tobytes())
        self.frames += 1
        self._next_s = self.frames / self.fps
        self._bar.update(1)

    def close(self) -> Path:
        """Finish the MP4 (ffmpeg writes its index) and free the renderer; safe to call twice."""
        if not self._closed:
            self._closed = True
            self._bar.close()
            self.renderer.close()
            self._writer.close()
        return self.path
