"""Actuation as a property of the robot: any joint passive (issue 46).

``make-model --passive J...`` writes the motors where they are, :func:`~paa_mj.model.load_robot` reads them back
(:attr:`~paa_mj.model.params.RobotParams.actuated`) and the input matrix B of (1) follows them everywhere: the
analytic model, the engines, the LQR (67), RealAIGym's protocols, the environments. The paper's controllers and
theory, built on joint 1 alone passive, refuse other patterns in one line; and every stored robot of the paper's
family runs as it did before (the JSON of its runs byte for byte).
"""
from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from paa_mj.control.registry import ControllerSpec
from paa_mj.errors import PaaError
from paa_mj.model.robot import NAMED_ROBOTS, load_robot
from paa_mj.sim.rollout import simulate_mujoco
from paa_mj.realaigym.study import run_protocol
from paa_mj.task import Task

BASELINE = Path(__file__).parent / "data" / "actuation_baseline"

#: The two robots of the issue: a pendubot (motor at the shoulder) and a three-link chain with a passive middle.
#: Their time steps are make-model's own choice (the largest of 1 ms / 2^k at which the LQR (67) of both goals is
#: stable when sampled), given here to spare the tests that search.
PATTERNS = {
    "pendubot": ("--links", 2, "--m", 1, 1, "--l", 1, 1, "--passive", 2, "--torque-limit", 50, "--timestep", 1e-3),
    "passive-middle": ("--links", 3, "--m", 1, 1, 1, "--l", 1, 1, 1, "--passive", 2, "--torque-limit", 100,
                       "--timestep", 5e-4),
}


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    """The robots of :data:`PATTERNS`, written by ``paa-mj make-model`` in this process, loaded."""
    from paa_mj.cli import main

    folder = tmp_path_factory.mktemp("actuation")
    robots = {}
    for name, args in PATTERNS.items():
        path = folder / f"{name}.xml"
        assert main(["make-model", *map(str, args), "--name", name, "--out", str(path)]) == 0
        robots[name] = load_robot(path)
    return robots


def test_make_model_writes_the_motors_where_they_are_and_load_robot_reads_them(made):
    pendubot, middle = made["pendubot"], made["passive-middle"]
    assert pendubot.params.actuated == (0,) and pendubot.params.passive == (1,)
    assert middle.params.actuated == (0, 2) and middle.params.passive == (1,)
    for robot in made.values():
        model, params = robot.model, robot.params
        assert [int(model.actuator_trnid[a, 0]) for a in range(model.nu)] == list(params.actuated)
        np.testing.assert_array_equal(robot.analytic.input_matrix, np.eye(params.n_links)[:, list(params.actuated)])
        assert robot.torque_limits.shape == (params.n_motors,) and robot.gains is None  # no gains of (40) stored
        assert not robot.analytic.paper_shape and not params.passive_first
    assert "Joint 2 (elbow) is passive; joint 1 (shoulder) carries a motor (a pendubot)." in pendubot.xml
    # the paper's family keeps its motors, its parameters' key and so every digest and cache
    gymnast = load_robot("gymnast")
    assert gymnast.params.actuated == (1, 2) and gymnast.params.passive_first and gymnast.analytic.paper_shape
    assert gymnast.params.key()[-1] == gymnast.params.g and "driven_joints" not in gymnast.params.actuation_meta()


@pytest.mark.parametrize("passive, message", [((1, 2), "leaves no motor"), ((3,), "distinct joints of 1..2"),
                                              ((2, 2), "distinct joints")])
def test_make_model_refuses_impossible_patterns_in_one_line(run, tmp_path, passive, message):
    result = run("make-model", "--links", 2, "--m", 1, 1, "--l", 1, 1, "--passive", *passive,
                 "--out", tmp_path / "x.xml")
    assert result.returncode == 2 and message in result.stderr and len(result.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "x.xml").exists()


def test_mujoco_agrees_with_the_analytic_model_with_B(made):
    """M, the bias forces and the accelerations under the motors' torques (B tau) at random states."""
    rng = np.random.default_rng(46)
    for robot in [*made.values(), load_robot("realaigym_pendubot")]:
        model, am, n = robot.model, robot.analytic, robot.params.n_links
        data = mujoco.MjData(model)
        for _ in range(20):
            q, qd = rng.uniform(-np.pi, np.pi, n), rng.uniform(-3, 3, n)
            tau = rng.uniform(-1, 1, robot.params.n_motors) * np.minimum(robot.torque_limits, 5.0)
            data.qpos[:], data.qvel[:], data.ctrl[:] = q, qd, tau
            mujoco.mj_forward(model, data)
            M = np.zeros((n, n))
            mujoco.mj_fullM(model, data, M)
            np.testing.assert_allclose(am.mass_matrix(q), M, rtol=1e-10, atol=1e-12)
            np.testing.assert_allclose(am.bias(q, qd), data.qfrc_bias, rtol=1e-9, atol=1e-10)
            np.testing.assert_allclose(am.joint_torques(tau), data.qfrc_actuator, atol=1e-12)
            np.testing.assert_allclose(am.acceleration(q, qd, tau), data.qacc, rtol=1e-8, atol=1e-8)


@pytest.mark.parametrize("name", list(PATTERNS))
def test_the_lqr_balances_them_from_near_the_top(made, name):
    robot = made[name]
    n = robot.params.n_links
    task = Task.named("stretched", robot.analytic)
    x0 = np.concatenate([np.tile([0.05, -0.05], n)[:n], np.zeros(n)])
    traj = simulate_mujoco(robot, "lqr", x0, 3.0, task=task)
    assert traj.meta["success"], traj.outcome()
    assert np.max(np.abs(traj.final_state)) < 0.5 * np.max(np.abs(x0))  # on its way to the goal, not just inside
    assert traj.tau.shape[1] == robot.params.n_motors and traj.meta["driven_joints"] == [j + 1 for j in
                                                                                       robot.params.actuated]
    # the exact closed loop of the analytic engine agrees with MuJoCo's (the same B)
    from paa_mj.sim.analytic import simulate_analytic

    exact, stepped = (simulate(robot, "lqr", x0, 1.0, task=task) for simulate in (simulate_analytic, simulate_mujoco))
    np.testing.assert_allclose(exact.final_state, stepped.final_state, atol=1e-4)


@pytest.mark.parametrize("name", list(PATTERNS))
def test_they_score_on_realaigym_performance_v2(made, name):
    """Their protocol's simulator puts each motor's torque on its joint: from near the top the LQR stays up for
    the whole run and scores above 0 (hanging down it could not: nothing would be up)."""
    robot = made[name]
    n = robot.params.n_links
    x0 = np.concatenate([np.tile([0.02, -0.02], n)[:n], np.zeros(n)])
    # their 2 ms step: the three links' LQR with the paper's weights is unstable sampled that slowly, Q = R = I is not
    weights = () if name == "pendubot" else (("lqr_weights", (1.0, 1.0)),)
    summary, arrays = run_protocol("performance-v2", robot, ControllerSpec("lqr", options=weights), "stretched", x0=x0,
                                   progress=False)
    result = summary["result"]
    assert result["criteria"]["success"] and result["score"] > 0.0, result
    U = arrays["U"]
    assert np.all(U[:, list(robot.params.passive)] == 0.0) and np.any(U[:, list(robot.params.actuated)] != 0.0)


@pytest.mark.parametrize("controller", ["vcl", "vc-only", "vcl-roa", "spong"])
def test_the_papers_controllers_refuse_them_in_one_line(made, run, controller):
    robot = made["pendubot"]
    with pytest.raises(PaaError, match="needs joint 1 alone passive"):
        ControllerSpec(controller, task=Task.named("stretched", robot.analytic)).build(robot)
    result = run("simulate", "--robot", "realaigym_pendubot", "--goal", "stretched", "--controller", controller)
    assert result.returncode == 2 and len(result.stderr.strip().splitlines()) == 1
    assert "needs joint 1 alone passive" in result.stderr and "joint 2 passive, joint 1 driven" in result.stderr


def test_theory_refuses_them_in_one_line(run):
    result = run("theory", "--robot", "realaigym_pendubot", "--goal", "stretched")
    assert result.returncode == 2 and result.stdout == "" and len(result.stderr.strip().splitlines()) == 1
    assert "Theorem 1" in result.stderr and "needs joint 1 alone passive" in result.stderr
    result = run("atlas", "--robot", "realaigym_pendubot", "--grid", 2)
    assert result.returncode == 2 and len(result.stderr.strip().splitlines()) == 1 and "the atlas" in result.stderr


def test_the_pendubot_is_stored_with_their_parameters():
    pendubot, acrobot = load_robot("realaigym_pendubot"), load_robot("realaigym_acrobot")
    assert "realaigym_pendubot" in NAMED_ROBOTS
    assert pendubot.params.actuated == (0,) and acrobot.params.actuated == (1,)
    assert pendubot.params.key()[:9] == acrobot.params.key()  # their design C.1: the same links
    np.testing.assert_array_equal(pendubot.torque_limits, [6.0])  # their [6, 0]


@pytest.mark.parametrize("args, stored", [
    (("simulate", "--robot", "gymnast", "--controller", "vcl", "--json"), "gymnast_vcl.json"),
    (("simulate", "--robot", "gymnast", "--controller", "vcl", "--engine", "analytic", "--json"),
     "gymnast_vcl_analytic.json"),
    (("simulate", "--robot", "acrobot", "--controller", "spong", "--goal", "stretched", "--json"), "acrobot_spong.json"),
    (("simulate", "--robot", "chain4", "--goal", "stretched", "--json"), "chain4_stretched.json"),
    (("realaigym", "--protocol", "performance-v2", "--controller", "spong", "--json"), "rag_acrobot_perf_spong.json"),
    (("realaigym", "--protocol", "global-v3", "--controller", "spong", "--json"), "rag_acrobot_global_spong.json"),
])
def test_the_papers_family_runs_as_before_byte_for_byte(run, args, stored):
    """The JSON of these runs as the code wrote it before the robots' actuation was read from their files
    (tests/data/actuation_baseline, written by the commit before the change). A change of these bytes is a change
    of the numbers of every robot of the paper's family: make it on purpose, and write the files anew with it."""
    result = run(*args)
    assert result.stdout == (BASELINE / stored).read_text()


def test_fantonis_swing_up_makes_their_lyapunov_function_decrease_as_designed():
    """Fantoni, Lozano & Spong's law on the stored pendubot: at random states, V_dot = k_E E~ E_dot + k_D qd1 qdd1 +
    k_P q1~ qd1 with E_dot = qd1 tau (no damping) and qdd1 from (1) is -k_V qd1^2, the compiled law and NumPy's
    agree, and it refuses the acrobot and a k_D at its bound in one line."""
    from paa_mj.control.pendubot import FantoniController, kd_bound

    robot = load_robot("realaigym_pendubot")
    am = robot.analytic
    law = FantoniController(am)
    g = law.gains
    rng = np.random.default_rng(2000)
    q, qd = rng.uniform(-np.pi, np.pi, (50, 2)), rng.uniform(-4, 4, (50, 2))
    tau = law.torque(q, qd)
    E_err = am.energy(q, qd) - np.sum(am.gravity_constants)
    qdd = am.acceleration(q, qd, tau)
    v_dot = g["k_e"] * E_err * qd[:, 0] * tau[:, 0] + g["k_d"] * qd[:, 0] * qdd[:, 0] + g["k_p"] * q[:, 0] * qd[:, 0]
    np.testing.assert_allclose(v_dot, -g["k_v"] * qd[:, 0] ** 2, rtol=1e-9, atol=1e-9)
    form = law.compiled()
    out = np.empty(1)
    for k in range(5):
        form.kernel(np.concatenate([q[k], qd[k]]), 0.0, form.params, form.memory.copy(), out)
        assert out[0] == pytest.approx(tau[k, 0], rel=1e-12)
    with pytest.raises(PaaError, match="the motor at joint 1"):
        FantoniController(load_robot("realaigym_acrobot").analytic)
    with pytest.raises(PaaError, match="must be above"):
        FantoniController(am, k_d=kd_bound(am))
