"""Headless matplotlib: one place that selects the Agg backend and saves figures.

matplotlib is imported on the first figure, not with this module: a run without plots
(``--no-plot``, a sweep's workers) never pays its 0.3 s import.
"""

from __future__ import annotations

from pathlib import Path


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")  # headless: no display on CI or lab servers
    import matplotlib.pyplot as plt

    return plt


def new_figure(rows: int = 1, cols: int = 1, figsize: tuple[float, float] = (8, 5), sharex: bool = False):
    """A figure and a 2-D list of axes (always indexable as axes[row][col])."""
    fig, axes = _pyplot().subplots(rows, cols, figsize=figsize, squeeze=False, sharex=sharex)
    return fig, axes


def save_figure(fig, path: Path, dpi: int = 120) -> Path:
    """Save ``fig`` as PNG at ``path`` and release it."""
    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    _pyplot().close(fig)
    return Path(path)
