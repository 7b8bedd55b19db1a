"""benchmarks/throughput.py and the revisions it runs (benchmarks/revisions.py): the report's
shape and text, a revision's tree (the timing itself is the benchmark's, not a test's)."""

import statistics
import subprocess
import sys
from pathlib import Path

import pytest

from benchmarks import revisions, throughput


def _report(**changes):
    report = {
        "experiment_serial_uncached_s": 40.0,
        "experiment_default_cold_cache_s": 12.0,
        "experiment_default_s": 10.0,
        "experiment_speedup": 4.0,
        "experiment_speedup_cold_cache": 40.0 / 12.0,
        "sweep_points": 8,
        "sweep_1_worker_s": 10.0,
        "sweep_2_workers_s": 5.5,
        "sweep_speedup_2_vs_1": 10.0 / 5.5,
        "cores": 2,
        "short_run_sim_s": 17.0,
        "short_run_rt_factor": 30.0,
        "long_run_sim_s": 307.0,
        "long_run_rt_factor": 29.0,
        "long_run_rt_ratio": 29.0 / 30.0,
        "short_hold_s": 10.0,
        "long_hold_s": 300.0,
        "short_hold_rt_factor": 25.0,
        "long_hold_rt_factor": 24.0,
        "hold_rt_ratio": 24.0 / 25.0,
    }
    report.update(changes)
    return report


def test_the_text_gives_each_ratio_with_what_it_compares():
    text = throughput.format_throughput(_report())
    assert "4.00x  (the caches' and workers' share" in text and "1.82x  (on 2 cores)" in text
    assert "ratio 0.97  (mostly hold against mostly free motion)" in text and "ratio 0.96  (hold against hold" in text
    # The measurements are reported, not judged: no verdict in any line.
    assert " ok" not in text and "NO" not in text and "target" not in text
    windows = {"long_hold_window_s": 10.0, "long_hold_window_rt_factors": [24.0, 15.0, 26.0], "long_hold_rt_factor_mean": 21.0}
    text = throughput.format_throughput(_report(**windows, hold_rt_ratio_mean=21.0 / 25.0))
    assert "median of 3 windows of 10 s: slowest 15.0x, fastest 26.0x" in text and "ratio 0.84)" in text


def test_the_long_hold_is_judged_by_its_median_window():
    """A burst of a slow machine in a few windows does not move the median window; a cost that
    grows with the run's length does (the failure the target is there to catch)."""
    dt, per = 0.005, 100
    steady = [1e-4] * (30 * per)
    assert throughput.window_rt_factors(steady, dt, per) == pytest.approx([50.0] * 30)
    burst = [1.6e-4 if 300 <= i < 900 else 1e-4 for i in range(30 * per)]  # 6 windows 1.6x slower
    windows = throughput.window_rt_factors(burst, dt, per)
    assert statistics.median(windows) == pytest.approx(50.0) and min(windows) == pytest.approx(50.0 / 1.6)
    growing = [1e-4 * (1 + i / (30 * per)) for i in range(30 * per)]  # twice as dear at the end
    assert statistics.median(throughput.window_rt_factors(growing, dt, per)) / 50.0 < 0.7
    # A short tail joins the last window rather than standing alone.
    assert len(throughput.window_rt_factors(steady + [1e-4] * 10, dt, per)) == 30


def test_the_hold_is_timed_alone_in_both_runs(tmp_path):
    """A short stand-in of the measurement (holds of 0.2 and 0.6 s): the hold's own real-time
    factor is measured over exactly the hold's steps, in both runs, the short one twice."""
    report = throughput.long_run_times(tmp_path, long_hold_s=0.6, short_hold_s=0.2)
    assert report["short_hold_rt_factor"] > 0 and report["long_hold_rt_factor"] > 0
    assert report["hold_rt_ratio"] == pytest.approx(report["long_hold_rt_factor"] / report["short_hold_rt_factor"])
    assert report["hold_rt_ratio_mean"] == pytest.approx(report["long_hold_rt_factor_mean"] / report["short_hold_rt_factor"])
    assert report["long_run_sim_s"] - report["short_run_sim_s"] == pytest.approx(0.4, abs=0.1)
    assert {p.name for p in tmp_path.iterdir()} == {"hold-0.2", "hold-0.6", "hold-0.2-again"}


def test_a_failing_command_is_an_error_naming_it(tmp_path):
    with pytest.raises(RuntimeError, match="nothere"):
        throughput._timed_command(["run", "nothere"], throughput._env(tmp_path))


def test_the_sweep_speedup_is_the_median_of_paired_rounds(tmp_path, monkeypatch):
    """Each round times 1 and 2 workers back to back, in alternating order; one slow spell (here
    the second round's 1-worker run) moves a single pair's ratio, not the median.  The judged
    sweep (``sweep_*``) is the users' grid, the small one (``small_sweep_*``) is reported beside it."""
    calls = []
    small = iter([6.0, 4.0, 4.0, 6.4, 6.2, 4.0])  # (1, 2), (2, 1), (1, 2)
    large = iter([9.0, 8.0, 5.0, 5.0, 12.0, 8.5, 5.0])  # warm-up, then (1, 2), (2, 1), (1, 2)

    def fake(args, env, script=None, cwd=None):
        grid = tuple(args[i + 1] for i, arg in enumerate(args) if arg == "--grid")
        workers = args[args.index("--workers") + 1]
        calls.append((len(grid), workers))
        return next(large if grid == throughput.SWEEP_GRID else small)

    monkeypatch.setattr(throughput, "_timed_command", fake)
    report = throughput.sweep_times(tmp_path, rounds=3)
    n_small, n_large = len(throughput.SMALL_SWEEP_GRID), len(throughput.SWEEP_GRID)
    assert calls[0] == (n_large, "2")  # the warm-up fills the disk cache of every sensor design
    assert [w for n, w in calls[1:] if n == n_large] == ["1", "2", "2", "1", "1", "2"]
    assert [w for n, w in calls[1:] if n == n_small] == ["1", "2", "2", "1", "1", "2"]
    assert report["sweep_1_worker_runs_s"] == [8.0, 12.0, 8.5] and report["sweep_2_workers_runs_s"] == [5.0, 5.0, 5.0]
    assert report["sweep_speedups"] == pytest.approx([1.6, 2.4, 1.7])
    assert report["sweep_speedup_2_vs_1"] == pytest.approx(1.7)
    assert report["sweep_1_worker_s"] == 8.5 and report["sweep_2_workers_s"] == 5.0
    assert report["small_sweep_speedups"] == pytest.approx([1.5, 1.6, 1.55])
    assert report["small_sweep_speedup_2_vs_1"] == pytest.approx(1.55)
    assert report["sweep_points"] == 96 and report["small_sweep_points"] == 24
    text = throughput.format_throughput(_report(**{k: v for k, v in report.items() if "sweep" in k}))
    assert "median of 3 pairs of runs: 8.0 s / 5.0 s = 1.60x, 12.0 s / 5.0 s = 2.40x, 8.5 s / 5.0 s = 1.70x" in text
    assert "1.55x  (about 1 s of each command is start-up)" in text and "1.70x  (on 2 cores)" in text


def test_the_sweep_grids_are_valid_and_the_users_scale():
    """The users' sweep varies objects, controllers and sensor designs (the issue's users' axes)
    and runs about a hundred points; every point is a valid configuration."""
    from piezotip.analysis.sweep_grid import check_points, grid_points, parse_grid

    grid = parse_grid(list(throughput.SWEEP_GRID))
    assert {key.split(".")[0] for key in grid} == {"object", "controller", "sensor"}
    assert 90 <= throughput.grid_points_count(throughput.SWEEP_GRID) <= 110
    assert set(parse_grid(list(throughput.SMALL_SWEEP_GRID))) < set(grid)
    check_points("grasp", grid_points(grid), None)


def _git_checkout() -> bool:
    proc = subprocess.run(["git", "-C", str(revisions.REPO), "rev-parse", "HEAD"], capture_output=True)
    return proc.returncode == 0


needs_git = pytest.mark.skipif(not _git_checkout(), reason="needs a git checkout of piezotip")


@needs_git
def test_a_revision_runs_its_own_code_not_this_checkouts(tmp_path):
    run_from, env = revisions.revision_tree("HEAD", tmp_path)
    code = (
        "import sys, piezotip.sensor.channel as c, piezotip.cli as cli, piezotip.cosim.loop; print(c.__file__); print(cli.__file__); "
        "print(*sorted(m.__file__ for m in list(sys.modules.values())"
        " if m.__name__.split('.')[0] == 'piezotip' and getattr(m, '__file__', None)))"
    )
    proc = subprocess.run([sys.executable, "-c", code], cwd=run_from, env=env, capture_output=True, text=True, check=True)
    files = proc.stdout.split()
    assert len(files) > 20 and all(f.startswith(str(run_from)) for f in files)
    # the symbolic links lead into the revision's extracted tree, never into this checkout
    # (no compiled twin of this checkout's either: the revision's own are not built)
    assert all(not Path(f).resolve().is_relative_to(revisions.REPO) for f in files)
    # Its run_sim.py too: Python puts a script's folder, its links resolved, first on sys.path
    # (a linked run_sim.py put the extracted tree's piezotip/ there, whose subpackages this
    # checkout's editable install then served).  -v names the file of every module it loads, last on its line.
    listed = subprocess.run([sys.executable, "-v", "run_sim.py", "list"], cwd=run_from, env=env, capture_output=True, text=True)
    assert listed.returncode == 0 and "grasp" in listed.stdout
    loaded = [line.split()[-1].strip("'") for line in listed.stderr.splitlines() if line.startswith("# ") and "/" in line]
    ours = [f for f in loaded if "/.venv" not in f and Path(f).resolve().is_relative_to(revisions.REPO)]
    assert any(f.startswith(str(run_from)) for f in loaded) and ours == []


@needs_git
def test_an_unknown_revision_is_an_error_naming_it(tmp_path):
    with pytest.raises(ValueError, match="no-such-revision"):
        revisions.revision_tree("no-such-revision", tmp_path)


def test_the_baseline_line_gives_its_ratio():
    report = _report(baseline_rev="abc1234", baseline_experiment_s=30.0, experiment_with_plot_s=10.0, baseline_speedup=3.0)
    text = throughput.format_throughput(report)
    assert "at abc1234" in text and "(as that revision ran it)" in text
    assert "3.00x  (the whole speed-up since abc1234)" in text and "NO" not in text


@needs_git
def test_a_revisions_imports_read_compiled_bytecode(tmp_path):
    """After compile_bytecode, the revision's imports (through its linked layout, a linked
    subpackage folder among them) find their bytecode cached and compile nothing, even with
    PYTHONDONTWRITEBYTECODE set."""
    run_from, env = revisions.revision_tree("HEAD", tmp_path / "baseline")
    assert revisions.compile_bytecode(tmp_path / "baseline")
    code = (
        "import importlib.util, sys, piezotip.cosim.control.multimode as m, piezotip.sensor.channel as c;"
        "print(all(importlib.util.cache_from_source(x.__file__) == x.__cached__ for x in (m, c)));"
        "import os; print(all(os.path.exists(x.__cached__) for x in (m, c)))"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code], cwd=run_from, env={**env, "PYTHONDONTWRITEBYTECODE": "1"}, capture_output=True, text=True, check=True
    )
    assert proc.stdout.split() == ["True", "True"]


def test_compiling_says_when_a_module_does_not_compile(tmp_path):
    (tmp_path / "good.py").write_text("x = 1\n")
    assert revisions.compile_bytecode(tmp_path)
    (tmp_path / "bad.py").write_text("def broken(:\n")
    assert not revisions.compile_bytecode(tmp_path)
    assert (tmp_path / "__pycache__").is_dir()


@pytest.mark.parametrize("rev", ["--output=F", "-h", "", "HEAD\n--output=F"])
def test_a_revision_that_reads_as_an_option_is_refused_before_git_sees_it(tmp_path, rev):
    """``bench --baseline=--output=F`` used to reach ``git archive`` as an option (which wrote F)."""
    with pytest.raises(ValueError, match="is not a revision"):
        revisions.revision_tree(rev, tmp_path)
    assert not (Path.cwd() / "F").exists() and list(tmp_path.iterdir()) == []


def test_a_revision_resolves_to_its_commit():
    head = revisions.resolve_revision("HEAD")
    assert len(head) == 40 and revisions.resolve_revision(head[:12]) == head
    with pytest.raises(ValueError, match="no-such-revision"):
        revisions.resolve_revision("no-such-revision")
    with pytest.raises(ValueError, match="is not a revision"):
        throughput.throughput_report(baseline="--output=F")
