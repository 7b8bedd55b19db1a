"""`bench --throughput`: its report's shape and verdicts (the timing itself is bench's, not a test's)."""

import pytest

from piezotip.analysis import throughput


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
    }
    report.update(changes)
    return report


def test_the_text_gives_each_ratio_against_its_target():
    text = throughput.format_throughput(_report())
    assert "4.00x" in text and "1.82x" in text and "ratio 0.97" in text
    assert text.count("  ok") == 3 and "NO" not in text
    assert throughput.format_throughput(_report(experiment_speedup=2.0)).count("NO") == 1


def test_a_failing_command_is_an_error_naming_it(tmp_path):
    with pytest.raises(RuntimeError, match="nothere"):
        throughput._timed_command(["run", "nothere"], throughput._env(tmp_path))


def test_the_sweep_grid_has_the_points_it_says():
    assert throughput.SWEEP_GRID and all("=" in g for g in throughput.SWEEP_GRID)
