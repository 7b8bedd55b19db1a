"""Train Stable-Baselines3's PPO on ``piezotip/GraspFlat-v0`` (docs/gym.md).

    pip install -e '.[rl]'                     # stable-baselines3 and PyTorch
    python examples/train_ppo.py --steps 4096
    python examples/train_ppo.py --steps 256 --set duration_s=0.5    # a quick check

It prints the mean return of the episodes that ended while training and of a few episodes of
the trained policy (deterministic).  A few thousand steps show that the pieces fit together;
they do not teach a grasp (the house controller's takes some 1100 steps of 5 ms, one episode).
"""

from __future__ import annotations

import argparse
import sys


def positive_int(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a positive whole number, got {text!r}")
    return value


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=positive_int, default=4096, help="environment steps to train for (default 4096)")
    parser.add_argument("--scenario", default="grasp", help="a registered scenario (run_sim.py list; default grasp)")
    parser.add_argument("--preset", default="fast", help="fast, balanced, accurate or reference (default fast)")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="a scenario override, as --set of run_sim.py")
    parser.add_argument("--seed", type=int, default=0, help="seeds PPO and the environment (default 0)")
    parser.add_argument("--eval-episodes", type=positive_int, default=3, help="episodes of the trained policy to average (default 3)")
    args = parser.parse_args(argv)
    try:
        from stable_baselines3 import PPO
        from stable_baselines3.common.evaluation import evaluate_policy
        from stable_baselines3.common.monitor import Monitor
    except ImportError as err:
        install = "pip install -e '.[rl]' (the 'rl' extra) or pip install stable-baselines3"
        print(f"train_ppo.py needs stable-baselines3, which is not installed ({err}): {install}", file=sys.stderr)
        return 2
    import gymnasium
    import numpy as np

    import piezotip  # noqa: F401 - registers piezotip/GraspFlat-v0

    def make_env():
        return Monitor(gymnasium.make("piezotip/GraspFlat-v0", scenario=args.scenario, overrides=args.set, preset=args.preset))

    try:
        env = make_env()
    except ValueError as err:  # an unknown scenario, preset or override: the command line's message
        parser.error(str(err))
    # One rollout of at most PPO's default 2048 steps, so that a short run still updates.
    n_steps = min(2048, args.steps)
    model = PPO("MlpPolicy", env, n_steps=n_steps, batch_size=min(64, n_steps), seed=args.seed, device="cpu")
    model.learn(total_timesteps=args.steps)
    trained = env.get_episode_rewards()
    if trained:
        print(f"training: {model.num_timesteps} steps, {len(trained)} episodes ended, mean episode return {np.mean(trained):.4g}")
    else:
        print(f"training: {model.num_timesteps} steps, no episode ended")
    eval_env = make_env()
    returns, lengths = evaluate_policy(model, eval_env, n_eval_episodes=args.eval_episodes, deterministic=True, return_episode_rewards=True)
    print(
        f"trained policy: mean episode return {np.mean(returns):.4g} (std {np.std(returns):.3g}) over {len(returns)} episodes "
        f"of {np.mean(lengths):.0f} steps on average"
    )
    env.close()
    eval_env.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
