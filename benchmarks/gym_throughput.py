"""Throughput of the Gymnasium environment: environment steps per second, one and two environments.

    python -m benchmarks.gym_throughput [--steps N] [--preset NAME]

Four numbers per preset: one environment driven by a constant action (the fingers and lift held
at home: the environment's own cost), one driven by the multimode controller wrapped as a policy
(:class:`piezotip.gym_env.MultimodePolicy`, the policy's cost included), and the same two with
two environments in ``gymnasium.vector.AsyncVectorEnv`` (worker processes; the policies run in
the main process).  An environment step is one 5 ms control period of one environment, so a
vector step of two environments counts two.  Episodes end and reset as they come (the
``grasp`` scenario truncates at 12 s = 2400 steps), resets included in the time.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np


def _hold_action(env) -> dict:
    """The action that keeps the set-points where they are, the grip at the fingers' free-motion
    guard (nothing squeezed), the lowest mode."""
    space = env.single_action_space if hasattr(env, "single_action_space") else env.action_space
    n = space["mode"].nvec.size
    return {
        "grip_force_n": np.array([1.0]),
        "opening_velocity_m_s": np.array([0.0]),
        "lift_velocity_m_s": np.array([0.0]),
        "mode": np.zeros(n, np.int64),
    }


def _batch(actions: list[dict]) -> dict:
    return {k: np.stack([a[k] for a in actions]) for k in actions[0]}


def measure(preset: str | None, steps: int, policy: bool, n_envs: int) -> float:
    """Environment steps per second of ``n_envs`` environments (1: no vector wrapper)."""
    import gymnasium

    import piezotip  # noqa: F401  (registers the environment)
    from piezotip.gym_env import MultimodePolicy

    if n_envs == 1:
        env = gymnasium.make("piezotip/Grasp-v0", preset=preset)
        pol = MultimodePolicy.for_env(env) if policy else None
        hold = _hold_action(env)
        obs, _ = env.reset(seed=0)
        start = time.perf_counter()
        for _ in range(steps):
            obs, _, terminated, truncated, _ = env.step(pol(obs) if pol else hold)
            if terminated or truncated:
                obs, _ = env.reset()
        elapsed = time.perf_counter() - start
        env.close()
        return steps / elapsed
    envs = gymnasium.vector.AsyncVectorEnv([lambda: gymnasium.make("piezotip/Grasp-v0", preset=preset) for _ in range(n_envs)])
    pols = [MultimodePolicy(preset=preset) for _ in range(n_envs)] if policy else None
    hold = _batch([_hold_action(envs)] * n_envs)
    obs, _ = envs.reset(seed=0)
    vector_steps = max(1, steps // n_envs)
    start = time.perf_counter()
    for _ in range(vector_steps):
        if pols:
            action = _batch([p({k: v[i] for k, v in obs.items()}) for i, p in enumerate(pols)])
        else:
            action = hold
        obs, *_ = envs.step(action)
    elapsed = time.perf_counter() - start
    envs.close()
    return vector_steps * n_envs / elapsed


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=4000, help="environment steps per measurement (default 4000)")
    parser.add_argument("--preset", action="append", help="fidelity preset(s) (default: fast and the scenario's own)")
    args = parser.parse_args(argv)
    if args.steps < 1:
        parser.error(f"--steps must be at least 1, got {args.steps}")
    presets = args.preset or ["fast", None]
    rows = []
    for preset in presets:
        for policy in (False, True):
            for n_envs in (1, 2):
                rate = measure(preset, args.steps, policy, n_envs)
                rows.append({"preset": preset or "balanced", "driver": "multimode policy" if policy else "constant action", "envs": n_envs})
                rows[-1]["env_steps_per_s"] = round(rate)
                print(json.dumps(rows[-1]), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
