"""Offscreen frames of a run (MuJoCo's Renderer, ``MUJOCO_GL=egl`` for headless machines)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .plotting import new_figure, save_figure

os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco  # after MUJOCO_GL is chosen


class FrameStrip:
    """Collects ``frames`` evenly spaced frames of a run and saves them side by side as PNG.

    Use as ``on_step`` of :meth:`cosim.loop.CoSimulation.run`.  The camera looks at the
    grasp from the side; every geom group is shown (pads and objects are collision geoms).
    """

    def __init__(self, model: mujoco.MjModel, total_steps: int, frames: int = 6, width: int = 320, height: int = 240) -> None:
        self.renderer = mujoco.Renderer(model, height, width)
        self.every = max(1, total_steps // max(frames - 1, 1))
        self.option = mujoco.MjvOption()
        self.option.geomgroup[:] = 1
        self.camera = mujoco.MjvCamera()
        self.camera.lookat[:] = (0.0, 0.0, 0.06)
        self.camera.distance, self.camera.elevation, self.camera.azimuth = 0.32, -12.0, 90.0
        self.images: list[np.ndarray] = []
        self.times: list[float] = []

    def __call__(self, sim) -> None:
        if (sim.steps - 1) % self.every == 0:
            self.renderer.update_scene(sim.data, camera=self.camera, scene_option=self.option)
            self.images.append(self.renderer.render().copy())
            self.times.append(sim.time_s)

    def save(self, path: Path) -> Path:
        fig, axes = new_figure(1, len(self.images), figsize=(3.2 * len(self.images), 2.8))
        for ax, img, t in zip(axes[0], self.images, self.times, strict=True):
            ax.imshow(img)
            ax.set_title(f"t = {t:.2f} s", fontsize=9)
            ax.axis("off")
        out = save_figure(fig, Path(path))
        self.renderer.close()
        return out
