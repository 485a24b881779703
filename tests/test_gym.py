"""paa_mj/GymnastKip-v0: Gymnasium's checker, seeding, determinism, and the paper's controller as a policy."""
import numpy as np
import pytest

gym = pytest.importorskip("gymnasium")

from gymnasium.utils.env_checker import check_env  # noqa: E402

from paa_mj.control import make_controller  # noqa: E402
from paa_mj.gym_env import ENV_ID, GymnastKipEnv  # noqa: E402


def test_passes_gymnasiums_checker():
    env = gym.make(f"paa_mj.gym_env:{ENV_ID}")
    check_env(env.unwrapped, skip_render_check=True)
    env.close()


def test_normalised_actions_pass_without_the_action_space_warning():
    import warnings

    env = GymnastKipEnv(normalize_actions=True, max_episode_seconds=0.1)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env, skip_render_check=True)
    assert not [w for w in caught if "symmetric and normalized" in str(w.message)]
    assert env.action_space.low.tolist() == [-1, -1] and env.action_space.high.tolist() == [1, 1]
    np.testing.assert_allclose(env.action_to_torque([0.5, -1.0]), [0.5 * env.torque_limit, -env.torque_limit])


def test_a_registered_controller_as_the_policy():
    from paa_mj.gym_env import controller_policy

    env = GymnastKipEnv(normalize_actions=True, init_noise=0.0, max_episode_seconds=25.0)
    policy = controller_policy("vcl", env)
    obs, info = env.reset(seed=0)
    policy.reset()
    truncated = terminated = False
    while not (truncated or terminated):
        obs, reward, terminated, truncated, info = env.step(policy(obs, info))
    assert not terminated and policy.controller.mode == 1 and reward > -1e-6


def test_seeded_and_deterministic():
    def episode(seed):
        env = GymnastKipEnv(max_episode_seconds=0.5)
        obs, _ = env.reset(seed=seed)
        rng = np.random.default_rng(0)
        rewards = []
        for _ in range(200):
            obs, r, term, trunc, _ = env.step(rng.uniform(-50, 50, 2).astype(np.float32))
            rewards.append(r)
        return obs, rewards

    a, b, c = episode(1), episode(1), episode(2)
    np.testing.assert_array_equal(a[0], b[0])
    assert a[1] == b[1]
    assert not np.array_equal(a[0], c[0])


def test_the_papers_controller_balances_through_the_env():
    env = GymnastKipEnv()
    ctrl = make_controller("vcl", env.robot)
    obs, info = env.reset(seed=0)
    total, truncated = 0.0, False
    while not truncated:
        obs, reward, terminated, truncated, info = env.step(ctrl.torque(info["q"], info["qd"]).astype(np.float32))
        assert not terminated
        total += reward
    assert ctrl.mode == 1
    assert reward > -1e-6  # at UDD at the end
    assert np.allclose(obs[:6], [1, 0, -1, 0, 1, 0], atol=1e-3)


def test_divergence_terminates():
    env = GymnastKipEnv()
    env.reset(seed=0, options={"x0": [0, 0, 0, 2e4, 0, 0]})
    _, reward, terminated, truncated, info = env.step(np.zeros(2, np.float32))
    assert terminated and not truncated and info["diverged"]


def test_render_rgb_array():
    from paa_mj.outputs.gl import probe

    if probe("egl") and probe("osmesa"):
        pytest.skip("no offscreen GL backend")
    env = GymnastKipEnv(render_mode="rgb_array", width=160, height=120)
    env.reset(seed=0)
    frame = env.render()
    env.close()
    assert frame.shape == (120, 160, 3) and frame.std() > 5
