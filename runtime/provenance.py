"""What made a result: the versions of piezotip and of the libraries whose numbers it depends on,
the git commit when it runs from a checkout, the seeds and the fully resolved config (defaults
and preset included).  Every output carries them (:func:`config_provenance`): summary.json and
``run --json``, sweep.json, the sweep's Parquet file (its schema metadata, key ``piezotip``) and
CSV (its ``# `` header lines, :func:`csv_header`), the experiment's JSON and CSV; so a result can
be traced to the code and the settings that made it, and made again."""

from __future__ import annotations

import dataclasses
import functools
import json
import math
import platform
import subprocess
from importlib import metadata
from pathlib import Path

import numpy as np

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


def resolved_config(config) -> dict:
    """``config`` (a :class:`~piezotip.scenarios.ScenarioConfig` as ``scenarios.get`` returns it:
    the scenario's defaults, the preset and the overrides applied) as plain data, every field of
    every section by the name ``--set`` takes (``["object"]["mass_kg"]`` is ``object.mass_kg``).
    A value JSON cannot hold (a registered controller's own type) is kept as its text: a record
    must not stop the run it records."""
    return json.loads(json.dumps(dataclasses.asdict(config), default=str))


def config_provenance(config) -> dict:
    """What made a result beside its inputs' names: ``versions`` (:func:`versions`), ``seed``
    (``sensor.seed``: the readout noise, and every other draw of the run), ``unit_seed``
    (``sensor.unit_seed``: which physical unit, when ``sensor.variation`` is not ``none``) and
    ``config`` (:func:`resolved_config`)."""
    return {"versions": versions(), "seed": config.sensor.seed, "unit_seed": config.sensor.unit_seed, "config": resolved_config(config)}


#: The name of the provenance in a Parquet file's schema metadata, and its CSV header line's tag.
METADATA_KEY = "piezotip"


def csv_header(provenance: dict, what: str) -> str:
    """The comment lines a CSV table starts with (each begins ``# ``; pandas reads the table with
    ``comment="#"``): a line for people (``what`` the table is, the versions, the commit, the
    seeds), then ``# piezotip: `` and ``provenance`` as one line of strict JSON, what the
    Parquet file's metadata holds."""

    v = provenance.get("versions") or {}
    made = ", ".join(f"{name} {v[name]}" for name in (*DISTRIBUTIONS, "python") if v.get(name))
    commit = v.get("git_commit") or "unknown"
    grid = provenance.get("grid") or {}  # a sweep's: a seed it varies is its row's

    def seed(name: str, key: str) -> str:
        return f"{name} per row" if f"sensor.{key}" in grid else f"{name} {provenance[key]}"

    seeds = f"{seed('seed', 'seed')}, {seed('unit seed', 'unit_seed')}" if "seed" in provenance else "seeds unknown"
    people = f"# {what}: {made}; git commit {commit}; {seeds}"
    # one line for people whatever ``what`` holds; the JSON (no indent) is one line too
    return f"{' '.join(people.split())}\n# {METADATA_KEY}: {json.dumps(json_safe(provenance), allow_nan=False)}\n"


def read_csv_header(lines) -> dict | None:
    """The provenance of a CSV table :func:`csv_header` began (``lines``: the file's lines, or
    an open file), or None for a table without one."""
    for line in lines:
        if not line.startswith("#"):
            return None
        if line.startswith(f"# {METADATA_KEY}: "):
            return json.loads(line[len(f"# {METADATA_KEY}: ") :])
    return None


__all__ = [
    "DISTRIBUTIONS",
    "METADATA_KEY",
    "config_provenance",
    "csv_header",
    "git_commit",
    "read_csv_header",
    "resolved_config",
    "versions",
]


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
