"""Headless matplotlib: one place that selects the Agg backend and saves figures."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # headless: no display on CI or lab servers

import matplotlib.pyplot as plt


def new_figure(rows: int = 1, cols: int = 1, figsize: tuple[float, float] = (8, 5), sharex: bool = False):
    """A figure and a 2-D list of axes (always indexable as axes[row][col])."""
    fig, axes = plt.subplots(rows, cols, figsize=figsize, squeeze=False, sharex=sharex)
    return fig, axes


def save_figure(fig, path: Path, dpi: int = 120) -> Path:
    """Save ``fig`` as PNG at ``path`` and release it."""
    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return Path(path)
