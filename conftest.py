"""Hooks for every test path of the repository (tests/ and benchmarks/tests/ alike): pytest
loads this file for any path under the repository, where tests/conftest.py serves tests/ only
(`pytest benchmarks/tests` alone took xdist's own count of workers, the host's cores)."""

from __future__ import annotations

import math
import os
from pathlib import Path

#: The most workers `-n auto` starts: the suite is about 1000 CPU-seconds and its longest test
#: about 100 s (tests/test_bench.py's presets' table), so past ten workers that one test sets the
#: suite's time and more workers only cost memory (each imports MuJoCo, scipy and matplotlib).
MAX_AUTO_WORKERS = 10


def cgroup_cpus(cpu_max: Path = Path("/sys/fs/cgroup/cpu.max")) -> float:
    """The CPUs a cgroup v2 quota grants this process ("quota period" in ``cpu.max``), inf
    where none is set or the file is not there."""
    try:
        quota, period = cpu_max.read_text().split()[:2]
    except (OSError, ValueError):
        return math.inf
    return math.inf if quota == "max" else int(quota) / int(period)


def pytest_xdist_auto_num_workers(config):
    """`-n auto`'s workers (pytest-xdist's hook): ``PYTEST_XDIST_AUTO_NUM_WORKERS`` if set, else
    the CPUs this process may run on, within a container's quota (psutil's count, xdist's own
    choice, is the host's cores), at most MAX_AUTO_WORKERS."""
    if os.environ.get("PYTEST_XDIST_AUTO_NUM_WORKERS"):
        return None  # xdist's own hook reads it
    allowed = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1  # not on macOS
    cpus = min(allowed, cgroup_cpus())
    return max(1, min(MAX_AUTO_WORKERS, math.floor(cpus)))
