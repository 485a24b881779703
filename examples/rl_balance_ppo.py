"""Train PPO (Stable-Baselines3) on paa_mj/GymnastBalance-v1 and report its success rate.

    pip install "paa_mj[gym,rl]"
    python examples/rl_balance_ppo.py                      # the full size: some minutes on 2 cores
    python examples/rl_balance_ppo.py --timesteps 512 --envs 2 --eval-episodes 4     # seconds (as the tests run it)
    python examples/rl_balance_ppo.py --robot acrobot --goal stretched --torque-limit 20     # another robot and goal

The environments are stepped together by the package's vector environment (``gym.make_vec``: one compiled
call steps all of them), seen by Stable-Baselines3 through the small :class:`VectorEnvForSB3` below.

A success is the package's (``info["is_success"]`` at the end of an episode): no divergence and the true
state inside region (68) of UDD throughout the last second. The evaluation runs ``--eval-episodes``
episodes from the seeds 10000, 10001, ... (starts the training never saw), the policy deterministic.
The trained model is saved (``--out``) and runs in every command through
:class:`paa_mj.envs.policy.SB3Policy`::

    # mine.py
    from paa_mj.envs.policy import SB3Policy

    class Balance(SB3Policy):
        path = "out/ppo_balance.zip"

    # paa-mj simulate --controller mine.py:Balance --x0 0.03 -3.1 0 0 0 0 --t-final 10
"""
import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

#: The seed of the first evaluation episode.
EVAL_SEED = 10_000


def make_adapter():
    """:class:`VectorEnvForSB3`, defined once Stable-Baselines3 is known to be importable."""
    from stable_baselines3.common.vec_env import VecEnv

    class VectorEnvForSB3(VecEnv):
        """A Gymnasium vector environment (autoreset ``SameStep``) as Stable-Baselines3's ``VecEnv``."""

        def __init__(self, envs):
            self.envs = envs
            super().__init__(envs.num_envs, envs.single_observation_space, envs.single_action_space)
            self._returns, self._lengths = np.zeros(envs.num_envs), np.zeros(envs.num_envs, int)

        def reset(self):
            seeds = None if all(s is None for s in self._seeds) else list(self._seeds)
            obs, _ = self.envs.reset(seed=seeds)
            self._reset_seeds()
            self._returns[:], self._lengths[:] = 0.0, 0
            return obs

        def step_async(self, actions):
            self._actions = actions

        def step_wait(self):
            obs, rewards, terminated, truncated, info = self.envs.step(self._actions)
            dones = terminated | truncated
            self._returns += rewards
            self._lengths += 1
            infos = [{} for _ in range(self.num_envs)]
            for i in np.flatnonzero(dones):  # as SB3's vector environments and Monitor report an ended episode
                infos[i] = {"terminal_observation": info["final_obs"][i],
                            "TimeLimit.truncated": bool(truncated[i] and not terminated[i]),
                            "is_success": bool(info["final_info"]["is_success"][i]),
                            "episode": {"r": self._returns[i], "l": int(self._lengths[i]), "t": 0.0}}
                self._returns[i], self._lengths[i] = 0.0, 0
            return obs, rewards.astype(np.float32), dones, infos

        def close(self):
            self.envs.close()

        def get_attr(self, attr_name, indices=None):
            return [getattr(self.envs, attr_name)] * len(self._get_indices(indices))

        def set_attr(self, attr_name, value, indices=None):
            raise NotImplementedError("the sub-environments share one vector environment")

        def env_method(self, method_name, *method_args, indices=None, **method_kwargs):
            raise NotImplementedError("the sub-environments share one vector environment")

        def env_is_wrapped(self, wrapper_class, indices=None):
            return [False] * len(self._get_indices(indices))

    return VectorEnvForSB3


def evaluate(model, episodes, seed=EVAL_SEED, **env_options):
    """Success rate and mean length of ``episodes`` episodes from the seeds ``seed``, ``seed + 1``, ...

    The episodes run side by side in one vector environment: sub-environment i is seeded as
    ``gym.make(BALANCE_ID, **env_options).reset(seed=seed + i)`` would be, and only its first episode counts.
    """
    import gymnasium as gym

    from paa_mj.envs import BALANCE_ID

    envs = gym.make_vec(BALANCE_ID, num_envs=episodes, **env_options)
    obs, _ = envs.reset(seed=seed)
    success = np.zeros(episodes, bool)
    length = np.zeros(episodes, int)
    running = np.ones(episodes, bool)
    while running.any():
        actions, _ = model.predict(obs, deterministic=True)
        obs, _, terminated, truncated, info = envs.step(actions)
        length += running
        ended = running & (terminated | truncated)
        success[ended] = info["is_success"][ended]
        running &= ~ended
    envs.close()
    return success, length


class OneLineParser(argparse.ArgumentParser):
    """Bad arguments: one line on stderr and exit 2, without the usage text."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see --help)\n")


def main(argv=None):
    parser = OneLineParser(prog="rl_balance_ppo.py", description=__doc__.splitlines()[0])
    parser.add_argument("--timesteps", type=int, default=1_000_000, help="environment steps of training")
    parser.add_argument("--robot", default="gymnast", help="a named robot (paa-mj simulate --help) or an MJCF file")
    parser.add_argument("--goal", default="folded", choices=("folded", "stretched"), help="the task's goal")
    parser.add_argument("--torque-limit", type=float,
                        help="the torque limit [N m] (default: the balance task's, 0.1 b1 / 1 rad, capped by the model)")
    parser.add_argument("--envs", type=int, default=16, help="environments stepped together while training")
    parser.add_argument("--eval-episodes", type=int, default=100, help="episodes of the evaluation")
    parser.add_argument("--seed", type=int, default=0, help="seed of the training (>= 0)")
    parser.add_argument("--threads", type=int, default=1, help="torch threads (1 is fastest for this small network)")
    parser.add_argument("--verbose", action="store_true", help="SB3's progress table (episode length, return)")
    parser.add_argument("--out", default="out/ppo_balance.zip", help="where the trained model is saved")
    args = parser.parse_args(argv)
    for name in ("timesteps", "envs", "eval_episodes", "threads"):
        if getattr(args, name) < 1:
            parser.error(f"--{name.replace('_', '-')} must be >= 1")
    if args.seed < 0:
        parser.error("--seed must be >= 0")

    from paa_mj.envs.policy import require_sb3
    from paa_mj.errors import PaaError

    try:
        require_sb3()
    except PaaError as err:
        sys.exit(f"rl_balance_ppo.py: {err}")
    import gymnasium as gym
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecNormalize

    from paa_mj.envs import BALANCE_ID

    torch.set_num_threads(args.threads)
    start_wall, start_cpu = time.perf_counter(), time.process_time()
    env_options = {"robot": args.robot, "task": args.goal}
    if args.torque_limit is not None:
        env_options["torque_limit"] = args.torque_limit
    try:
        vector = gym.make_vec(BALANCE_ID, num_envs=args.envs, autoreset_mode="SameStep", **env_options)
    except (PaaError, ValueError) as err:
        sys.exit(f"rl_balance_ppo.py: error: {err}")
    env = make_adapter()(vector)
    # Returns scaled to about 1 for the learner only (the observations are left alone, so the saved model needs
    # nothing but itself): a return reaches ~900 when the robot stays up, and unscaled value errors of that size
    # would dominate the gradient that PPO clips (one norm for policy and value).
    env = VecNormalize(env, norm_obs=False, norm_reward=True, gamma=0.99)
    # rollouts of n_steps per environment, smaller at small sizes so that --timesteps is roughly what is run
    n_steps = max(16, min(256, args.timesteps // args.envs))
    model = PPO("MlpPolicy", env, n_steps=n_steps, batch_size=min(256, n_steps * args.envs), n_epochs=10,
                gamma=0.99, gae_lambda=0.95, learning_rate=3e-4, policy_kwargs=dict(log_std_init=-1.0),
                seed=args.seed, device="cpu", verbose=int(args.verbose))
    model.learn(total_timesteps=args.timesteps)
    train_wall, train_cpu = time.perf_counter() - start_wall, time.process_time() - start_cpu
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    model.save(args.out)
    env.close()

    success, length = evaluate(model, args.eval_episodes, **env_options)
    result = {"success_rate": float(success.mean()), "successes": int(success.sum()), "episodes": len(success),
              "mean_length": float(length.mean()), "timesteps": int(model.num_timesteps), "envs": args.envs,
              "robot": args.robot, "goal": args.goal,
              "train_wall_s": round(train_wall, 1), "train_cpu_s": round(train_cpu, 1), "model": args.out}
    print(f"success rate {result['success_rate']:.2f} ({result['successes']} of {result['episodes']} episodes from"
          f" seeds {EVAL_SEED}..{EVAL_SEED + len(success) - 1}), mean length {result['mean_length']:.0f} of 1000"
          f" steps; trained {result['timesteps']} steps in {train_wall:.0f} s wall, {train_cpu:.0f} CPU-s;"
          f" model saved to {args.out}")
    print(json.dumps(result))
    return result


if __name__ == "__main__":
    main()
