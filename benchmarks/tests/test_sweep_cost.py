"""The sweep's fixed-cost measurement (benchmarks/sweep_cost.py): what it times and what it reports."""

import pytest

from benchmarks import sweep_cost


def test_the_fixed_cost_is_the_median_of_the_pairs_differences(monkeypatch):
    calls = []
    seconds = {"sweep": iter([9.0, 1.0, 1.5, 3.0]), "run": iter([9.0, 0.5, 1.0, 1.5])}  # the first pair untimed

    def timed(call, env):
        calls.append(call)
        assert "piezotip-sweep-cost-" in env["PIEZOTIP_CACHE_DIR"]  # never the user's cache
        return next(seconds["sweep" if "sweep(" in call else "run"])

    monkeypatch.setattr(sweep_cost, "_api_seconds", timed)
    report = sweep_cost.measure(pairs=3)
    assert report["sweep_s"] == [1.0, 1.5, 3.0] and report["run_s"] == [0.5, 1.0, 1.5]
    assert report["fixed_cost_s"] == 0.5 and report["ratio"] == 2.0  # differences 0.5, 0.5, 1.5; ratios 2, 1.5, 2
    # The same point both ways, alternating.
    assert calls[2:4] == [
        "piezotip.sweep('grasp', {'object.mass_kg': ['0.1']}, preset='fast')",
        "piezotip.run('grasp', ['object.mass_kg=0.1'], preset='fast')",
    ]
    text = sweep_cost.format_cost(report)
    assert "fixed cost (sweep - run) 0.50 s, ratio 2.00" in text and "sweep  median 1.50 s  (1.00 .. 3.00)" in text


def test_the_commands_each_sweep_get_a_fresh_out(monkeypatch):
    seen = []
    monkeypatch.setattr(sweep_cost, "_command_seconds", lambda args, env: seen.append(args) or 1.0)
    sweep_cost.measure(pairs=2, command=True)
    outs = [a[a.index("--out") + 1] for a in seen if a[0] == "sweep"]
    assert len(outs) == 3 == len(set(outs))
    assert all("--no-plot" in a for a in seen) and {a[0] for a in seen} == {"sweep", "run"}


@pytest.mark.slow
def test_a_real_pair_of_api_calls_is_timed():
    report = sweep_cost.measure(pairs=1)
    assert report["sweep_s"][0] > 0 and report["run_s"][0] > 0


def test_no_pairs_is_an_error_naming_the_value():
    with pytest.raises(ValueError, match="-1"):
        sweep_cost.measure(pairs=-1)
