"""benchmarks/gym_throughput.py: environment steps per second (measured, not judged, here)."""

import pytest

from benchmarks import gym_throughput


@pytest.mark.parametrize("policy", [False, True])
def test_one_environment_is_stepped_by_either_driver(policy):
    assert gym_throughput.measure("fast", steps=5, policy=policy, n_envs=1) > 0


def test_a_step_count_below_one_is_refused(capsys):
    with pytest.raises(SystemExit) as stop:
        gym_throughput.main(["--steps", "0"])
    assert stop.value.code == 2 and "--steps" in capsys.readouterr().err
