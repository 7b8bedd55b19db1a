"""What made a result: the versions of piezotip and of the libraries whose numbers it depends on,
and the git commit when it runs from a checkout (recorded in summary.json, ``run --json``,
sweep.json and the experiment's JSON, so a result can be traced to the code that made it)."""

from __future__ import annotations

import functools
import platform
import subprocess
from importlib import metadata
from pathlib import Path

#: The distributions whose versions a result records (piezotip itself first).
DISTRIBUTIONS = ("piezotip", "mujoco", "numpy", "scipy")


def _version(name: str) -> str | None:
    try:
        return metadata.version(name)
    except metadata.PackageNotFoundError:
        return None


@functools.cache
def git_commit(path: str | None = None) -> str | None:
    """The commit of the git checkout holding ``path`` (default: this package's folder), with
    "-dirty" when its tracked files differ from it; None outside a checkout or without git."""
    where = Path(path) if path is not None else Path(__file__).resolve().parent
    try:
        commit = subprocess.run(
            ["git", "-C", str(where), "rev-parse", "HEAD"], capture_output=True, text=True, timeout=5, check=True
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "-C", str(where), "status", "--porcelain", "--untracked-files=no"],
            capture_output=True,
            text=True,
            timeout=5,
            check=True,
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None
    return f"{commit}-dirty" if dirty else commit or None


@functools.cache
def versions() -> dict[str, str | None]:
    """{"piezotip": ..., "mujoco": ..., "numpy": ..., "scipy": ..., "python": ..., "git_commit": ...}:
    each distribution's installed version (None where it is not installed), Python's, and the
    checkout's commit (None outside one)."""
    out: dict[str, str | None] = {name: _version(name) for name in DISTRIBUTIONS}
    out["python"] = platform.python_version()
    out["git_commit"] = git_commit()
    return out


__all__ = ["DISTRIBUTIONS", "git_commit", "versions"]
