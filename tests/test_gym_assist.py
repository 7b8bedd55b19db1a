"""The assisted environment ``piezotip/GraspAssist-v0`` (piezotip/gym_learn.py, issue 46): the house
controller runs the grasp and the policy scales its grip.

* registered beside the others; Gymnasium's ``check_env`` passes, and Stable-Baselines3's;
* action 0 is the house controller bit for bit: the same record, the referee's same outcome and
  grip margin as the controller run alone in ``Grasp-v0`` on the same object and seed;
* an action scales the controller's grip by 2^a (at most the fingers' limit);
* the reward is the sum of its parts in ``info``, at every step; the observations stay in bounds;
* a seed repeats its episode;
* bad input (outside the space, NaN, a wrong shape, stepping after the end) is an error.
"""

from __future__ import annotations

import math
import re
import subprocess
import sys
from pathlib import Path

import gymnasium
import numpy as np
import pytest
from gym_checks import registered_entry_point, stable_baselines3_warnings
from gymnasium.utils.env_checker import check_env
from test_gym_learn import _episode  # one episode under a policy(obs, env), as GraspLearn-v0's tests run it

import piezotip  # noqa: F401 - registers the environments
from piezotip.gym_env import GraspEnv, MultimodePolicy
from piezotip.gym_learn import PHASE_NAMES, REWARD_PARTS, GraspAssistEnv, GraspLearnEnv, LearnSettings

ROOT = Path(__file__).resolve().parent.parent
ASSIST_ID = "piezotip/GraspAssist-v0"
ZERO = np.zeros(1, np.float32)


@pytest.fixture(scope="module")
def env():
    env = GraspAssistEnv(preset="fast", randomize=True)
    yield env
    env.close()


def _random_policy(seed, scale=1.0):
    rng = np.random.default_rng(seed)
    return lambda obs, env: np.clip(rng.normal(0.0, scale, 1), -1.0, 1.0).astype(np.float32)


def test_registered_and_gymnasium_check_env():
    assert registered_entry_point(ASSIST_ID) == "piezotip.gym_learn:GraspAssistEnv"
    env = gymnasium.make(ASSIST_ID, preset="fast", randomize=True)
    u = env.unwrapped
    assert isinstance(u, GraspAssistEnv) and isinstance(u, GraspLearnEnv)
    assert env.action_space.shape == (1,)
    learn_names = GraspLearnEnv(preset="fast").observation_names
    assert u.observation_names == (*learn_names, "house_grip", "grip_factor", *(f"phase_{p}" for p in PHASE_NAMES))
    assert len(u.observation_names) == env.observation_space.shape[0]
    assert u.settings.time_limit_s == u.grasp_env.base_config.duration_s  # the house's whole time
    check_env(u, skip_render_check=True)
    env.close()


def test_stable_baselines3_check_env():
    pytest.importorskip("stable_baselines3")
    messages = stable_baselines3_warnings(GraspAssistEnv(preset="fast", randomize=True))
    assert not messages, messages


# 1000000: the house succeeds (placed at 5 s); 1000005: a 3.6 kg sphere it never lifts (12 s).
@pytest.mark.parametrize("seed", [1_000_000, 1_000_005])
def test_action_zero_is_the_house_controller_bit_for_bit(env, seed):
    _, _, _, infos = _episode(env, seed, lambda obs, env: ZERO)
    assisted = env.grasp_env.recording()
    house_env = GraspEnv("grasp", None, "fast")
    house = MultimodePolicy.for_env(house_env)
    obs, _ = house_env.reset(seed=seed, options={"object": env.grasp_env.config.object})
    house.config = house_env.config  # the episode's scenario: the camera sees the episode's object
    while True:
        obs, _, terminated, truncated, house_info = house_env.step(house(obs))
        if terminated or truncated:
            break
    alone = house_env.recording()
    n = len(assisted["time_s"])
    assert 0 < n <= len(alone["time_s"])
    for column, values in assisted.items():
        np.testing.assert_array_equal(values, alone[column][:n], err_msg=column)
    last = infos[-1]
    assert last["outcome"] == house_info["outcome"]
    margin, house_margin = last["grip_margin"], house_info["verdict"]["grip_margin"]
    assert margin == house_margin or (math.isnan(margin) and math.isnan(house_margin))
    assert all(i["grip_factor"] == 1.0 for i in infos)
    house_env.close()


def test_an_action_scales_the_controllers_grip(env):
    env.reset(seed=3)
    for a, factor in [(0.0, 1.0), (1.0, 2.0), (-1.0, 0.5), (0.5, math.sqrt(2.0))]:
        obs, _, terminated, truncated, info = env.step(np.array([a], np.float32))
        assert not (terminated or truncated)
        assert info["grip_factor"] == pytest.approx(factor)
        assert env.grip_command_n == pytest.approx(min(factor * env._house_grip_n, env.grip_max_n))
        o = dict(zip(env.observation_names, obs.tolist(), strict=True))
        assert o["grip_factor"] == pytest.approx(a)
        assert sum(o[f"phase_{p}"] for p in PHASE_NAMES) == 1.0 and o[f"phase_{env.phase.label}"] == 1.0
    with pytest.raises(ValueError, match="grip_octaves"):
        GraspAssistEnv(preset="fast", grip_octaves=0.0)


@pytest.mark.parametrize("seed", [0, 1])
def test_the_reward_is_the_sum_of_its_parts_at_every_step(env, seed):
    _, observations, rewards, infos = _episode(env, seed, _random_policy(seed, 0.3))
    for reward, info in zip(rewards, infos, strict=True):
        assert set(REWARD_PARTS) <= set(info)
        assert reward == pytest.approx(sum(info[k] for k in REWARD_PARTS), abs=1e-12)
    assert all(env.observation_space.contains(o) for o in observations) and np.all(np.isfinite(observations))
    last = infos[-1]
    assert {"outcome", "grip_margin", "needed_grip_n", "verdict"} <= set(last) and "outcome" not in infos[0]
    if last["outcome"] == "success":
        assert last["reward_success"] == env.weights.success


def test_a_seed_repeats_its_episode_and_another_changes_it(env):
    first = _episode(env, 7, _random_policy(0), max_steps=40)
    again = _episode(env, 7, _random_policy(0), max_steps=40)
    assert first[0] == again[0]
    np.testing.assert_array_equal(first[1], again[1])
    assert first[2] == again[2]
    other = _episode(env, 8, _random_policy(0), max_steps=40)
    assert other[0]["object"] != first[0]["object"]


def test_bad_input_is_an_error_never_a_reward():
    env = GraspAssistEnv(preset="fast", settings=LearnSettings(time_limit_s=0.08))  # two decisions
    with pytest.raises(RuntimeError, match="reset"):
        env.step(ZERO)
    env.reset(seed=0)
    for bad, match in [
        (np.array([1.5]), "action space"),
        (np.array([np.nan]), "finite"),
        (np.zeros(2), "1 real number"),
        (np.zeros((1, 1)), "1 real number"),
        (["a"], "1 real number"),
        ({"grip": 0}, "1 real number"),
    ]:
        with pytest.raises(ValueError, match=match):
            env.step(bad)
    env.step(ZERO)
    _, _, terminated, truncated, info = env.step(ZERO)
    assert truncated and not terminated and info["ended"] == "time_limit"
    with pytest.raises(RuntimeError, match="episode has ended"):
        env.step(ZERO)
    env.reset(seed=0)
    env.step(np.float32(0.2))  # a scalar is one number too; a reset starts again
    env.close()


def test_every_observation_is_in_a_docstring(env):
    doc = GraspLearnEnv.__doc__ + GraspAssistEnv.__doc__
    for name in env.observation_names:
        template = re.sub(r"^(left|right)_pad\.", "{pad}.", name)
        template = re.sub(r"mode_\d+$", "mode_{m}", template)
        template = re.sub(r"status_\w+$", "status_{s}", template)
        template = re.sub(r"^phase_\w+$", "phase_{p}", template)
        assert f"``{template}``" in doc, name


def test_train_ppo_chooses_the_environment():
    result = subprocess.run([sys.executable, "examples/train_ppo.py", "--help"], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert result.returncode == 0 and "--env {assist,learn}" in result.stdout and "--out" in result.stdout, result.stderr
