"""Train PPO (Stable-Baselines3) on paa_mj/GymnastBalance-v1 and report its success rate.

    pip install "paa_mj[gym,rl]"
    python examples/rl_balance_ppo.py                      # 300k steps: some minutes on a laptop
    python examples/rl_balance_ppo.py --timesteps 2000     # seconds (as the tests run it)

A success is the package's (``info["is_success"]`` at the end of an episode): no divergence and the true
state inside region (68) of UDD throughout the last second. The trained model is saved (``--out``) and
runs in every command through :class:`paa_mj.control.policy.SB3Policy`::

    # mine.py
    from paa_mj.control.policy import SB3Policy

    class Balance(SB3Policy):
        path = "out/ppo_balance.zip"

    # paa-mj simulate --controller mine.py:Balance --x0 0.03 -3.1 0 0 0 0 --t-final 10
"""
import argparse
import sys
from pathlib import Path


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--timesteps", type=int, default=300_000, help="environment steps of training")
    parser.add_argument("--envs", type=int, default=8, help="environments stepped together while training")
    parser.add_argument("--eval-episodes", type=int, default=20, help="episodes of the evaluation")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default="out/ppo_balance.zip", help="where the trained model is saved")
    args = parser.parse_args(argv)
    for name in ("timesteps", "envs", "eval_episodes"):
        if getattr(args, name) < 1:
            parser.error(f"--{name.replace('_', '-')} must be >= 1")

    from paa_mj.control.policy import require_sb3
    from paa_mj.errors import PaaError

    try:
        require_sb3()
    except PaaError as err:
        sys.exit(f"rl_balance_ppo.py: {err}")
    import gymnasium as gym
    from stable_baselines3 import PPO
    from stable_baselines3.common.env_util import make_vec_env

    from paa_mj.gym_env import BALANCE_ID

    # small rollouts at small sizes, so that --timesteps is roughly what is run
    n_steps = max(16, min(1024, args.timesteps // args.envs))
    env = make_vec_env(BALANCE_ID, n_envs=args.envs, seed=args.seed)
    model = PPO("MlpPolicy", env, n_steps=n_steps, batch_size=min(256, n_steps * args.envs), seed=args.seed,
                device="cpu", verbose=0)
    model.learn(total_timesteps=args.timesteps)
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    model.save(args.out)
    env.close()

    evaluation = gym.make(BALANCE_ID)
    successes, lengths = 0, []
    for episode in range(args.eval_episodes):
        obs, info = evaluation.reset(seed=10_000 + episode)  # starts the training never saw
        done, steps = False, 0
        while not done:
            action, _ = model.predict(obs, deterministic=True)
            obs, _, terminated, truncated, info = evaluation.step(action)
            done, steps = terminated or truncated, steps + 1
        successes += bool(info["is_success"])
        lengths.append(steps)
    evaluation.close()
    rate = successes / args.eval_episodes
    print(f"success rate {rate:.2f} ({successes} of {args.eval_episodes} episodes), mean length"
          f" {sum(lengths) / len(lengths):.0f} of {evaluation.spec.max_episode_steps} steps; model saved to {args.out}")
    return rate


if __name__ == "__main__":
    main()
