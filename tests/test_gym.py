"""The Gymnasium environments: v0 (checker, seeding, determinism, the paper's controller as a policy), the v1 tasks
(defaults, success, rewards, termination), the vector environment against single ones bit for bit, a trained
policy as a controller (a stand-in for a Stable-Baselines3 model); the PPO example is in test_examples.py."""
import numpy as np
import pytest

gym = pytest.importorskip("gymnasium")

from gymnasium.utils.env_checker import check_env  # noqa: E402
from gymnasium.vector import AutoresetMode, SyncVectorEnv  # noqa: E402

from paa_mj import envs  # noqa: E402
from paa_mj.control import make_controller  # noqa: E402
from paa_mj.task import Task  # noqa: E402
from paa_mj.envs import BALANCE_ID, ENV_ID, KIP_ID, GymnastEnv, GymnastKipEnv  # noqa: E402
from paa_mj.envs.vector import GymnastVectorEnv  # noqa: E402

from .helpers import cli  # noqa: E402


def test_passes_gymnasiums_checker():
    env = gym.make(f"paa_mj.envs:{ENV_ID}")
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


@pytest.mark.slow  # a kip of 25 s, a step at a time (17 CPU-s); a controller as the policy, quick: the LQR's balance
def test_a_registered_controller_as_the_policy():
    from paa_mj.envs import controller_policy

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


@pytest.mark.slow  # a kip of 30 s, a step at a time (13 CPU-s)
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
    from paa_mj.view.gl import probe

    if probe("egl") and probe("osmesa"):
        pytest.skip("no offscreen GL backend")
    env = GymnastKipEnv(render_mode="rgb_array", width=160, height=120)
    env.reset(seed=0)
    frame = env.render()
    env.close()
    assert frame.shape == (120, 160, 3) and frame.std() > 5


# --- v1: the learning defaults, the tasks, success, rewards --------------------------------------------------

@pytest.mark.parametrize("env_id, task, horizon", [(KIP_ID, "kip", 3000), (BALANCE_ID, "balance", 1000)])
def test_v1_ids_have_learning_defaults_and_a_horizon_wrappers_read(env_id, task, horizon):
    env = gym.make(env_id)
    assert env.spec.max_episode_steps == horizon and _time_limit(env) == horizon
    inner = env.unwrapped
    assert inner.episode == task and inner.task.name == "folded" and inner.frame_skip == 10 and inner.dt == pytest.approx(0.01)
    assert inner.max_steps == horizon  # the env's own truncation agrees with the registered horizon
    assert env.action_space.low.tolist() == [-1, -1] and env.action_space.high.tolist() == [1, 1]
    check_env(inner, skip_render_check=True)
    old = gym.make(ENV_ID).unwrapped  # v0 keeps its defaults
    assert not old.normalize_actions and old.frame_skip == 1 and old.max_steps == 30000


def _time_limit(env):
    """The max_episode_steps of the TimeLimit wrappers around ``env`` (the innermost), or None."""
    found = None
    while isinstance(env, gym.Wrapper):
        found = env._max_episode_steps if isinstance(env, gym.wrappers.TimeLimit) else found
        env = env.env
    return found


def test_the_registered_horizon_is_the_envs_own_at_any_time_step(tmp_path):
    """A robot stepped at 0.5 ms: the registered id truncates at its 30 s (6000 steps of 5 ms), as the env does,
    not at the 3000 steps of the 1 ms models; the vector environment's task lasts as long as its episodes."""
    from paa_mj.model.robot import load_robot

    path = tmp_path / "half.xml"
    text = load_robot("gymnast").xml.replace('timestep="0.001"', 'timestep="0.0005"')
    path.write_text(text)
    env = gym.make(KIP_ID, robot=str(path))
    assert env.unwrapped.max_steps == 6000 and env.spec.max_episode_steps == 6000 and _time_limit(env) == 6000
    envs = gym.make_vec(KIP_ID, num_envs=2, robot=str(path), max_episode_steps=100)
    assert envs.unwrapped.max_steps == 100 and envs.unwrapped.task.horizon == pytest.approx(0.5)
    envs.close()


def test_balance_starts_from_a_uniform_perturbation_of_udd():
    env = GymnastEnv(episode="balance")
    starts = np.array([np.concatenate([info["q"], info["qd"]]) for info in
                       (env.reset(seed=s)[1] for s in range(200))])
    error = starts - [0, -np.pi, 0, 0, 0, 0]
    assert np.all(np.abs(error) <= 0.05) and np.all(np.abs(error).max(axis=0) > 0.045)
    assert abs(error.mean()) < 0.01  # centred


def test_is_success_is_the_package_success_over_every_physics_step():
    """frame_skip 1: every state the env steps through is seen, so the task's success can be recomputed from them."""
    env = GymnastEnv(episode="balance", frame_skip=1, max_episode_seconds=2.5, terminate_margin=np.inf, torque_limit=500.0)
    policy = envs.controller_policy("lqr", env)
    # a start just outside region (68) (d1 = 0.6 rad/s): the last second starts when the LQR brings it in
    obs, info = env.reset(seed=0, options={"x0": [0.05, -np.pi, 0, 0.6, 0, 0]})
    policy.reset()
    states, flags, done = [np.concatenate([info["q"], info["qd"]])], [info["is_success"]], False
    while not done:
        obs, reward, terminated, truncated, info = env.step(policy(obs, info))
        states.append(np.concatenate([info["q"], info["qd"]]))
        flags.append(info["is_success"])
        done = terminated or truncated
    states = np.array(states)
    task = env.task
    inside = task.in_switch_region(states[:, :3], states[:, 3:])
    assert not inside[0] and inside[-1]
    steps = np.arange(len(states))
    outside = ~task.in_success_region(states[:, :3], states[:, 3:])
    books = np.column_stack([np.zeros_like(steps), np.maximum.accumulate(np.where(outside, steps, -1)),
                             np.zeros_like(steps)])
    expected = task.succeeded(books, steps, True, False, 0.001)
    np.testing.assert_array_equal(flags, expected)
    assert flags[-1] and not all(flags)


def test_the_rewards_are_the_documented_formulas():
    for task in ("kip", "balance"):
        env = GymnastEnv(episode=task)
        env.reset(seed=1, options={"x0": [0.03, -np.pi + 0.02, -0.02, 0.01, 0.0, 0.0]})  # near UDD: the 1[(68)] too
        action = np.array([0.3, -0.2] if task == "balance" else [0.02, -0.01], np.float32)  # ~10 N m, both
        _, reward, _, _, info = env.step(action)
        x = env.task.error(info["q"], info["qd"])
        u = env.action_to_torque(action) / env.torque_limits
        alive = float(env.task.in_switch_region(info["q"], info["qd"]))
        if task == "kip":
            expected = alive - x[:3] @ x[:3] / (3 * np.pi**2) - 1e-3 * x[3:] @ x[3:] - 1e-2 * np.mean(u**2)
        else:
            scaled = x / np.array([np.pi / 6] * 3 + [0.5] * 3)
            expected = alive - 0.5 * np.mean(scaled**2) - 0.1 * np.mean(u**2)
        assert alive == 1.0 and reward == pytest.approx(expected, abs=1e-12)


def test_balance_terminates_when_it_leaves_region_68_by_the_margin():
    env = GymnastEnv(episode="balance")
    env.reset(seed=0)
    terminated = truncated = False
    while not (terminated or truncated):  # no torque: it falls
        _, _, terminated, truncated, info = env.step(np.zeros(2, np.float32))
    assert terminated and not truncated and not info["is_success"] and not info["diverged"]
    assert env.task.switch_margin(info["q"], info["qd"]) >= 0.5
    kip = GymnastEnv(episode="kip", max_episode_seconds=0.5)  # the kip leaves region (68) at once: never terminates
    kip.reset(seed=0)
    results = [kip.step(np.zeros(2, np.float32)) for _ in range(50)]
    assert not any(r[2] for r in results) and results[-1][3]


def test_an_episode_cut_short_is_no_success_even_inside_a_wide_success_region():
    """A success region wider than region (68)'s margin: the episode that leaves (68) ends early, unfinished, and
    is no success in either environment, as a run cut short is none for the engines."""
    from paa_mj.task import Region

    wide = Task.named("folded", 3, success_region=Region(2.0, 10.0))
    for env in (GymnastEnv(episode="balance", task=wide), GymnastVectorEnv(num_envs=2, episode="balance", task=wide)):
        env.reset(seed=0)
        push = np.tile([1.0, -1.0], (2, 1)).astype(np.float32)
        action = push if isinstance(env, GymnastVectorEnv) else push[0]
        for _ in range(500):
            _, _, terminated, _, info = env.step(action)
            if np.all(terminated):
                break
        assert np.all(terminated) and not np.any(info["is_success"]) and not np.any(info["diverged"])
        env.close()


def test_the_lqr_balances_every_start_of_the_balance_task():
    env = gym.make(BALANCE_ID)
    policy = envs.controller_policy("lqr", env)
    for seed in range(3):
        obs, info = env.reset(seed=seed)
        policy.reset()
        done, total = False, 0.0
        while not done:
            obs, reward, terminated, truncated, info = env.step(policy(obs, info))
            total += reward
            done = terminated or truncated
        assert truncated and info["is_success"] and total > 990


@pytest.mark.parametrize("kwargs, fragment", [
    (dict(episode="walk"), "episode must be 'kip' or 'balance', got 'walk'"),
    (dict(episode=None), "episode must be 'kip' or 'balance'"),
    (dict(task="kip"), "task='kip' names an episode type: use episode='kip'"),
    (dict(init_speed_noise=-0.1), "init_speed_noise must be a finite number >= 0 [rad/s]"),
    (dict(init_speed_noise=np.nan), "init_speed_noise must be a finite number >= 0"),
    (dict(terminate_margin=-1.0), "terminate_margin must be a number >= 0"),
    (dict(terminate_margin=np.nan), "terminate_margin must be a number >= 0"),
    (dict(terminate_margin="1"), "terminate_margin must be a number, got '1'"),
    (dict(max_episode_seconds=0.001), "shorter than one environment step (0.01 s)"),
])
def test_new_arguments_are_refused_in_one_line(kwargs, fragment):
    with pytest.raises(ValueError) as caught:
        GymnastEnv(**kwargs)
    assert fragment in str(caught.value) and "\n" not in str(caught.value)


# --- the vector environment --------------------------------------------------------------------------------

def _as_given(actions, k):
    """The actions as a user may give them, in turn: float32 (what an agent gives), float64, a list, Fortran order."""
    return [actions, actions.astype(float), actions.tolist(), np.asfortranarray(actions.astype(float))][k % 4]


@pytest.mark.parametrize("num_threads", [1, 2])
@pytest.mark.parametrize("mode", list(AutoresetMode), ids=lambda m: m.value)
def test_the_vector_env_equals_single_envs_bit_for_bit(mode, num_threads):
    """Random actions (some beyond [-1, 1]: clipped), short episodes and a tight margin: terminations, truncations
    and resets in every mode, with the compiled step in one call or split over threads."""
    n, options = 5, dict(episode="balance", max_episode_seconds=0.25, terminate_margin=0.2)
    vector = GymnastVectorEnv(n, autoreset_mode=mode, num_threads=num_threads, **options)
    singles = SyncVectorEnv([lambda: GymnastEnv(**options) for _ in range(n)], autoreset_mode=mode)
    a, info_a = vector.reset(seed=7)
    b, info_b = singles.reset(seed=7)
    np.testing.assert_array_equal(a, b)
    rng, ended, ends = np.random.default_rng(0), np.zeros(n, bool), 0
    for k in range(80):
        if mode == AutoresetMode.DISABLED and ended.any():
            a, _ = vector.reset(options={"reset_mask": ended.copy()})
            b, _ = singles.reset(options={"reset_mask": ended.copy()})
            np.testing.assert_array_equal(a, b)
        actions = rng.uniform(-1.2, 1.2, (n, 2)).astype(np.float32)
        got, want = vector.step(_as_given(actions, k)), singles.step(actions)
        for x, y in zip(got[:4], want[:4]):
            assert x.dtype == y.dtype
            np.testing.assert_array_equal(x, y)
        for key in ("q", "qd", "time", "is_success", "diverged"):
            np.testing.assert_array_equal(got[4][key], want[4][key])
            np.testing.assert_array_equal(got[4]["_" + key], want[4]["_" + key])
        if "final_obs" in want[4]:
            np.testing.assert_array_equal(got[4]["_final_obs"], want[4]["_final_obs"])
            for i in np.flatnonzero(want[4]["_final_obs"]):
                np.testing.assert_array_equal(got[4]["final_obs"][i], want[4]["final_obs"][i])
            for key in ("is_success", "q"):
                np.testing.assert_array_equal(got[4]["final_info"][key], want[4]["final_info"][key])
        ended = got[2] | got[3]
        ends += ended.sum()
    assert ends > 10
    vector.close()


def test_the_vector_env_of_torques_and_of_the_kip_equals_single_envs():
    """v0's torque actions (clipped at the limits, one physics step) and the kip: the same bits as single envs,
    and the arrays a step returns stay the caller's (the next steps do not change them)."""
    for options in (dict(episode="kip", normalize_actions=False, frame_skip=1, torque_limit=50.0), dict(episode="kip")):
        n, torques = 4, not options.get("normalize_actions", True)
        vector = GymnastVectorEnv(n, **options)
        singles = [GymnastEnv(**options) for _ in range(n)]
        first = vector.reset(seed=3)[0]
        np.testing.assert_array_equal(first, [env.reset(seed=3 + i)[0] for i, env in enumerate(singles)])
        rng, kept = np.random.default_rng(1), None
        for k in range(12):
            actions = rng.uniform(-80, 80, (n, 2)) if torques else rng.uniform(-1, 1, (n, 2)).astype(np.float32)
            got = vector.step(actions)
            want = [env.step(a) for env, a in zip(singles, actions)]
            for j in range(4):
                np.testing.assert_array_equal(got[j], [w[j] for w in want])
            for key in ("q", "qd", "time", "diverged", "is_success"):
                np.testing.assert_array_equal(got[4][key], [w[4][key] for w in want])
            if k == 0:
                kept = got, [np.copy(x) for x in got[:4]] + [{key: np.copy(x) for key, x in got[4].items()}]
        for x, y in zip(kept[0][:4], kept[1][:4]):
            np.testing.assert_array_equal(x, y)
        for key, value in kept[1][4].items():
            np.testing.assert_array_equal(kept[0][4][key], value)
        vector.close()


def test_bench_times_the_physics_of_the_same_steps_without_timing_assertions():
    """``physics_only`` (bench's floor) runs the vector environment's steps: from the same reset, the same states."""
    from paa_mj.envs.vector import physics_only
    from paa_mj.studies.bench import vector_env_costs

    vector = GymnastVectorEnv(3, episode="kip")
    actions = np.random.default_rng(0).uniform(-1, 1, (4, 3, 2)).astype(np.float32)
    vector.reset(seed=0)
    for a in actions:
        vector.step(a)
    stepped = np.hstack([vector._robots.q, vector._robots.qd])
    vector.reset(seed=0)
    tau = np.ascontiguousarray(envs.action_to_torque(actions, vector.torque_limits))
    physics = vector._robots.physics
    physics_only(physics.model, physics.addresses, tau, physics.frame_skip)
    np.testing.assert_array_equal(np.hstack([[d.qpos for d in vector._robots.datas],
                                             [d.qvel for d in vector._robots.datas]]), stepped)
    costs = vector_env_costs(n_envs=2, steps=2, repeats=1, frame_skip=1)
    assert set(costs) == {"single", "sync", "vector", "physics", "single_analytic", "vector_analytic"}
    assert all(np.isfinite(c) and c > 0 for c in costs.values())


def test_make_vec_builds_the_compiled_vector_env():
    envs = gym.make_vec(BALANCE_ID, num_envs=3)
    assert isinstance(envs, GymnastVectorEnv) and envs.max_steps == 1000 and envs.num_envs == 3
    assert envs.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    assert envs.observation_space.shape == (3, 9) and envs.action_space.shape == (3, 2)
    obs, info = envs.reset(seed=0)
    assert obs.dtype == np.float32 and info["is_success"].all() and info["_is_success"].all()
    obs, rewards, terminated, truncated, info = envs.step(np.zeros((3, 2), np.float32))
    assert rewards.shape == (3,) and np.all(rewards > 0.5) and info["time"] == pytest.approx([0.01] * 3)
    short = gym.make_vec(KIP_ID, num_envs=2, max_episode_steps=2)
    short.reset(seed=0)
    assert not short.step(np.zeros((2, 2)))[3].any() and short.step(np.zeros((2, 2)))[3].all()


@pytest.mark.parametrize("kwargs, call, fragment", [
    (dict(num_envs=0), None, "num_envs must be in [1, 1000000]"),
    (dict(num_envs=2.5), None, "num_envs must be a whole number"),
    (dict(autoreset_mode="sometimes"), None, "autoreset_mode must be one of NextStep, SameStep, Disabled"),
    (dict(render_mode="rgb_array"), None, "render_mode must be None for the vector environment"),
    (dict(num_threads=0), None, "num_threads must be in [1, 1024]"),
    (dict(frame_skip=0), None, "frame_skip must be in [1, 1000000]"),
    (dict(episode="walk"), None, "episode must be"),
    (dict(max_episode_steps=0), None, "max_episode_steps must be in"),
    ({}, ("step", np.zeros(2)), "actions are two real numbers per sub-environment, shape (2, 2), got shape (2,)"),
    ({}, ("step", [[np.nan, 0], [0, 0]]), "actions must be finite; sub-environment(s) [0]"),
    ({}, ("step", [["a", "b"], ["c", "d"]]), "actions are two real numbers per sub-environment"),
    ({}, ("reset", dict(seed=-1)), "seed must be an integer >= 0"),
    ({}, ("reset", dict(seed=[1])), "a list of 2 of them"),
    ({}, ("reset", dict(options={"x_0": 0})), "unknown reset option(s) x_0"),
    ({}, ("reset", dict(options={"x0": np.zeros((3, 6))})), "options['x0'] must be 6 finite numbers or 2 rows of 6"),
    ({}, ("reset", dict(options={"reset_mask": np.array([1, 0])})), "options['reset_mask'] must be a bool array"),
])
def test_the_vector_env_refuses_what_it_would_misread(kwargs, call, fragment):
    with pytest.raises(ValueError) as caught:
        envs = GymnastVectorEnv(**({"num_envs": 2} | kwargs))
        envs.reset(seed=0)
        before = envs._robots.q.copy()
        if call[0] == "reset":
            envs.reset(**call[1])
        else:
            envs.step(call[1])
    assert fragment in str(caught.value) and "\n" not in str(caught.value), str(caught.value)
    if call is not None:
        np.testing.assert_array_equal(envs._robots.q, before)


def test_the_vector_env_asks_for_reset_first_and_for_resets_when_autoreset_is_off():
    envs = GymnastVectorEnv(2, episode="balance", autoreset_mode="Disabled", max_episode_steps=1)
    with pytest.raises(ValueError, match="call reset"):
        envs.step(np.zeros((2, 2)))
    envs.reset(seed=0)
    assert envs.step(np.zeros((2, 2)))[3].all()
    with pytest.raises(ValueError, match="reset them with"):
        envs.step(np.zeros((2, 2)))


# --- a trained policy as a controller ------------------------------------------------------------------------

STAND_IN = '''
import numpy as np
from paa_mj.control.lqr import LQRController
from paa_mj.envs.policy import SB3Policy
from paa_mj.task import Task


class Linear:
    """A stand-in for a trained model: the LQR (67) read off the observation, in normalised actions."""

    def __init__(self, K, limits):
        self.K, self.limits = K, limits

    def predict(self, obs, deterministic=True):
        obs = np.asarray(obs, float)
        x = np.stack([obs[:, 1], -obs[:, 3], obs[:, 5], obs[:, 6], obs[:, 7], obs[:, 8]], -1)
        return -(x @ self.K.T) / self.limits, None


class Trained(SB3Policy):
    def load_model(self):
        return Linear(LQRController.for_model(self.robot.analytic, Task.named("folded", self.robot)).K,
                      self.torque_limits)


class Saved(SB3Policy):
    path = "ppo_balance.zip"
'''

X0_NEAR_UDD = [0.03, -np.pi + 0.02, -0.02, 0.01, 0.0, 0.0]


@pytest.fixture
def policy_file(tmp_path):
    path = tmp_path / "mine.py"
    path.write_text(STAND_IN)
    return path


def test_a_policy_adapter_runs_as_the_env_runs_it(policy_file, gymnast):
    """The adapter through the package's engine and the same model through the env: the same states."""
    from paa_mj.control.registry import make_controller
    from paa_mj.sim.rollout import simulate_mujoco

    controller = make_controller(f"{policy_file}:Trained", gymnast)
    traj = simulate_mujoco(gymnast, controller, X0_NEAR_UDD, t_final=1.0, sample_dt=0.01)
    env = GymnastEnv(episode="balance", init_noise=0.0, init_speed_noise=0.0)
    obs, info = env.reset(options={"x0": X0_NEAR_UDD})
    states = [np.concatenate([info["q"], info["qd"]])]
    for _ in range(100):
        action, _ = controller.model.predict(obs[None], deterministic=True)
        obs, _, _, _, info = env.step(action[0])
        states.append(np.concatenate([info["q"], info["qd"]]))
    np.testing.assert_allclose(np.hstack([traj.q, traj.qd]), states, rtol=0, atol=1e-12)
    assert np.all(np.abs(traj.tau) <= env.torque_limits)


def test_a_policy_adapter_through_simulate(policy_file, tmp_path, capsys):
    import json

    from paa_mj.cli import main

    code = main(["simulate", "--controller", f"{policy_file}:Trained", "--x0", *map(str, X0_NEAR_UDD),
                 "--t-final", "6", "--json"])
    summary = json.loads(capsys.readouterr().out)
    assert code == 0 and summary["balanced"]


def test_the_analytic_engine_refuses_a_policy_held_over_its_period(policy_file):
    """A policy holds each action for its period: the analytic engine, which integrates continuous laws, would
    re-evaluate it wherever its solver steps, in silence."""
    result = cli("simulate", "--engine", "analytic", "--controller", f"{policy_file}:Trained", "--x0",
                 *map(str, X0_NEAR_UDD), "--t-final", "1")
    assert result.returncode == 2 and result.stderr == (
        "paa-mj: error: the analytic engine integrates laws continuous in time, and mine.py:Trained holds each torque"
        " for 10 ms (a sampled-data controller); use --engine cpu\n")


def test_the_analytic_engine_refuses_a_held_policy_inside_a_switched_controller(policy_file, gymnast):
    from paa_mj.control.combined import CombinedController
    from paa_mj.control.registry import make_controller
    from paa_mj.errors import PaaError
    from paa_mj.sim.analytic.engine import simulate_analytic

    policy = make_controller(f"{policy_file}:Trained", gymnast)
    vcl = make_controller("vcl", gymnast)
    switched = CombinedController(policy, vcl.second, vcl.condition)
    with pytest.raises(PaaError, match="holds each torque for 10 ms"):
        simulate_analytic(gymnast, switched, t_final=0.05)


def test_a_policy_file_without_stable_baselines3_is_one_line(policy_file, capsys):
    try:
        import stable_baselines3  # noqa: F401
    except ImportError:
        pass
    else:
        pytest.skip("stable-baselines3 is installed: the message is for those without it")
    from paa_mj.cli import main

    assert main(["simulate", "--controller", f"{policy_file}:Saved", "--t-final", "1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("paa-mj: error:") and 'pip install "paa_mj[rl]"' in err[0]


def test_the_observation_and_action_maps_are_the_envs():
    env = GymnastEnv(episode="kip")
    obs, info = env.reset(seed=3)
    np.testing.assert_array_equal(envs.observation(info["q"], info["qd"]), obs)
    assert envs.observation(np.zeros((4, 5, 3)), np.zeros(3)).shape == (4, 5, 9)
    actions = np.array([[0.5, -2.0], [1.0, 0.25]])
    np.testing.assert_array_equal(envs.action_to_torque(actions, env.torque_limits),
                                  [env.action_to_torque(a) for a in actions])
    np.testing.assert_allclose(envs.torque_to_action(envs.action_to_torque(actions[1], env.torque_limits),
                                                        env.torque_limits), actions[1], rtol=1e-6)


def test_a_policy_whose_spaces_are_not_the_envs_is_one_line(gymnast):
    from gymnasium import spaces

    from paa_mj.envs.policy import SB3Policy
    from paa_mj.errors import PaaError

    class Model:
        def __init__(self, obs, low, high):
            self.observation_space = spaces.Box(-1, 1, (obs,), np.float32)
            self.action_space = spaces.Box(np.float32(low), np.float32(high), (2,), np.float32)

        def predict(self, obs, deterministic=True):
            return np.zeros((len(obs), 2), np.float32), None

    SB3Policy(gymnast, model=Model(9, -1, 1))  # the v1 environments' spaces
    for model, match in ((Model(6, -1, 1), "observes"), (Model(9, -579, 579), "not in \\[-1, 1\\]")):
        with pytest.raises(PaaError, match=match) as caught:
            SB3Policy(gymnast, model=model)
        assert "\n" not in str(caught.value)


def test_a_policy_adapter_runs_a_chain_as_its_env_runs_it():
    """The adapter on the acrobot at the stretched goal (6 observations, 1 action) through the package's engine
    and the same model through the environment: the same states; a gymnast-shaped model is refused."""
    from gymnasium import spaces

    from paa_mj.control.lqr import LQRController
    from paa_mj.envs.policy import SB3Policy
    from paa_mj.errors import PaaError
    from paa_mj.model.robot import load_robot
    from paa_mj.sim.rollout import simulate_mujoco

    acrobot = load_robot("acrobot")
    K = LQRController.for_model(acrobot.analytic, Task.named("stretched", acrobot)).K

    class Linear:
        def __init__(self, obs, actions, limits):
            self.observation_space = spaces.Box(-np.inf, np.inf, (obs,), np.float32)
            self.action_space = spaces.Box(-1, 1, (actions,), np.float32)
            self.limits = limits

        def predict(self, obs, deterministic=True):
            obs = np.asarray(obs, float)
            x = np.stack([np.arctan2(obs[:, 1], obs[:, 0]), np.arctan2(obs[:, 3], obs[:, 2]), obs[:, 4], obs[:, 5]], -1)
            return -(x @ K.T) / self.limits, None

    class Policy(SB3Policy):
        torque_limit = 20.0

        def load_model(self):
            return Linear(6, 1, self.torque_limits)

    policy = Policy(acrobot)
    x0 = [0.05, -0.04, 0.0, 0.1]
    traj = simulate_mujoco(acrobot, policy, x0, t_final=1.0, task="stretched", sample_dt=0.01)
    env = GymnastEnv(episode="balance", robot="acrobot", task="stretched", torque_limit=20.0, init_noise=0.0,
                     init_speed_noise=0.0)
    obs, info = env.reset(options={"x0": x0})
    states = [np.concatenate([info["q"], info["qd"]])]
    for _ in range(100):
        action, _ = policy.model.predict(obs[None])
        obs, _, _, _, info = env.step(action[0])
        states.append(np.concatenate([info["q"], info["qd"]]))
    np.testing.assert_allclose(np.hstack([traj.q, traj.qd]), states, rtol=0, atol=1e-12)
    assert traj.tau.shape[1] == 1 and np.all(np.abs(traj.tau) <= 20.0) and np.any(traj.tau != 0)
    with pytest.raises(PaaError, match="not the 6 observations of the environments of robot acrobot"):
        SB3Policy(acrobot, model=Linear(9, 2, 1.0))
    with pytest.raises(PaaError, match="not the 1 torques"):
        SB3Policy(acrobot, model=Linear(6, 2, 1.0))


@pytest.mark.parametrize("robot, goal", [("gymnast", "folded"), ("acrobot", "stretched"), ("chain4", "folded")])
def test_the_analytic_physics_steps_as_mujoco_does_to_rounding(robot, goal):
    """physics="analytic" (RK4 of the robot's own equations) against MuJoCo's mj_step: the same episode under the
    same actions, state for state to 1e-9 over a second; and its vector environment equals its single
    environments bit for bit (the same compiled code)."""
    from paa_mj.envs.vector import GymnastVectorEnv

    links = {"gymnast": 3, "acrobot": 2, "chain4": 4}[robot]
    actions = np.random.default_rng(1).uniform(-0.3, 0.3, (100, 3, links - 1)).astype(np.float32)
    states = {}
    for physics in ("mujoco", "analytic"):
        envs = [GymnastEnv(episode="kip", robot=robot, task=goal, physics=physics) for _ in range(3)]
        rows = []
        for i, env in enumerate(envs):
            env.reset(seed=i)
            rows.append([np.r_[info["q"], info["qd"]] for info in (env.step(a[i])[4] for a in actions)])
        states[physics] = np.array(rows)
    assert np.all(np.isfinite(states["analytic"]))
    np.testing.assert_allclose(states["analytic"], states["mujoco"], rtol=0, atol=1e-9)
    assert np.max(np.abs(states["analytic"][:, -1] - states["analytic"][:, 0])) > 0.1  # it moved
    vector = GymnastVectorEnv(3, episode="kip", robot=robot, task=goal, physics="analytic")
    vector.reset(seed=0)
    stepped = np.array([np.hstack([info["q"], info["qd"]]) for info in (vector.step(a)[4] for a in actions)])
    np.testing.assert_array_equal(stepped.transpose(1, 0, 2), states["analytic"])
    vector.close()


def test_an_unknown_physics_is_one_line():
    with pytest.raises(ValueError, match="physics must be 'mujoco' or 'analytic', got 'bullet'"):
        GymnastEnv(physics="bullet")


def test_the_analytic_physics_refuses_a_model_of_another_integrator(tmp_path):
    """It steps RK4: on an Euler model it would silently differ from MuJoCo's steps (5.6e-4 after 200 steps)."""
    from pathlib import Path

    euler = tmp_path / "euler.xml"
    source = (Path(__file__).resolve().parent.parent / "models" / "gymnast.xml").read_text()
    euler.write_text(source.replace('integrator="RK4"', 'integrator="Euler"'))
    with pytest.raises(ValueError, match="physics 'analytic' steps RK4, and this model's integrator is Euler"):
        GymnastEnv(robot=str(euler), physics="analytic")
    GymnastEnv(robot=str(euler))  # MuJoCo's physics steps the model's own integrator
