"""The Gymnasium environment ``piezotip/Grasp-v0`` (piezotip/gym_env.py, issue 12).

* ``import piezotip`` registers the environment without importing gymnasium, in either order;
* Gymnasium's own ``check_env`` passes; the observation holds no ground truth;
* a seeded episode repeats exactly, a different seed changes the readout noise and the drawn object;
* the multimode controller wrapped as a policy records exactly the steps ``run`` records and
  earns the same referee outcome;
* the episode ends when the referee's criteria say so (crushed, dropped), the reward is the sum
  of its parts in ``info``, truncation comes at the scenario's duration;
* bad input: the command line's errors for scenarios and overrides, actions clipped or refused
  as the manual says; AsyncVectorEnv with two environments.
"""

from __future__ import annotations

import os
import subprocess
import sys
from dataclasses import asdict
from pathlib import Path

import gymnasium
import numpy as np
import pytest
from gym_checks import registered_entry_point
from gymnasium.utils.env_checker import check_env

import piezotip
from piezotip import cli
from piezotip.analysis.referee import judge
from piezotip.analysis.runner import run_scenario
from piezotip.gym_env import GraspEnv, MultimodePolicy, ObjectRanges

ROOT = Path(__file__).resolve().parent.parent
ENV_ID = "piezotip/Grasp-v0"


def _python(code: str, **env) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120, env={**os.environ, **env})


def test_import_piezotip_does_not_import_gymnasium():
    result = _python("import sys, piezotip; print('gymnasium' in sys.modules)")
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "False"


@pytest.mark.parametrize("first", ["piezotip", "gymnasium"])
def test_registered_whichever_is_imported_first(first):
    assert registered_entry_point(ENV_ID, first) == "piezotip.gym_env:GraspEnv"


def test_make_and_gymnasium_check_env():
    env = gymnasium.make(ENV_ID, scenario="grasp", overrides={"duration_s": 1.0}, preset="fast")
    assert isinstance(env.unwrapped, GraspEnv)
    # Rendering needs MUJOCO_GL=egl before MuJoCo's first import in this process: checked with
    # check_env's render check in a process of its own (test_render_rgb_array_...).
    check_env(env.unwrapped, skip_render_check=True)
    env.close()


def test_observation_holds_only_what_the_robot_senses():
    env = GraspEnv(preset="fast")
    obs, _ = env.reset(seed=0)
    truth = ("object", "mass", "contact", "true", "table", "finger_force", "pose", "friction")
    assert not [key for key in obs for word in truth if word in key]
    assert set(obs) == set(env.observation_space.spaces)
    assert env.observation_space.contains(obs)


def _scripted_actions(env: GraspEnv, grip_n: float, lift_after_s: float, open_after_s: float | None = None):
    """An open-loop grasp: close at 0.1 m/s with ``grip_n``, lift at 0.1 m/s after ``lift_after_s``
    for 0.5 s, open at 0.2 m/s after ``open_after_s`` (never if None)."""
    lowest = np.zeros(len(env.pads), np.int64)

    def action(t):
        opening = -0.1
        lift = 0.1 if lift_after_s <= t < lift_after_s + 0.5 else 0.0
        grip = grip_n
        if open_after_s is not None and t >= open_after_s:
            opening, grip = 0.2, 1.0
        return {"grip_force_n": [grip], "opening_velocity_m_s": [opening], "lift_velocity_m_s": [lift], "mode": lowest}

    return action


def _episode(env, seed, policy, steps=None):
    obs, info = env.reset(seed=seed)
    observations, rewards, infos = [obs], [], []
    for _ in range(steps or 10**9):
        obs, reward, terminated, truncated, info = env.step(policy(float(obs["time_s"][0])))
        observations.append(obs)
        rewards.append(reward)
        infos.append(info)
        if terminated or truncated:
            break
    return observations, rewards, infos


def test_a_seeded_episode_repeats_exactly_and_the_seed_matters():
    env = GraspEnv(preset="fast", randomize_object=True)
    policy = _scripted_actions(env, grip_n=3.0, lift_after_s=0.6)
    first = _episode(env, 7, policy, steps=200)
    object_first = env.config.object
    again = _episode(env, 7, policy, steps=200)
    assert env.config.object == object_first
    for a, b in zip(first[0], again[0], strict=True):
        for key in a:
            np.testing.assert_array_equal(a[key], b[key])
    assert first[1] == again[1]
    other = _episode(env, 8, policy, steps=200)
    assert env.config.object != object_first
    assert not np.array_equal(first[0][5]["amplitude"], other[0][5]["amplitude"])  # another readout noise
    ranges = ObjectRanges()
    for obj in (object_first, env.config.object):
        assert ranges.mass_kg[0] <= obj.mass_kg <= ranges.mass_kg[1]
        assert ranges.size_m[0] <= obj.size_m <= ranges.size_m[1]
        assert ranges.friction[0] <= obj.friction <= ranges.friction[1]
        assert ranges.crush_force_n[0] <= obj.crush_force_n <= ranges.crush_force_n[1]


def test_random_objects_are_drawn_within_what_a_mounted_gripper_takes(tmp_path):
    """A mounted gripper's pads may open narrower than the house's 90 mm (robosuite's Panda takes
    64 mm; this slide gripper 67 mm): the default ranges' sizes are cut there, so that no reset
    draws an object the mount refuses (one in five of the defaults' 20-80 mm did, a ValueError
    out of ``reset``); ranges the user gave that reach past it are refused when the environment
    is made, naming the size."""
    from test_third_party_grippers import keys, write_gripper

    overrides = keys(write_gripper(tmp_path))
    env = GraspEnv(overrides=overrides, preset="fast", randomize_object=True)
    assert env.object_ranges.size_m == pytest.approx((0.02, 0.067))
    sizes = []
    for seed in range(20):
        env.reset(seed=seed)
        sizes.append(env.config.object.size_m)
    assert max(sizes) <= 0.067 < ObjectRanges().size_m[1]
    with pytest.raises(ValueError, match=r"ObjectRanges.size_m \(0.02, 0.08\) reaches past the widest object this gripper takes, 0.067 m"):
        GraspEnv(overrides=overrides, preset="fast", randomize_object=ObjectRanges())
    assert GraspEnv(preset="fast", randomize_object=True).object_ranges == ObjectRanges()  # the house takes 85 mm


def test_the_multimode_policy_records_what_run_records_and_earns_its_outcome(tmp_path):
    report, data = run_scenario("grasp", [], tmp_path, plot=False, quiet=True, preset="fast")
    env = gymnasium.make(ENV_ID, preset="fast")
    policy = MultimodePolicy.for_env(env)
    obs, _ = env.reset(seed=0)  # run_sim.py run's readout noise (sensor.seed = 0)
    steps, parts = 0, {}
    while True:
        obs, _, terminated, truncated, info = env.step(policy(obs))
        steps += 1
        for key in info:
            if key.startswith("reward_"):
                parts[key] = parts.get(key, 0.0) + info[key]
        if terminated or truncated:
            break
    record = env.unwrapped.recording()
    n = report["steps"]
    assert n == data["time_s"].size < steps
    for column, values in data.items():
        if column != "phase":  # the agent has no phases
            np.testing.assert_array_equal(record[column][:n], values, err_msg=column)
    cfg = env.unwrapped.config
    verdict = judge({k: v[:n] for k, v in record.items()}, cfg.controller.lift_height_m, cfg.controller.hold_s, None, report["events"])
    assert (verdict.outcome, verdict.reason) == (report["outcome"], report["reason"]) == ("success", verdict.reason)
    assert truncated and not terminated and steps == env.unwrapped.total_steps
    assert info["outcome"] == "success" and info["reward_success"] == env.unwrapped.weights.success
    # The hold reward stops at the hold time (held 1.26 s of the 1 s asked), and the grip's cost
    # is its excess over 1.25 m g / (2 mu) = 0.613 N, over the fingers' 100 N, per second.
    w, dt = env.unwrapped.weights, cfg.physics.control_period_s
    assert parts["reward_hold"] == pytest.approx(w.hold_per_s * cfg.controller.hold_s, abs=0.5 * dt)
    grip = np.maximum(record["left_finger_force_n"], record["right_finger_force_n"])
    need = 1.25 * 0.1 * 9.81 / (2 * 1.0)
    assert parts["reward_grip"] == pytest.approx(-np.sum(np.clip(grip - need, 0, None)) / 100.0 * dt, rel=1e-9)
    assert parts["reward_crush"] == parts["reward_drop"] == 0.0


def test_crushing_ends_the_episode_as_the_referee_judges_it():
    env = GraspEnv(overrides={"object.crush_force_n": 0.5}, preset="fast")
    _, rewards, infos = _episode(env, 0, _scripted_actions(env, grip_n=5.0, lift_after_s=5.0))
    info = infos[-1]
    assert info["ended"] == "crushed" and info["outcome"] == "crushed"
    assert info["reward_crush"] == -env.weights.crush
    cfg = env.config
    assert judge(env.recording(), cfg.controller.lift_height_m, cfg.controller.hold_s, 0.5).outcome == "crushed"
    grip = np.maximum(env.recording()["left_finger_force_n"], env.recording()["right_finger_force_n"])
    assert grip[-1] > 0.5 and np.all(grip[:-1] <= 0.5)  # ended at the first crushing step
    for reward, step_info in zip(rewards, infos, strict=True):
        parts = [v for k, v in step_info.items() if k.startswith("reward_")]
        assert reward == pytest.approx(sum(parts), abs=1e-12)


def test_letting_go_in_the_air_is_a_drop_and_lifting_earns_the_lift_reward():
    env = GraspEnv(preset="fast")
    _, _, infos = _episode(env, 0, _scripted_actions(env, grip_n=3.0, lift_after_s=0.6, open_after_s=1.4))
    info = infos[-1]
    assert info["ended"] == "dropped" and info["outcome"] == "dropped"
    assert info["reward_drop"] == -env.weights.drop
    assert sum(i["reward_lift"] for i in infos) > 0.0  # carried before it fell
    cfg = env.config
    assert judge(env.recording(), cfg.controller.lift_height_m, cfg.controller.hold_s, None).outcome == "dropped"


def test_truncation_at_the_scenarios_duration():
    env = GraspEnv(overrides=["duration_s=0.2"], preset="fast")
    _, _, infos = _episode(env, 0, _scripted_actions(env, grip_n=1.0, lift_after_s=9.0))
    assert len(infos) == env.total_steps == 40
    assert infos[-1]["ended"] == "duration" and "outcome" in infos[-1]


def _cli_error(capsys, argv) -> str:
    assert cli.main(argv) == 2
    return capsys.readouterr().err.strip().removeprefix("error: ")


def test_unknown_scenario_or_override_is_the_command_lines_error(capsys):
    with pytest.raises(ValueError) as err:
        gymnasium.make(ENV_ID, scenario="grasp-everything")
    assert str(err.value) == _cli_error(capsys, ["run", "grasp-everything"])
    with pytest.raises(ValueError) as err:
        gymnasium.make(ENV_ID, overrides={"object.weight": 1})
    assert str(err.value) == _cli_error(capsys, ["run", "grasp", "--set", "object.weight=1"])


def test_actions_are_clipped_or_refused_as_documented():
    env = GraspEnv(preset="fast")
    env.reset(seed=0)
    ok = {"grip_force_n": [1e6], "opening_velocity_m_s": [-1e6], "lift_velocity_m_s": [1e6], "mode": [0, 0]}
    obs, *_ = env.step(ok)
    fingers = env.sim.model.actuator("fingers_actuator").id
    assert env.sim.model.actuator_forcerange[fingers, 1] == env.finger_force_limit_n == 100.0
    assert obs["opening_setpoint_m"][0] == env.opening_range_m[0] and obs["lift_setpoint_m"][0] == env.lift_range_m[1]
    bad = [
        {**ok, "grip_force_n": [np.nan]},
        {**ok, "mode": [0, 4]},
        {**ok, "mode": [0]},
        {k: v for k, v in ok.items() if k != "mode"},
        {**ok, "torque": [1.0]},
    ]
    for action in bad:
        with pytest.raises(ValueError, match="action"):
            env.step(action)


def test_async_vector_env_runs_two_environments():
    envs = gymnasium.vector.AsyncVectorEnv([lambda: gymnasium.make(ENV_ID, overrides={"duration_s": 0.1}, preset="fast")] * 2)
    obs, _ = envs.reset(seed=[0, 1])
    assert obs["time_s"].shape == (2, 1)
    hold = {
        "grip_force_n": np.ones((2, 1)),
        "opening_velocity_m_s": np.zeros((2, 1)),
        "lift_velocity_m_s": np.zeros((2, 1)),
        "mode": np.zeros((2, 2), np.int64),
    }
    ends = 0
    for _ in range(25):  # 20 steps to the 0.1 s duration, then the vector env resets both
        obs, _, _, truncated, _ = envs.step(hold)
        ends += int(np.sum(truncated))
    envs.close()
    assert ends == 2
    assert not np.array_equal(obs["amplitude"][0], obs["amplitude"][1])  # two seeds, two noises


def test_render_rgb_array_and_no_display_names_mujoco_gl():
    code = (
        "import gymnasium, piezotip; from gymnasium.utils.env_checker import check_env; "
        "env = gymnasium.make('piezotip/Grasp-v0', overrides={'duration_s': 0.5}, preset='fast', render_mode='rgb_array', "
        "width=320, height=240); check_env(env.unwrapped); "
        "env.reset(seed=0); img = env.render(); print(img.shape, img.dtype, int(img.std() > 5))"
    )
    result = _python(code, MUJOCO_GL="egl")
    if result.returncode != 0 and "MUJOCO_GL" in result.stderr:
        pytest.skip(f"no EGL here: {result.stderr.strip().splitlines()[-1]}")
    assert result.stdout.strip() == "(240, 320, 3) uint8 1", result.stderr
    failed = _python(code, MUJOCO_GL="glfw", DISPLAY="")
    assert failed.returncode != 0
    last = failed.stderr.strip().splitlines()[-1]
    assert "RendererUnavailable" in last and "MUJOCO_GL='glfw'" in last


def test_events_of_the_policy_are_the_controllers(tmp_path):
    """The wrapped controller is the command line's: its events are those ``run`` reports."""
    report, _ = run_scenario("grasp", ["duration_s=3.0"], tmp_path, plot=False, quiet=True, preset="fast")
    env = GraspEnv(overrides={"duration_s": 3.0}, preset="fast")
    policy = MultimodePolicy(overrides={"duration_s": 3.0}, preset="fast")
    obs, _ = env.reset(seed=0)
    truncated = terminated = False
    while not (terminated or truncated):
        obs, _, terminated, truncated, _ = env.step(policy(obs))
    events = [asdict(e) for e in policy.controller.events]
    assert [(e["time_s"], e["kind"], e["message"]) for e in events] == [(e["time_s"], e["kind"], e["message"]) for e in report["events"]]


def test_piezotip_import_registers_in_this_process_too():
    assert piezotip.gym_registration.ENV_ID in gymnasium.registry


def test_the_episodes_verdict_reads_the_need_on_the_contacts_as_run_does(tmp_path):
    """The raspberry in robosuite's Rethink gripper, pinched above its centre (the multimode
    grip tilts its contacts ~17 degrees): the episode's verdict needs m g / sum tan(phi - a), as
    ``run``'s does (the
    simulated object's friction handed to the referee), not the level m g / 2 mu.  Before: the
    environment judged without the friction, on the level need, 1.6x lower."""
    from piezotip.analysis.run_report import object_needed_grip_n
    from piezotip.reports.gripper_tables import _object_keys, grippers

    if "Rethink" not in grippers():
        pytest.skip("robosuite is not installed (pip install -e .[grippers])")
    overrides = {**_object_keys("raspberry-4g"), **grippers()["Rethink"], "controller.kind": "multimode"}
    report, _ = run_scenario("grasp", [f"{k}={v}" for k, v in overrides.items()], tmp_path, plot=False, quiet=True, preset="fast")
    assert report["outcome"] == "success" and report["contact_tilt_deg"] > 5.0, report["reason"]
    env = gymnasium.make(ENV_ID, preset="fast", overrides=overrides)
    policy = MultimodePolicy.for_env(env)
    obs, _ = env.reset(seed=0)
    while True:
        obs, _, terminated, truncated, info = env.step(policy(obs))
        if terminated or truncated:
            break
    verdict = env.unwrapped.verdict()
    assert verdict.outcome == report["outcome"]
    assert verdict.needed_grip_n == pytest.approx(report["needed_grip_n"], rel=1e-6)
    assert verdict.needed_grip_n > 1.2 * object_needed_grip_n(env.unwrapped.sim.model)  # the level need, below it
    assert info["verdict"]["needed_grip_n"] == verdict.needed_grip_n  # the last step's info: the same verdict
