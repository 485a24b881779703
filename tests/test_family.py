"""The gymnast's family: planar chains of 2 to 6 links, with damping and armature, read from their MJCF."""
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest

from paa_mj.control import make_controller
from paa_mj.errors import PaaError
from paa_mj.model import chain
from paa_mj.model.crosscheck import cross_check
from paa_mj.model.dynamics import AnalyticModel
from paa_mj.model.mjcf import MODEL_DIR, mjcf_from_params
from paa_mj.model.mjcf_read import compile_mjcf, params_from_model
from paa_mj.model.params import RobotParams
from paa_mj.model.robot import NAMED_ROBOTS, load_robot, model_from_params
from paa_mj.task import Task

from .helpers import cli

ROOT = Path(__file__).resolve().parents[1]
TOL = 1e-9


def random_chain(rng, n, damping=True, armature=True):
    m, l = rng.uniform(0.1, 80, n), rng.uniform(0.1, 3, n)
    return RobotParams(m=m, l=l, lc=rng.uniform(0, 1, n) * l, J=rng.uniform(0.05, 3, n) * m * l**2 / 12,
                       g=rng.uniform(1.0, 20.0), damping=rng.uniform(0, 2, n) if damping else None,
                       armature=rng.uniform(0, 0.5, n) if armature else None)


@pytest.mark.parametrize("n", [2, 3, 4, 5, 6])
def test_engine_equals_the_chain_model_for_random_robots_of_2_to_6_links(n):
    rng = np.random.default_rng(100 + n)
    for k in range(3):
        params = random_chain(rng, n, damping=k != 1, armature=k != 2)
        result = cross_check(model_from_params(params), samples=150, seed=k)
        assert result.worst() < TOL, (n, k, result)


def test_the_chain_formulas_are_the_papers_for_three_links(gymnast, rng):
    """(2)-(7) in closed form and the general chain agree: the same robot, two derivations."""
    A, b = chain.chain_constants(gymnast.params)
    am = gymnast.analytic
    assert am.paper_shape
    assert np.allclose(b, am.beta, rtol=1e-15)
    q, qd = rng.uniform(-7, 7, (40, 3)), rng.uniform(-10, 10, (40, 3))
    assert np.allclose(chain.batch_mass_matrix(A, np.zeros(3), q), am.mass_matrix(q), rtol=1e-13, atol=1e-13)
    assert np.allclose(chain.batch_bias(A, b, q, qd), am.bias(q, qd), rtol=1e-13, atol=1e-10)
    assert np.allclose(chain.batch_bias(A, b, q, 0 * qd), am.gravity(q), rtol=1e-13, atol=1e-12)
    assert np.allclose(chain.batch_gravity_jacobian(b, q), am.gravity_jacobian(q), rtol=1e-13, atol=1e-12)
    assert np.allclose(chain.batch_potential(b, q), am.potential(q), rtol=1e-13, atol=1e-12)


def test_the_small_solver_solves_and_reports_singular_systems():
    rng = np.random.default_rng(3)
    for n in (1, 2, 5):
        matrix, rhs = rng.normal(size=(n, n)), rng.normal(size=(n, 3))
        out = rhs.copy()
        assert chain._solve_in_place(matrix.copy(), out)
        assert np.allclose(out, np.linalg.solve(matrix, rhs), rtol=1e-10)
    assert not chain._solve_in_place(np.array([[1.0, 2.0], [2.0, 4.0]]), np.ones((2, 1)))


def test_damping_enters_the_acceleration_and_the_linearisation():
    rng = np.random.default_rng(5)
    params = random_chain(rng, 3, damping=True, armature=False)
    am = AnalyticModel.from_params(params)
    assert not am.paper_shape
    q, qd, tau = rng.normal(size=3), rng.normal(size=3), rng.normal(size=2)
    undamped = AnalyticModel.from_params(RobotParams(m=params.m, l=params.l, lc=params.lc, J=params.J, g=params.g))
    difference = am.acceleration(q, qd, tau) - undamped.acceleration(q, qd, tau)
    assert np.allclose(difference, -np.linalg.solve(am.mass_matrix(q), params.damping * qd), rtol=1e-10)
    A, B = am.linearize(np.zeros(3))
    assert np.allclose(A[3:, 3:], -np.linalg.solve(am.mass_matrix(np.zeros(3)), np.diag(params.damping)))
    assert B.shape == (6, 2)


@pytest.mark.parametrize("name, links", [("gymnast", 3), ("example2", 3), ("acrobot", 2), ("chain4", 4)])
def test_named_robots_live_in_models_at_the_top_level(name, links):
    robot = load_robot(name)
    assert robot.params.n_links == links
    assert robot.torque_limits.shape == (links - 1,)
    assert (ROOT / "models" / f"{name}.xml").is_file()
    assert MODEL_DIR.resolve() == (ROOT / "models").resolve()
    assert cross_check(robot.model, samples=100).worst() < TOL


def test_the_package_installs_the_models_folder():
    """The wheel's package list names ``paa_mj.models`` (from ``models/``) and every package of the tree."""
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    assert config["package-dir"]["paa_mj.models"] == "models"
    assert "*.xml" in config["package-data"]["paa_mj.models"]
    found = {".".join(p.relative_to(ROOT).parent.parts) for p in (ROOT / "paa_mj").rglob("*.py")
             if "__pycache__" not in p.parts}
    assert set(config["packages"]) == found | {"paa_mj.models"}
    assert set(NAMED_ROBOTS) == {p.stem for p in (ROOT / "models").glob("*.xml")}


def test_the_acrobot_is_drakes():
    """Drake's AcrobotPlant defaults (m, l, lc, Ic, damping b; one motor at the elbow)."""
    p = load_robot("acrobot").params
    assert p.m.tolist() == [1.0, 1.0] and p.l.tolist() == [1.0, 2.0] and p.lc.tolist() == [0.5, 1.0]
    assert np.allclose(p.J, [0.083, 0.33], rtol=1e-12)
    assert p.damping.tolist() == [0.1, 0.1] and p.g == 9.81
    am = load_robot("acrobot").analytic
    # the folded goal of an acrobot is the up-down point of Lemma 1: E_r = b1 - b2
    assert Task.named("folded", am).goal_energy(am) == pytest.approx((0.5 * 1 + 1 * 1 - 1 * 1) * 9.81)


def test_make_model_takes_every_parameter_per_link(tmp_path, run):
    out = tmp_path / "five.xml"
    result = run("make-model", "--links", 5, "--m", 1, 2, 3, 4, 5, "--l", 0.5, 0.6, 0.7, 0.8, 0.9,
                 "--damping", 0.05, "--armature", 0.01, 0, 0, 0, 0.02, "--gravity", 3.7, "--torque-limit", 7,
                 "--out", out)
    assert result.returncode == 0, result.stderr
    robot = load_robot(out)
    p = robot.params
    assert p.n_links == 5 and p.m.tolist() == [1, 2, 3, 4, 5] and p.g == pytest.approx(3.7)
    assert np.allclose(p.lc, p.l / 2) and np.allclose(p.J, p.m * p.l**2 / 12)
    assert p.damping.tolist() == [0.05] * 5 and p.armature.tolist() == [0.01, 0, 0, 0, 0.02]
    assert robot.torque_limits.tolist() == [7.0] * 4
    bad = run("make-model", "--links", 4, "--m", 1, 2, 3, "--l", 1, 1, 1, 1, "--out", tmp_path / "x.xml")
    assert bad.returncode == 2 and "--m needs 4 values (one per link) for --links 4, got 3" in bad.stderr
    assert not (tmp_path / "x.xml").exists()
    bad = cli("make-model", "--links", 1, "--m", 1, "--l", 1, "--out", tmp_path / "x.xml")  # a real process too
    assert bad.returncode == 2 and "from 2 to 64" in bad.stderr


def test_every_parameter_is_read_back_from_the_written_file():
    params = random_chain(np.random.default_rng(9), 4)
    back = params_from_model(compile_mjcf(mjcf_from_params(params, torque_limits=[1, 2, 3])))
    for key in ("m", "l", "lc", "J", "damping", "armature"):
        assert np.allclose(getattr(back, key), getattr(params, key), rtol=1e-12, atol=1e-15), key
    assert back.g == pytest.approx(params.g, rel=1e-12)


@pytest.mark.parametrize("field, value, message", [
    ("damping", [-1.0, 0.0], "damping1 = -1 must be >= 0"),
    ("armature", [0.0, np.nan], "armature = [0.0, nan] is not finite"),
    ("m", [1.0], "for 2 to 64 links"),
])
def test_non_physical_chains_are_refused(field, value, message):
    base = dict(m=[1.0, 1.0], l=[1.0, 1.0], lc=[0.5, 0.5], J=[0.1, 0.1])
    base[field] = value
    with pytest.raises(PaaError, match=re.escape(message)):
        RobotParams(**base)


# --- controllers and theory over the family ---------------------------------------------------------------

def _energy_run(n, goal, damping, seed):
    """A random chain of n links under (40) alone, integrated exactly (DOP853), with its controller."""
    from paa_mj.control.energy import EnergyVCLController
    from paa_mj.model.robot import robot_from_xml
    from paa_mj.sim.analytic.engine import simulate_analytic
    from paa_mj.theory.conditions import chain_kd_min

    rng = np.random.default_rng(seed)
    m, l = rng.uniform(0.5, 3.0, n), rng.uniform(0.3, 1.0, n)
    params = RobotParams(m=m, l=l, lc=l * rng.uniform(0.3, 0.7, n), J=m * l**2 / 12,
                         damping=rng.uniform(0.05, 0.3, n) if damping else None)
    robot = robot_from_xml(mjcf_from_params(params, name=f"chain{n}"))
    task = Task.named(goal, robot)
    kD = 1.5 * chain_kd_min(robot.analytic, task).value
    controller = EnergyVCLController(robot.analytic, kD, kD, kD, task=task)
    traj = simulate_analytic(robot, controller, t_final=1.5, sample_dt=0.002, rtol=1e-11, atol=1e-11, task=task)
    return robot, controller, traj


@pytest.mark.parametrize("n", [2, 3, 4, 5])
@pytest.mark.parametrize("goal", ["folded", "stretched"])
def test_the_lyapunov_function_falls_as_36_says_along_simulated_chains(n, goal):
    """V(t) - V(0) = -kV int |qd_a|^2 dt along the closed loop of (40), for any chain and either goal."""
    robot, controller, traj = _energy_run(n, goal, damping=False, seed=10 * n + len(goal))
    V = controller.lyapunov(traj.q, traj.qd)
    rate = -controller.kV * np.sum(traj.qd[:, 1:] ** 2, axis=1)
    integral = np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * np.diff(traj.t))])
    assert V[-1] < V[0]  # the run moves: the identity is not checked on a resting robot
    assert np.max(np.abs((V - V[0]) - integral)) < 1e-4 * (V[0] - V[-1])
    # the rate from the chain rule equals -kV |qd_a|^2 at every sample
    assert np.allclose(controller.lyapunov_rate(traj.q, traj.qd), rate, rtol=1e-7, atol=1e-7 * np.max(np.abs(rate)))


@pytest.mark.parametrize("n", [2, 4])
def test_with_damping_the_lyapunov_rate_has_the_damping_term(n):
    """dV/dt = -kV |qd_a|^2 - (E - E_r) qd^T D qd: the law compensates damping in the accelerations only."""
    robot, controller, traj = _energy_run(n, "folded", damping=True, seed=n)
    damping = robot.params.damping
    energy_error = robot.analytic.energy(traj.q, traj.qd) - controller.E_r
    rate = -controller.kV * np.sum(traj.qd[:, 1:] ** 2, 1) - energy_error * np.sum(damping * traj.qd**2, 1)
    V = controller.lyapunov(traj.q, traj.qd)
    integral = np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * np.diff(traj.t))])
    assert np.max(np.abs((V - V[0]) - integral)) < 1e-4 * np.max(np.abs(integral))
    without = -controller.kV * np.sum(traj.qd[:, 1:] ** 2, 1)
    assert np.max(np.abs(rate - without)) > 1e-3 * np.max(np.abs(without))  # the term is there, not negligible


def test_the_chain_law_is_the_papers_law_for_the_gymnast(gymnast, rng):
    from paa_mj.control.energy import _chain_torque_rows, chain_parameters, chain_work_size, EnergyVCLController

    gains = gymnast.gains
    paper = EnergyVCLController(gymnast.analytic, **gains)
    params = chain_parameters(gymnast.analytic, Task.named("folded", gymnast), gains["kD"], gains["kP"], gains["kV"], True)
    x = np.ascontiguousarray(np.concatenate([rng.uniform(-3, 3, (50, 3)), rng.uniform(-2, 2, (50, 3))], 1))
    out = np.empty((50, 2))
    _chain_torque_rows(params, x, out, np.empty(chain_work_size(3)))
    assert np.allclose(out, paper.torque(x[:, :3], x[:, 3:]), rtol=1e-11, atol=1e-9)


def test_the_singularity_bound_by_its_definition_is_41_for_the_gymnast(gymnast, example2):
    from paa_mj.theory.conditions import chain_kd_min, frozen_acrobot_controllable, kd_min
    from paa_mj.theory.merged import merged_acrobot

    for robot in (gymnast, example2):
        assert chain_kd_min(robot.analytic, Task.named("folded", robot)).value == pytest.approx(kd_min(robot.analytic).value, rel=1e-9)
        ok, low, high = frozen_acrobot_controllable(robot.analytic)
        merged = merged_acrobot(robot.analytic)
        assert merged.controllable == ok
        assert merged.minimum == pytest.approx(low, rel=1e-6) and merged.maximum == pytest.approx(high, rel=1e-6)


def test_gains_at_the_bound_are_refused_for_a_chain():
    from paa_mj.control.energy import EnergyVCLController
    from paa_mj.control.gains import chain_singularity_bound

    acrobot = load_robot("acrobot")
    stretched = Task.named("stretched", acrobot)
    bound = chain_singularity_bound(acrobot.analytic, stretched)
    with pytest.raises(PaaError, match=r"kD = .* is not above kD_min = .* of \(41\)"):
        EnergyVCLController(acrobot.analytic, 0.99 * bound, 10.0, 10.0, task=stretched)


@pytest.mark.parametrize("robot, goal", [("acrobot", "folded"), ("acrobot", "stretched"), ("chain4", "folded")])
def test_the_named_robots_swing_up_and_balance_with_their_stored_gains(robot, goal):
    from paa_mj.sim.rollout import simulate_mujoco

    traj = simulate_mujoco(load_robot(robot), "vcl", t_final=30.0, task=goal)
    assert traj.meta["success"], traj.meta["status"]
    assert traj.switch_time is not None and traj.summary()["goal"] == goal and traj.task.name == goal


def test_the_lqr_balances_any_chain_at_either_goal():
    from paa_mj.sim.batch import simulate_batch
    from paa_mj.task import goal_angles

    for name in ("acrobot", "chain4"):
        robot = load_robot(name)
        n = robot.params.n_links
        for goal in ("folded", "stretched"):
            x0 = np.concatenate([goal_angles(goal, n) + 0.02, np.zeros(n)])
            result = simulate_batch(robot, x0[None], 3.0, controller="lqr", task=goal)
            assert result.success[0], (name, goal)
            other = "stretched" if goal == "folded" else "folded"
            moved = simulate_batch(robot, x0[None], 3.0, controller="lqr", task=other)
            assert not moved.success[0], (name, goal)  # the other goal's balance, judged against it, fails
            with pytest.raises(PaaError, match=f"built for the {goal} task"):
                simulate_batch(robot, x0[None], 3.0, controller=make_controller("lqr", robot, task=goal), task=other)


def test_every_command_takes_a_robot_of_the_family_and_either_goal(tmp_path, run):
    import json

    theory = run("theory", "--robot", "acrobot", "--goal", "stretched", "--json")
    assert theory.returncode == 0, theory.stderr
    report = json.loads(theory.stdout)
    assert report["links"] == 2 and report["goal_controllable"] and "not covered" in report["theorem1"]
    check = run("check", "--robot", "chain4", "--samples", 50, "--json")
    assert check.returncode == 0 and json.loads(check.stdout)["max_rel_err_qacc"] < 1e-9
    sim = run("simulate", "--robot", "chain4", "--goal", "stretched", "--controller", "lqr", "--x0", 0.02, 0, 0, 0,
              0, 0, 0, 0, "--t-final", 2, "--json", "--out", tmp_path / "sim")
    assert sim.returncode == 0, sim.stderr
    assert json.loads(sim.stdout)["success"] and json.loads(sim.stdout)["goal"] == "stretched"
    assert (tmp_path / "sim" / "trajectory.csv").read_text().startswith("t,q1,q2,q3,q4,d1,d2,d3,d4,tau2,tau3,tau4,")
    basin = run("basin", "--robot", "acrobot", "--goal", "stretched", "--axes", "q2,d1", "--grid", 3, "--t-final", 2,
                "--json", "--scheduler", "inline")
    assert basin.returncode == 0, basin.stderr
    assert json.loads(basin.stdout)["axes"] == ["q2", "d1"]
    bad = run("basin", "--robot", "acrobot", "--axes", "q3,q1", "--grid", 3, "--scheduler", "inline")
    assert bad.returncode == 2 and "out of q1, q2, d1, d2" in bad.stderr
    short = run("simulate", "--robot", "acrobot", "--x0", 0, 0, 0, 0, 0, 0)
    assert short.returncode == 2 and "--x0 needs 4 numbers for robot acrobot (q1 q2 d1 d2), got 6" in short.stderr


@pytest.mark.parametrize("goal", [pytest.param("folded", marks=pytest.mark.slow), "stretched"])  # folded: 6.5 CPU-s
def test_a_planned_kip_tracked_by_tvlqr_balances_the_acrobot(goal):
    """trajopt over a chain: collocation on the chain's dynamics (CasADi), TVLQR along it, then (67) at the goal."""
    from paa_mj.control.registry import make_controller
    from paa_mj.sim.rollout import simulate_mujoco

    robot = load_robot("acrobot")
    controller = make_controller("trajopt", robot, task=goal)
    plan = controller.describe()["plan"]
    assert 0.2 < plan["duration"] < 20 and plan["torque_bounds"] == pytest.approx([0.9 * 20.0])
    kip = controller.first.kip
    assert kip.x.shape == (101, 4) and kip.u.shape == (101, 1)
    assert kip.defects(robot.analytic) < 1e-6  # the NumPy chain model agrees with the CasADi one it was solved on
    assert np.max(np.abs(kip.u)) <= 0.9 * 20.0 + 1e-6
    traj = simulate_mujoco(robot, controller, t_final=plan["duration"] + 3.0, task=goal)
    assert traj.meta["success"], traj.meta["status"]


def test_the_gymnasium_environments_take_the_family():
    """3n observations and n - 1 actions; the package's controllers balance the acrobot at its folded goal through
    the environment; a vector environment of the chain equals its single environments bit for bit."""
    gym = pytest.importorskip("gymnasium")
    import paa_mj.envs as ge
    from paa_mj.envs.vector import GymnastVectorEnv

    ge.register()
    env = gym.make(ge.KIP_ID, robot="acrobot", task="folded")
    assert env.observation_space.shape == (6,) and env.action_space.shape == (1,)
    policy = ge.controller_policy("vcl", env)
    obs, info = env.reset(seed=0)
    policy.reset()
    done = False
    while not done:
        obs, reward, terminated, truncated, info = env.step(policy(obs, info))
        done = terminated or truncated
    assert info["is_success"] and not info["diverged"]
    with pytest.raises(ValueError, match=r"an action is 3 real numbers, shape \(3,\)"):
        ge.GymnastEnv(robot="chain4").step(np.zeros(2))

    vector = GymnastVectorEnv(num_envs=3, episode="balance", robot="chain4", task="stretched")
    singles = [ge.GymnastEnv(episode="balance", robot="chain4", task="stretched") for _ in range(3)]
    obs, _ = vector.reset(seed=5)
    assert obs.shape == (3, 12)
    assert np.array_equal(obs, np.array([s.reset(seed=5 + i)[0] for i, s in enumerate(singles)]))
    rng = np.random.default_rng(1)
    running, compared = [True] * 3, 0
    for _ in range(20):
        actions = rng.uniform(-0.05, 0.05, (3, 3)).astype(np.float32)  # small: the episodes go on
        obs, rewards, terminated, truncated, _ = vector.step(actions)
        for i, single in enumerate(singles):
            if running[i]:  # until its episode ends (the vector environment then resets it)
                o, r, done, cut, _ = single.step(actions[i])
                assert np.array_equal(o, obs[i]) and r == rewards[i] and (done, cut) == (terminated[i], truncated[i])
                running[i], compared = not (done or cut), compared + 1
    assert compared >= 20


def test_the_atlas_maps_the_family_beyond_theorem_1(run):
    import json

    from paa_mj.theory.conditions import chain_kd_min

    out = run("atlas", "--robot", "acrobot", "--goal", "stretched", "--vary", "m2,l2", "--range", "0.5:1", "--grid", 2,
              "--simulate", "--starts", 0, "--t-final", 2, "--json", "--scheduler", "inline")
    assert out.returncode == 0, out.stderr
    atlas = json.loads(out.stdout)
    assert atlas["links"] == 2 and atlas["goal"] == "stretched" and not atlas["theorem1_covers"]
    assert atlas["counts"]["goal controllable"] == 4 and atlas["counts"]["Theorem 1 applies"] == 0
    assert "(54) holds" not in atlas["counts"] and "Theorem 1 does not cover" in atlas["findings"][0]
    base = load_robot("acrobot")
    for row in atlas["robots"]:
        p = row["params"]
        params = RobotParams(m=p["m"], l=p["l"], lc=p["lc"], J=p["J"], g=base.params.g, damping=base.params.damping)
        am = AnalyticModel.from_params(params)
        stretched = Task.named("stretched", am)
        assert row["E_r"] == pytest.approx(stretched.goal_energy(am), rel=1e-12)
        assert row["kD_min"] == pytest.approx(chain_kd_min(am, stretched).value, rel=1e-12)
        gains = row["gains"]
        assert gains["kD"] == pytest.approx(1.05 * row["kD_min"], rel=1e-12)
        assert gains["kP"] / gains["kD"] == pytest.approx(base.gains["kP"] / base.gains["kD"], rel=1e-12)
        assert row["eta1"] is None and row["holds_54"] is False and row["theorem1"] is False
        assert row["outcome"] is not None
    scaled = [row for row in atlas["robots"] if row["factors"] == [0.5, 0.5]][0]
    assert scaled["params"]["m"][1] == pytest.approx(0.5 * base.params.m[1])
    assert scaled["params"]["l"][1] == pytest.approx(0.5 * base.params.l[1])
    four = run("atlas", "--robot", "chain4", "--vary", "l4,m3", "--grid", 2, "--json", "--scheduler", "inline")
    assert four.returncode == 0, four.stderr
    assert json.loads(four.stdout)["vary"] == ["l4", "m3"]
    bad = run("atlas", "--robot", "acrobot", "--vary", "m3,l1", "--grid", 2)
    assert bad.returncode == 2 and "out of m1, m2, l1, l2 (this robot has 2 links)" in bad.stderr


def test_theory_says_when_the_lqr_weights_are_unstable_at_the_time_step(run):
    """RealAIGym's small acrobot: the LQR of Q = 1e4 I, R = I sampled at 1 ms is unstable (radius > 1), the gymnast's
    stable; the radius is that of the zero-order-hold discretisation, recomputed here with SciPy."""
    import json

    from scipy.linalg import expm
    from scipy.signal import cont2discrete

    from paa_mj.theory.linear import goal_linearization, lqr_gain

    for name, goal, unstable in (("realaigym_acrobot", "stretched", True), ("gymnast", "folded", False)):
        out = run("theory", "--robot", name, "--goal", goal, "--json")
        assert out.returncode == 0, out.stderr
        report = json.loads(out.stdout)
        am = load_robot(name).analytic
        task = Task.named(goal, am)
        A, B = goal_linearization(am, task)
        Ad, Bd, *_ = cont2discrete((A, B, np.eye(len(A)), 0 * B), 1e-3, method="zoh")
        assert np.allclose(Ad, expm(A * 1e-3))
        radius = np.max(np.abs(np.linalg.eigvals(Ad - Bd @ lqr_gain(am, task))))
        assert report["dt"] == 1e-3 and report["lqr_sampled_radius"] == pytest.approx(radius, rel=1e-9)
        assert (report["lqr_sampled_radius"] > 1) == unstable
    text = run("theory", "--robot", "realaigym_acrobot", "--goal", "stretched").stdout
    assert "UNSTABLE: these weights do not balance at this time step" in text


def test_the_balance_lqr_takes_weights(run):
    """--lqr-weights q r: Q = q I, R = r I for (67). On RealAIGym's small acrobot the paper's weights, sampled at
    1 ms, do not balance from 0.05 rad off the upright; theirs (q = 1, r = 0.11, the scale of their LQR) do."""
    import json

    from paa_mj.control.lqr import LQRController
    from paa_mj.theory.linear import lqr_gain

    common = ("simulate", "--robot", "realaigym_acrobot", "--goal", "stretched", "--controller", "lqr", "--x0", 0.05,
              0, 0, 0, "--t-final", 5, "--json")
    paper = run(*common)
    theirs = run(*common, "--lqr-weights", 1, 0.11)
    assert paper.returncode == 0 and theirs.returncode == 0, theirs.stderr
    assert not json.loads(paper.stdout)["success"] and json.loads(theirs.stdout)["success"]
    am = load_robot("realaigym_acrobot").analytic
    stretched = Task.named("stretched", am)
    K = LQRController.for_model(am, stretched, (1.0, 0.11)).K
    np.testing.assert_allclose(K, lqr_gain(am, stretched, np.eye(4), 0.11 * np.eye(1)), rtol=1e-12)
    assert not np.allclose(K, LQRController.for_model(am, stretched).K)
    bad = run("simulate", "--robot", "acrobot", "--goal", "stretched", "--controller", "spong", "--lqr-weights", 1, 1)
    assert bad.returncode == 2 and "--lqr-weights applies to the controllers vcl, vcl-roa, vc, vc-roa, lqr" in bad.stderr
    with pytest.raises(PaaError, match=r"must each lie in \[1e-09, 1e\+12\], got 1, nan"):
        LQRController.for_model(am, stretched, (1.0, float("nan")))
