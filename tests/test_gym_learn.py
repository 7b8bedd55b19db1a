"""The learning environment ``piezotip/GraspLearn-v0`` (piezotip/gym_learn.py, issue 46).

* registered beside the others; Gymnasium's ``check_env`` passes, and Stable-Baselines3's;
* the reward is the sum of its parts in ``info``, at every step;
* doing nothing returns 0, below a successful grasp, and no weights can make a success worth
  less (the least successful return is checked);
* a grasp that knows the object's need succeeds at the referee's margin it aimed for, and the last
  step's ``info`` carries the referee's outcome and grip margin; a crushing grip ends the episode
  with its penalty;
* a seed repeats its episode and its object; ``randomize`` draws within the gripper's rating;
* bad input (outside the space, NaN, a wrong shape, stepping after the end) is an error;
* examples/train_ppo.py says what is missing without Stable-Baselines3, and trains with it.
"""

from __future__ import annotations

import csv
import importlib.util
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import gymnasium
import numpy as np
import pytest
from gym_checks import registered_entry_point, stable_baselines3_warnings
from gymnasium.utils.env_checker import check_env

import piezotip  # noqa: F401 - registers the environments
from piezotip.gym_learn import REWARD_PARTS, GraspLearnEnv, LearnReward, LearnSettings, ObjectDraw, force_to_unit, unit_to_force
from piezotip.scenarios.config import OBJECT_SHAPES, RATED_MASS_KG

ROOT = Path(__file__).resolve().parent.parent
LEARN_ID = "piezotip/GraspLearn-v0"
HAVE_SB3 = importlib.util.find_spec("stable_baselines3") is not None
#: Holds still at home: the opening target at home, no lift.
STILL = np.array([-1.0, 1.0, 0.0, -1.0], np.float32)


@pytest.fixture(scope="module")
def env():
    env = GraspLearnEnv(preset="fast", randomize=True)
    yield env
    env.close()


def _episode(env, seed, policy, max_steps=10**9):
    obs, start = env.reset(seed=seed)
    observations, rewards, infos = [obs], [], []
    for _ in range(max_steps):
        obs, reward, terminated, truncated, info = env.step(policy(obs, env))
        observations.append(obs)
        rewards.append(reward)
        infos.append(info)
        if terminated or truncated:
            break
    return start, np.array(observations), rewards, infos


def _random_policy(seed):
    rng = np.random.default_rng(seed)
    return lambda obs, env: rng.uniform(-1.0, 1.0, 4).astype(np.float32)


def _knowing_policy(margin):
    """Grips ``margin`` times the object's true need (which no agent sees) from the start, closes
    until both pads feel the object, lifts, holds until the hold clock is full, lowers, opens."""
    state = {}

    def policy(obs, env):
        names = env.observation_names
        o = dict(zip(names, obs.tolist(), strict=True))
        if not state or o["time"] == 0.0:
            state.clear()
            state.update(phase="close", touched=0, waited=0)
        a = np.array([_grip_rate_to(env, margin * env.need_n), -1.0, 0.0, -1.0], np.float32)
        state["touched"] = state["touched"] + 1 if o["left_pad.pressure"] > 0 and o["right_pad.pressure"] > 0 else 0
        if state["phase"] == "close":
            if state["touched"] >= 3:
                state["phase"] = "lift"
            return a
        state["waited"] += 1
        if state["phase"] == "lift":
            a[2] = 1.0 if state["waited"] > 3 else 0.0  # the lift's top, 1.2 lift heights
            if o["hold_clock"] >= 1.0:
                state["phase"] = "lower"
        elif state["phase"] == "lower":
            a[2] = -1.0
            if o["lift"] <= 0.001:
                state["phase"], state["waited"] = "open", 0
        else:
            a[1:3] = 1.0 if state["waited"] > 5 else -1.0, -1.0
        return a

    return policy


def _grip_rate_to(env, grip_n):
    """The grip action that moves the grip toward ``grip_n`` as far as one decision can."""
    s = env.settings
    return float(np.clip(math.log10(grip_n / env.grip_command_n) / (s.grip_rate_decades_per_s * s.decision_period_s), -1.0, 1.0))


def test_registered_and_gymnasium_check_env():
    assert registered_entry_point(LEARN_ID) == "piezotip.gym_learn:GraspLearnEnv"
    env = gymnasium.make(LEARN_ID, preset="fast", randomize=True)
    assert isinstance(env.unwrapped, GraspLearnEnv)
    assert len(env.unwrapped.observation_names) == env.observation_space.shape[0] == 31
    check_env(env.unwrapped, skip_render_check=True)
    env.close()


@pytest.mark.skipif(not HAVE_SB3, reason="stable-baselines3 is not installed (the 'rl' extra)")
def test_stable_baselines3_check_env():
    messages = stable_baselines3_warnings(GraspLearnEnv(preset="fast", randomize=True))
    assert not messages, messages


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_reward_is_the_sum_of_its_parts_at_every_step(env, seed):
    _, observations, rewards, infos = _episode(env, seed, _random_policy(seed))
    for reward, info in zip(rewards, infos, strict=True):
        assert set(REWARD_PARTS) <= set(info)
        assert reward == pytest.approx(sum(info[k] for k in REWARD_PARTS), abs=1e-12)
    assert env.observation_space.contains(observations[-1]) and np.all(np.isfinite(observations))
    assert "outcome" in infos[-1] and "grip_margin" in infos[-1] and "outcome" not in infos[0]


def test_doing_nothing_returns_nothing_and_a_success_more():
    env = GraspLearnEnv(preset="fast")
    _, _, rewards, infos = _episode(env, 0, lambda obs, env: STILL)
    assert sum(rewards) == 0.0 and len(rewards) == env.max_steps
    assert infos[-1]["ended"] == "time_limit" and infos[-1]["outcome"] != "success"
    _, _, rewards, infos = _episode(env, 0, _knowing_policy(1.4))
    last = infos[-1]
    assert last["ended"] == last["outcome"] == "success", last["reason"]
    assert last["grip_margin"] == pytest.approx(1.4, rel=0.02) and last["grip_margin"] == last["verdict"]["grip_margin"]
    assert last["reward_success"] == env.weights.success
    # Every potential earned once; the grip under 1.25 x need (1.4 > 1.25: a small cost).
    assert sum(rewards) == pytest.approx(env.weights.progress_total + env.weights.success + sum(i["reward_grip"] for i in infos))
    assert sum(rewards) > 0.0 > sum(i["reward_grip"] for i in infos) > -0.5
    # The least a success could return, the grip's cost at its cap for the whole episode, is above 0 ...
    assert env.weights.least_success_return(env.settings.time_limit_s) > 0.0
    # ... and weights that would make it less are refused.
    with pytest.raises(ValueError, match="worth more than doing nothing"):
        GraspLearnEnv(preset="fast", reward=LearnReward(grip_per_s=5.0))
    env.close()


def test_a_crushing_grip_ends_the_episode_with_its_penalty():
    env = GraspLearnEnv(preset="fast", overrides={"object.crush_force_n": 0.5})
    squeeze = np.array([1.0, -1.0, 0.0, -1.0], np.float32)  # the grip rising as fast as it can
    _, _, rewards, infos = _episode(env, 0, lambda obs, env: squeeze)
    last = infos[-1]
    assert last["ended"] == last["outcome"] == "crushed" and math.isnan(last["grip_margin"])
    assert all(i["reward_crush"] == 0.0 for i in infos[:-1])
    assert last["reward_crush"] == -env.weights.crush
    # Touched, then broken on the table: less than doing nothing.
    assert sum(rewards) == pytest.approx(env.weights.touch - env.weights.crush) and sum(rewards) < 0.0
    env.close()


def test_a_seed_repeats_its_episode_and_another_changes_it(env):
    first = _episode(env, 7, _random_policy(0), max_steps=60)
    again = _episode(env, 7, _random_policy(0), max_steps=60)
    assert first[0] == again[0]  # the object and its need
    np.testing.assert_array_equal(first[1], again[1])
    assert first[2] == again[2]
    other = _episode(env, 8, _random_policy(0), max_steps=60)
    assert other[0]["object"] != first[0]["object"]


def test_randomize_draws_within_the_grippers_rating(env):
    draw, limit, g = ObjectDraw(), env.grip_max_n, env.grasp_env.gravity_m_s2
    rng = np.random.default_rng(0)
    objects = [draw.sample(rng, limit, g) for _ in range(2000)]
    for obj in objects:
        obj.validate()
        need = obj.mass_kg * g / (2 * obj.friction)
        assert RATED_MASS_KG[0] <= obj.mass_kg <= RATED_MASS_KG[1]
        assert draw.friction[0] <= obj.friction <= draw.friction[1] and draw.size_m[0] <= obj.size_m <= draw.size_m[1]
        assert max(draw.crush_over_need * need, draw.crush_floor_n) <= obj.crush_force_n <= limit
    assert {o.shape for o in objects} == set(OBJECT_SHAPES)
    masses = sorted(o.mass_kg for o in objects)
    assert masses[0] < 0.002 and masses[-1] > 5.0  # the whole rating, log-uniform
    # The environment grasps what it drew from the seed, and says so at the reset.
    _, info = env.reset(seed=5)
    assert info["object"] == {k: getattr(env.grasp_env.config.object, k) for k in info["object"]}
    assert info["needed_grip_n"] == pytest.approx(env.grasp_env.config.object.mass_kg * g / (2 * env.grasp_env.config.object.friction))


def test_force_scale_round_trips_and_spans_the_rating(env):
    lo, hi = env.grip_min_n, env.grip_max_n
    assert (lo, hi) == pytest.approx((1e-3, 100.0))
    for x in (-1.0, -0.3, 0.0, 0.7, 1.0):
        assert force_to_unit(unit_to_force(x, lo, hi), lo, hi) == pytest.approx(x)
    assert force_to_unit(0.0, lo, hi) == force_to_unit(-3.0, lo, hi) == -1.0 and force_to_unit(1e3, lo, hi) == 1.0


def test_every_observation_is_in_the_docstring(env):
    doc = GraspLearnEnv.__doc__
    for name in env.observation_names:
        template = re.sub(r"^(left|right)_pad\.", "{pad}.", name)
        template = re.sub(r"mode_\d+$", "mode_{m}", template)
        template = re.sub(r"status_\w+$", "status_{s}", template)
        assert f"``{template}``" in doc, name


def test_bad_input_is_an_error_never_a_reward():
    env = GraspLearnEnv(preset="fast", settings=LearnSettings(time_limit_s=0.08))  # two decisions
    with pytest.raises(RuntimeError, match="reset"):
        env.step(STILL)
    env.reset(seed=0)
    for bad, match in [
        (np.array([1.5, 0, 0, 0]), "action space"),
        (np.array([np.nan, 0, 0, 0]), "finite"),
        (np.zeros(5), "4 real numbers"),
        (np.zeros((2, 2)), "4 real numbers"),
        (["a", 0, 0, 0], "4 real numbers"),
        ({"grip": 0}, "4 real numbers"),
    ]:
        with pytest.raises(ValueError, match=match):
            env.step(bad)
    _, _, terminated, truncated, _ = env.step(STILL)
    _, _, terminated, truncated, info = env.step(STILL)
    assert truncated and not terminated and info["ended"] == "time_limit"
    with pytest.raises(RuntimeError, match="episode has ended"):
        env.step(STILL)
    env.reset(seed=0)
    env.step(STILL)  # a reset starts again
    for kwargs, match in [
        ({"settings": LearnSettings(decision_period_s=0.007)}, "whole number of control periods"),
        ({"settings": LearnSettings(time_limit_s=-1.0)}, "time_limit_s"),
        ({"randomize": "yes"}, "randomize"),
        ({"randomize": ObjectDraw(friction=(0.05, 0.06), mass_kg=(5.0, 10.0))}, "no mass"),
        ({"reward": {"success": 1}}, "LearnReward"),
    ]:
        with pytest.raises(ValueError, match=match):
            GraspLearnEnv(preset="fast", **kwargs)
    env.close()


def _python(args: list[str], env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, *args], cwd=ROOT, capture_output=True, text=True, timeout=600, env=env)


def test_train_ppo_says_what_is_missing_without_stable_baselines3():
    code = (
        "import runpy, sys; sys.modules['stable_baselines3'] = None; sys.argv = ['train_ppo.py', '--steps', '8'];"
        "runpy.run_path('examples/train_ppo.py', run_name='__main__')"
    )
    result = _python(["-c", code])
    assert result.returncode == 2
    assert "needs stable-baselines3" in result.stderr and "pip install" in result.stderr


@pytest.mark.slow
@pytest.mark.skipif(not HAVE_SB3, reason="stable-baselines3 is not installed (the 'rl' extra)")
def test_train_ppo_trains_on_two_processes_and_writes_its_curve(tmp_path):
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    save = tmp_path / "model.zip"
    args = ["examples/train_ppo.py", "--steps", "512", "--seed", "3", "--randomize", "--save", str(save), "--eval-episodes", "1"]
    result = _python(args, env)
    assert result.returncode == 0, result.stderr
    assert re.search(r"training: 512 steps in \d+ s \(\d+ steps/s\), \d+ episodes ended", result.stdout), result.stdout
    assert re.search(r"trained policy: \d+ % success on 1 held-out objects", result.stdout), result.stdout
    assert re.search(r"house controller: \d+ % success on 1 held-out objects", result.stdout), result.stdout
    assert save.is_file() and (tmp_path / "model_curve.png").is_file()
    rows = list(csv.DictReader((tmp_path / "model_curve.csv").open()))
    assert [int(r["steps"]) for r in rows] == [512]  # one rollout of 256 decisions on each of 2 environments
    assert {"success_rate", "median_grip_margin", "fps", "wall_s", "lift_progress", "hold_progress"} <= set(rows[0])
    evaluated = list(csv.DictReader((tmp_path / "model_eval.csv").open()))
    assert [int(r["seed"]) for r in evaluated] == [1_000_000]
