"""Rollouts in MuJoCo and of the analytic model: tests (b)-(d) of issue 3, the record and the CLI."""
import json
import warnings

import numpy as np
import pytest

from paa_mj.cli import main
from paa_mj.control import TheoryWarning, make_controller
from paa_mj.errors import PaaError, SimulationDiverged
from paa_mj.model.states import X0_HANGING
from paa_mj.sim import Trajectory, simulate_analytic, simulate_mujoco

from .helpers import replay_torques_analytic, replay_torques_mujoco


@pytest.fixture(scope="module")
def gymnast_balanced(gymnast):
    return simulate_mujoco(gymnast, "vcl", X0_HANGING, t_final=30.0)


def test_V_never_increases_along_the_analytic_solution(gymnast):
    traj = simulate_analytic(gymnast, "vcl-only", X0_HANGING, t_final=8.0, sample_dt=0.005)
    increase = np.diff(traj.V)
    assert np.max(increase) <= 1e-8 * traj.V[0]
    assert traj.V[-1] < 0.05 * traj.V[0]


def test_mujoco_and_analytic_agree_on_the_same_torque_sequence(gymnast):
    """Same zero-order-hold torques, 1 s: RK4 at 1 ms against an rtol 1e-12 integration (one interval at a time)."""
    traj = simulate_mujoco(gymnast, "vcl", X0_HANGING, t_final=1.0, sample_dt=0.001)
    torques = traj.tau[:-1]
    engine = replay_torques_mujoco(gymnast, X0_HANGING, torques)
    exact = replay_torques_analytic(gymnast, X0_HANGING, torques, dt=0.001)
    np.testing.assert_allclose(engine[:, :3], traj.q[1:], atol=1e-12)  # replay reproduces the closed loop
    err = np.max(np.abs(engine - exact))
    assert err < 1e-6, err


def test_hybrid_controller_balances_table1_in_mujoco(gymnast_balanced):
    traj = gymnast_balanced
    assert traj.switch_time is not None
    assert traj.balanced()
    assert abs(traj.E_minus_Er[-1]) < 1e-3
    assert np.all(traj.mode[traj.t >= traj.switch_time + 0.01] == 1)
    assert np.all(traj.mode[traj.t < traj.switch_time] == 0)
    # the paper's Fig. 7: link 1 swings through more than 2 pi
    assert np.ptp(traj.q[:, 0]) > 2 * np.pi - 0.5


def test_hybrid_controller_balances_table1_analytic(gymnast):
    traj = simulate_analytic(gymnast, "vcl", X0_HANGING, t_final=20.0)
    assert traj.switch_time is not None and traj.balanced()


def test_table2_never_swings_up(example2):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TheoryWarning)
        ctrl = make_controller("vcl", example2)
    traj = simulate_mujoco(example2, ctrl, X0_HANGING, t_final=30.0, sample_dt=0.01)
    assert traj.switch_time is None
    assert not traj.balanced()
    assert np.max(np.cos(traj.q[:, 0])) < 0  # link 1 stays below the bar
    assert abs(traj.E_minus_Er[-1]) > 10 and traj.V[-1] > 100  # neither goes to 0 (Figs. 12-14)
    # q2 -> -pi, q3 -> 0 and the torques decay (the paper's Figs. 13, 14)
    assert abs(traj.q[-1, 1] + np.pi) < 0.05 and abs(traj.q[-1, 2]) < 0.05
    assert np.max(np.abs(traj.tau[-100:])) < 0.1 * np.max(np.abs(traj.tau))


def test_divergence_keeps_the_record(gymnast):
    with pytest.raises(SimulationDiverged, match=r"diverged at t = \d") as info:
        simulate_mujoco(gymnast, "vcl", X0_HANGING, t_final=20.0, dt=0.05, integrator="Euler")
    traj = info.value.trajectory
    assert len(traj) > 10 and np.all(np.isfinite(traj.q))


def test_save_and_load_round_trip(gymnast_balanced, tmp_path):
    gymnast_balanced.save(tmp_path)
    back = Trajectory.load(tmp_path / "trajectory.npz")
    np.testing.assert_array_equal(back.q, gymnast_balanced.q)
    assert back.switch_time == gymnast_balanced.switch_time
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["balanced"] is True
    csv = np.loadtxt(tmp_path / "trajectory.csv", delimiter=",", skiprows=1)
    np.testing.assert_allclose(csv[:, 1:4], gymnast_balanced.q, rtol=1e-15)
    np.testing.assert_allclose(csv[:, 0], gymnast_balanced.t, rtol=1e-12, atol=0)


def test_the_csv_keeps_sample_times_below_a_microsecond(gymnast, tmp_path):
    traj = simulate_mujoco(gymnast, "passive", t_final=6.25e-4, dt=6.25e-5, sample_dt=6.25e-5)
    traj.save(tmp_path)
    times = [line.split(",")[0] for line in (tmp_path / "trajectory.csv").read_text().splitlines()[1:4]]
    assert times == ["0", "6.25e-05", "0.000125"]


@pytest.mark.parametrize("kwargs, message", [
    (dict(x0=[0, 0, 0]), "6 numbers"),
    (dict(x0=[0, 0, 0, 0, np.inf, 0]), "finite"),
    (dict(t_final=0), "final time"),
    (dict(t_final=np.inf), "final time"),
    (dict(dt=-1e-3), "time step"),
    (dict(dt=np.nan), "time step"),
    (dict(integrator="Verlet"), "unknown integrator"),
    (dict(sample_dt=2.0), "longer than the run"),
    (dict(t_final=1e12), "physics steps"),
])
def test_bad_rollout_input(gymnast, kwargs, message):
    args = dict(x0=X0_HANGING, t_final=1.0)
    args.update(kwargs)
    with pytest.raises(PaaError, match=message):
        simulate_mujoco(gymnast, "vcl", **args)


def test_simulate_cli_json_and_files(capsys, tmp_path):
    code = main(["simulate", "--robot", "gymnast", "--t-final", "1", "--json", "--out", str(tmp_path)])
    out = capsys.readouterr().out
    assert code == 0
    s = json.loads(out)
    for key in ("switch_time", "balanced", "final_state", "E_minus_Er_final", "V_final", "max_abs_tau"):
        assert key in s
    assert s["switch_time"] is None and s["balanced"] is False
    assert len(s["final_state"]) == 6 and len(s["max_abs_tau"]) == 2
    assert {p.name for p in tmp_path.iterdir()} == {"trajectory.npz", "trajectory.csv", "summary.json"}
    assert s["controller"] == "vcl" and s["gains"] == {"kD": 4550.0, "kP": 16000.0, "kV": 5000.0}


def test_simulate_cli_divergence_exit_3(capsys, tmp_path):
    code = main(["simulate", "--t-final", "20", "--dt", "0.05", "--integrator", "Euler", "--json", "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert code == 3
    # the sampling warning comes first where this process has not shown it yet (Python shows a warning once)
    errors = [line for line in err.strip().splitlines() if not line.startswith("paa-mj: warning: the balance LQR")]
    assert len(errors) == 1 and errors[0].startswith("paa-mj: error: simulation diverged at t =")
    assert (tmp_path / "trajectory.npz").exists()


# the gymnast to 1 s past its switch (at 8.08 s; 12 s before, a third more CPU), the acrobot's 6 s of swing-up
@pytest.mark.parametrize("robot, goal, t_final", [("gymnast", "folded", 9.0), ("acrobot", "stretched", 6.0)])
def test_the_exact_closed_loop_of_a_compiled_law_is_that_of_its_torque(robot, goal, t_final):
    """simulate_analytic evaluates a compiled law and (1) in one compiled call; through the law's Python torque
    and the analytic model's NumPy accelerations (the same controller wrapped, compiled form hidden) the
    integration gives the same trajectory and switch time to the integrator's tolerance."""
    from paa_mj.control.combined import CombinedController
    from paa_mj.model import load_robot

    from .helpers import Uncompiled

    r = load_robot(robot)
    compiled = simulate_analytic(r, make_controller("vcl", r, task=goal), t_final=t_final, task=goal)
    plain = make_controller("vcl", r, task=goal)
    plain = CombinedController(Uncompiled(plain.first), Uncompiled(plain.second), plain.condition)
    python = simulate_analytic(r, plain, t_final=t_final, task=goal)
    assert np.all(np.isfinite(compiled.q)) and len(compiled.t) == len(python.t)
    np.testing.assert_allclose(compiled.q, python.q, rtol=0, atol=1e-6)
    np.testing.assert_allclose(compiled.qd, python.qd, rtol=0, atol=1e-5)
    assert (python.switch_time is not None) == (robot == "gymnast")  # the switch itself is compared, once
    if python.switch_time is not None:
        assert compiled.switch_time == pytest.approx(python.switch_time, abs=1e-8)
    assert np.max(np.abs(compiled.q[-1] - compiled.q[0])) > 0.5  # it moved


def test_a_run_ending_between_two_samples_records_its_end(gymnast):
    traj = simulate_mujoco(gymnast, t_final=0.013, sample_dt=0.01)
    assert traj.t.tolist() == pytest.approx([0.0, 0.01, 0.013]) and traj.summary()["final_time"] == pytest.approx(0.013)
    longer = simulate_mujoco(gymnast, t_final=0.02, sample_dt=0.001)
    np.testing.assert_array_equal(traj.q[-1], longer.q[13])  # the state of step 13, as the finer grid has it


@pytest.mark.parametrize("timestep", [1e-3, 5e-4])
def test_both_engines_run_a_final_time_to_the_same_step_and_judge_the_same_instants(gymnast, tmp_path, timestep):
    """A final time between two steps: the MuJoCo engine runs to the nearest step, and so does the exact closed loop,
    which judges success at the instants k dt of the robot's own step (not at a fixed 1 ms)."""
    from paa_mj.model.robot import load_robot
    from paa_mj.task import Task

    path = tmp_path / "robot.xml"
    path.write_text(gymnast.xml.replace('timestep="0.001"', f'timestep="{timestep}"'))
    robot = load_robot(str(path))
    assert robot.model.opt.timestep == timestep
    x0 = np.concatenate([Task.named("folded", robot).goal + [1e-3, 0, 0], np.zeros(3)])
    t_final = 0.2 + 0.7 * timestep
    mujoco_run = simulate_mujoco(robot, "lqr", x0, t_final, sample_dt=timestep)
    exact = simulate_analytic(robot, "lqr", x0, t_final, sample_dt=timestep)
    assert exact.t[-1] == pytest.approx(mujoco_run.t[-1], abs=1e-12) and exact.t[-1] == pytest.approx(0.2 + timestep)
    assert exact.meta["success"] and mujoco_run.meta["success"]
