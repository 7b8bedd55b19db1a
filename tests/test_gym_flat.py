"""The flat Gymnasium environment ``piezotip/GraspFlat-v0`` (piezotip/gym_flat.py, issue 32).

* registered next to ``piezotip/Grasp-v0``; Gymnasium's ``check_env`` passes, and
  Stable-Baselines3's where it is installed;
* a seeded rollout repeats exactly, another seed changes it;
* random actions keep the observation finite and within its bounds, and what the docstring
  calls never clipped stays within them before clipping;
* an action's -1 and +1 are the robot's limits exactly (the RobotLimits the house controller
  uses), and reach the set-points; each pad's mode is binned evenly;
* the house controller driving it ends its episode on success, terminated, right after the
  release; without ``terminate_on_success`` the episode goes on;
* every observation entry is in the docstring's table; bad actions are refused.

examples/train_ppo.py trains on ``piezotip/GraspLearn-v0``: its tests are in tests/test_gym_learn.py.
"""

from __future__ import annotations

import importlib.util
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
from piezotip.cosim.assembly import build_scene
from piezotip.cosim.loop import REST_MAX_S
from piezotip.cosim.rows import READOUT_STATUSES as STATUS_CODES  # what an agent sees
from piezotip.gym_env import MultimodePolicy
from piezotip.gym_flat import GraspFlatEnv

ROOT = Path(__file__).resolve().parent.parent
FLAT_ID = "piezotip/GraspFlat-v0"
HAVE_SB3 = importlib.util.find_spec("stable_baselines3") is not None


@pytest.fixture(scope="module")
def env():
    env = GraspFlatEnv(preset="fast", overrides={"duration_s": 3.0})
    yield env
    env.close()


def _python(code: str, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, *(["-c", code] if code else []), *args], cwd=ROOT, capture_output=True, text=True, timeout=600)


def test_registered_with_gymnasium_in_either_import_order():
    for first in ("piezotip", "gymnasium"):
        assert registered_entry_point(FLAT_ID, first) == "piezotip.gym_flat:GraspFlatEnv"


def test_make_and_gymnasium_check_env():
    env = gymnasium.make(FLAT_ID, preset="fast", overrides={"duration_s": 1.0})
    assert isinstance(env.unwrapped, GraspFlatEnv)
    assert len(env.unwrapped.observation_names) == env.observation_space.shape[0]
    check_env(env.unwrapped, skip_render_check=True)  # rendering: tests/test_gym_env.py
    env.close()


@pytest.mark.skipif(not HAVE_SB3, reason="stable-baselines3 is not installed (the 'rl' extra)")
def test_stable_baselines3_check_env():
    messages = stable_baselines3_warnings(GraspFlatEnv(preset="fast", overrides={"duration_s": 1.0}))
    assert not messages, messages


def _rollout(env, seed: int, steps: int, action_seed: int = 0):
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(action_seed)
    observations = [obs]
    for _ in range(steps):
        obs, _, terminated, truncated, _ = env.step(rng.uniform(-1.0, 1.0, env.action_space.shape).astype(np.float32))
        observations.append(obs)
        if terminated or truncated:
            break
    return np.array(observations)


def test_a_seeded_rollout_repeats_and_the_seed_matters(env):
    first = _rollout(env, seed=3, steps=60)
    again = _rollout(env, seed=3, steps=60)
    np.testing.assert_array_equal(first, again)
    other = _rollout(env, seed=4, steps=60)
    assert first.shape == other.shape and not np.array_equal(first, other)  # another readout noise


def test_random_actions_keep_observations_finite_and_within_bounds(env):
    space = env.observation_space
    assert np.all(np.isfinite(space.low)) and np.all(np.isfinite(space.high))
    never_clipped = np.array([not e.clipped for e in env.observation_entries])
    obs, _ = env.reset(seed=11)
    rng = np.random.default_rng(11)
    steps = 0
    while True:
        assert obs.dtype == np.float32 and np.all(np.isfinite(obs)) and space.contains(obs), steps
        raw = env.scaled_observation(env.grasp_observation)
        assert np.all(np.isfinite(raw)), [n for n, x in zip(env.observation_names, raw, strict=True) if not np.isfinite(x)]
        ok = ((raw >= space.low - 1e-6) & (raw <= space.high + 1e-6)) | ~never_clipped
        assert np.all(ok), [(n, x) for n, x, good in zip(env.observation_names, raw, ok, strict=True) if not good]
        obs, _, terminated, truncated, _ = env.step(rng.uniform(-1.0, 1.0, env.action_space.shape))
        steps += 1
        if terminated or truncated:
            break
    assert space.contains(obs)


def test_actions_at_plus_and_minus_one_are_the_robots_limits(env):
    robot = MultimodePolicy.for_env(env).robot  # the house controller's own RobotLimits
    model = build_scene(env.base_config)
    fingers, lift = model.actuator("fingers_actuator"), model.actuator("lift_actuator")
    assert robot.finger_force_limit_n == fingers.forcerange[1] and robot.lift_force_limit_n == lift.forcerange[1]
    n_pads, n_modes = len(env.pads), len(env.modes)
    top = env.action_to_grasp(np.ones(3 + n_pads))
    bottom = env.action_to_grasp(-np.ones(3 + n_pads))
    assert top["grip_force_n"][0] == robot.finger_force_limit_n and bottom["grip_force_n"][0] == 0.0
    opening_top = robot.finger_force_limit_n / robot.finger_damping_n_s_m
    lift_top = robot.lift_force_limit_n / robot.lift_kv_n_s_m
    assert top["opening_velocity_m_s"][0] == opening_top and bottom["opening_velocity_m_s"][0] == -opening_top
    assert top["lift_velocity_m_s"][0] == lift_top and bottom["lift_velocity_m_s"][0] == -lift_top
    assert top["mode"].tolist() == [n_modes - 1] * n_pads and bottom["mode"].tolist() == [0] * n_pads
    # Beyond the bounds is clipped to them; every key is GraspEnv's and in its space.
    beyond = env.action_to_grasp(np.full(3 + n_pads, 5.0))
    assert all(np.array_equal(beyond[k], top[k]) for k in top)
    assert env.grasp_env.action_space.contains(top) and env.grasp_env.action_space.contains(bottom)
    # ... and they reach the set-points: one step from home closes and raises at the top speeds.
    env.reset(seed=0)
    home = env.grasp_observation
    env.step(np.array([-1.0, -1.0, 1.0, *([-1.0] * n_pads)], np.float32))
    after = env.grasp_observation
    dt = env.grasp_env.dt
    assert after["opening_setpoint_m"][0] == home["opening_setpoint_m"][0] - opening_top * dt
    assert after["lift_setpoint_m"][0] == home["lift_setpoint_m"][0] + lift_top * dt


def test_each_pads_mode_is_binned_evenly(env):
    n_pads, n_modes = len(env.pads), len(env.modes)
    edges = np.linspace(-1.0, 1.0, n_modes + 1)
    for k in range(n_modes):
        for a in (edges[k] + 1e-6, 0.5 * (edges[k] + edges[k + 1]), edges[k + 1] - 1e-6):
            assert env.action_to_grasp(np.array([0.0, 0.0, 0.0, *([a] * n_pads)]))["mode"].tolist() == [k] * n_pads, (k, a)
    # A house controller's action comes back as itself (the mode at its bin's centre).
    grasp = {"grip_force_n": [2.5], "opening_velocity_m_s": [-0.02], "lift_velocity_m_s": [0.1], "mode": np.arange(n_pads) % n_modes}
    back = env.action_to_grasp(env.action_from_grasp(grasp))
    assert back["mode"].tolist() == list(grasp["mode"])
    continuous = [back[k][0] for k in ("grip_force_n", "opening_velocity_m_s", "lift_velocity_m_s")]
    np.testing.assert_allclose(continuous, [2.5, -0.02, 0.1], rtol=1e-6)


def _house_episode(env, steps: int | None = None):
    policy = MultimodePolicy.for_env(env)
    env.reset(seed=0)
    n, total, info = 0, 0.0, {}
    terminated = truncated = False
    while steps is None or n < steps:
        action = env.action_from_grasp(policy(env.grasp_observation))
        _, reward, terminated, truncated, info = env.step(action)
        n, total = n + 1, total + reward
        if terminated or truncated:
            break
    return n, total, terminated, truncated, info


def test_the_house_controller_ends_its_episode_on_success_right_after_the_release():
    env = GraspFlatEnv(preset="fast")
    steps, total, terminated, truncated, info = _house_episode(env)
    assert terminated and not truncated
    assert info["ended"] == "success" and info["outcome"] == "success" and info["verdict"]["success"], info.get("reason")
    assert info["reward_success"] == env.grasp_env.weights.success and total > env.grasp_env.weights.success
    record = env.grasp_env.recording()
    touching = (record["left_finger_force_n"] > 0) | (record["right_finger_force_n"] > 0)
    released_at = int(np.flatnonzero(touching)[-1]) + 1  # the first row no finger touches
    assert len(touching) == steps < env.grasp_env.total_steps
    # At most the loop's own wait for an object to come to rest after the controller is done.
    assert released_at < steps <= released_at + round(REST_MAX_S / env.grasp_env.dt)
    # Without terminate_on_success the same episode goes on past that step.
    env_on = GraspFlatEnv(preset="fast", terminate_on_success=False)
    n, _, terminated, truncated, _ = _house_episode(env_on, steps=steps + 20)
    assert n == steps + 20 and not (terminated or truncated)
    env.close()
    env_on.close()


def test_every_observation_entry_is_in_the_docstring(env):
    doc = GraspFlatEnv.__doc__
    for name in env.observation_names:
        template = name
        for pad in env.pads:
            template = template.replace(f"{pad}.", "{pad}.")
        template = re.sub(r"mode_\d+$", "mode_{m}", template)
        template = re.sub(rf"status_({'|'.join(STATUS_CODES)})$", "status_{s}", template)
        assert f"``{template}``" in doc, name
    for status in STATUS_CODES:
        assert status in doc


def test_bad_actions_and_arguments_are_refused(env):
    env.reset(seed=0)
    n = env.action_space.shape[0]
    with pytest.raises(ValueError, match="finite"):
        env.step(np.full(n, np.nan))
    with pytest.raises(ValueError, match=f"{n} numbers"):
        env.step(np.zeros(n + 1))
    with pytest.raises(ValueError, match="terminate_on_success"):
        GraspFlatEnv(preset="fast", terminate_on_success="yes")
