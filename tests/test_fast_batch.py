"""The compiled kernel and the batch engine give the same results as the reference paths."""
import json
import warnings

import numpy as np
import pytest

from paa_mj.batch import simulate_batch
from paa_mj.cli import main
from paa_mj.controllers import SwitchingController, TheoryWarning
from paa_mj.errors import PaaError
from paa_mj.fast import hybrid_torque, kernel_constants
from paa_mj.model import load_robot
from paa_mj.params import RobotParams
from paa_mj.rollout import X0_HANGING, simulate_mujoco
from paa_mj.theory import Q_UDD

from .conftest import GAINS1, GAINS2


@pytest.mark.parametrize("robot, gains, limit", [("gymnast", GAINS1, None), ("gymnast", GAINS1, 80.0),
                                                 ("example2", GAINS2, None)])
def test_kernel_equals_numpy_controller(robot, gains, limit, request, rng):
    am = request.getfixturevalue(robot).analytic
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TheoryWarning)
        ctrl = SwitchingController.for_model(am, **gains, torque_limit=limit)
    consts, K = kernel_constants(ctrl)
    out = np.zeros(2)
    states = [(rng.uniform(-7, 7, 3), rng.uniform(-5, 5, 3)) for _ in range(500)]
    states += [(Q_UDD + rng.uniform(-0.4, 0.4, 3), rng.uniform(-0.4, 0.4, 3)) for _ in range(100)]
    for q, qd in states:
        ctrl.reset()
        expected = ctrl.torque(q, qd)
        mode = hybrid_torque(*q, *qd, consts, K, 0, out)
        assert mode == int(ctrl.mode)
        np.testing.assert_allclose(out, expected, rtol=1e-9, atol=1e-9 * np.max(np.abs(expected)))


def test_compiled_rollout_equals_numpy_rollout(gymnast):
    ctrl = SwitchingController.for_model(gymnast.analytic, **GAINS1)
    fast = simulate_mujoco(gymnast, ctrl, X0_HANGING, 3.0)
    slow = simulate_mujoco(gymnast, ctrl, X0_HANGING, 3.0, compiled=False)
    np.testing.assert_allclose(fast.q, slow.q, rtol=0, atol=1e-10)
    np.testing.assert_allclose(fast.tau, slow.tau, rtol=1e-9, atol=1e-7)
    x0 = np.concatenate([Q_UDD + [0.3, -0.2, 0.1], [0.2, 0.0, 0.0]])
    fast = simulate_mujoco(gymnast, ctrl, x0, 2.0)
    slow = simulate_mujoco(gymnast, ctrl, x0, 2.0, compiled=False)
    assert fast.switch_time == slow.switch_time == 0.0
    np.testing.assert_allclose(fast.q, slow.q, atol=1e-10)


@pytest.fixture(scope="module")
def random_starts():
    rng = np.random.default_rng(5)
    x0 = np.zeros((6, 6))
    x0[:, 0] = -np.pi + rng.uniform(-1.0, 1.0, 6)
    x0[:, 1:3] = rng.uniform(-1.0, 1.0, (6, 2))
    return x0


def test_batch_equals_single_rollouts(gymnast, random_starts):
    batch = simulate_batch(gymnast, random_starts, 20.0, record=True)
    for i, x0 in enumerate(random_starts):
        # every step recorded: the batch's max |tau| is over every step too
        single = simulate_mujoco(gymnast, SwitchingController.for_model(gymnast.analytic, **GAINS1), x0, 20.0,
                                 sample_dt=0.001)
        assert (single.switch_time or np.nan) == pytest.approx(batch.switch_time[i], nan_ok=True)
        assert single.balanced() == batch.balanced[i]
        np.testing.assert_allclose(batch.final_state[i], single.final_state, atol=1e-12)
        np.testing.assert_allclose(batch.trajectories["q"][i], single.q[::10], atol=1e-12)
        np.testing.assert_allclose(batch.max_abs_tau[i], np.max(np.abs(single.tau), axis=0), rtol=1e-12)


def test_batch_per_rollout_gains_and_model_error(gymnast):
    x0 = np.tile(X0_HANGING, (2, 1))
    gains = np.array([[4600.0, 17000.0, 4000.0], [4550.0, 16000.0, 5000.0]])
    wrong = gymnast.params.scaled(mass_factor=1.05, length_factor=0.98)
    batch = simulate_batch(gymnast, x0, 3.0, gains=gains, controller_params=[gymnast.params, wrong], record=True)
    one = simulate_mujoco(gymnast, SwitchingController.for_model(gymnast.analytic, *gains[0]), x0[0], 3.0)
    np.testing.assert_allclose(batch.trajectories["q"][0], one.q, atol=1e-12)
    from paa_mj.dynamics import AnalyticModel

    believed = SwitchingController.for_model(AnalyticModel.from_params(wrong), *gains[1], check=False)
    two = simulate_mujoco(gymnast, believed, x0[1], 3.0)
    np.testing.assert_allclose(batch.trajectories["q"][1], two.q, atol=1e-12)
    assert np.max(np.abs(batch.trajectories["q"][1] - batch.trajectories["q"][0])) > 1e-3


def test_batch_plant_perturbation(gymnast):
    heavier = gymnast.params.scaled(mass_factor=1.1)
    batch = simulate_batch(gymnast, X0_HANGING[None], 2.0, plant_params=[heavier], record=True)
    from paa_mj.model import Robot, model_from_params
    from paa_mj.dynamics import AnalyticModel

    plant = Robot("heavier", model_from_params(heavier), heavier, AnalyticModel.from_params(heavier), gymnast.gains)
    single = simulate_mujoco(plant, SwitchingController.for_model(gymnast.analytic, **GAINS1), X0_HANGING, 2.0)
    np.testing.assert_allclose(batch.trajectories["q"][0], single.q, atol=1e-12)


def test_batch_divergence_is_contained(gymnast):
    x0 = np.tile(X0_HANGING, (3, 1))
    x0[1, 3] = 5e4  # runaway speed
    batch = simulate_batch(gymnast, x0, 0.5)
    assert list(batch.diverged) == [False, True, False]
    assert np.all(np.isfinite(batch.final_state))
    np.testing.assert_allclose(batch.final_state[0], batch.final_state[2])


def test_batch_bad_input(gymnast):
    with pytest.raises(PaaError, match=r"\(N, 6\)"):
        simulate_batch(gymnast, np.zeros((3, 5)), 1.0)
    with pytest.raises(PaaError, match="kD_min"):
        simulate_batch(gymnast, X0_HANGING[None], 1.0, gains=[100.0, 16000.0, 5000.0])
    with pytest.raises(PaaError, match="3 values per rollout"):
        simulate_batch(gymnast, np.zeros((2, 6)), 1.0, gains=np.ones((3, 3)))


def test_basin_cli(capsys, tmp_path):
    code = main(["basin", "--grid", "3", "--t-final", "2", "--axes", "q1,d2", "--json", "--out", str(tmp_path)])
    out = capsys.readouterr().out
    assert code == 0
    s = json.loads(out)
    assert s["cells"] == 9 and s["axes"] == ["q1", "d2"]
    assert 0.0 <= s["success_fraction"] <= 1.0
    assert "median_switch_time" in s
    data = np.load(tmp_path / "basin.npz")
    assert data["switch_time"].shape == (9,) and data["x0"].shape == (9, 6)
    assert np.all(data["x0"][:, [1, 2, 3, 5]] == 0)
    assert (tmp_path / "basin.png").read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize("args, fragment", [
    (["basin", "--axes", "q1"], "two different coordinates"),
    (["basin", "--axes", "q1,q1"], "two different coordinates"),
    (["basin", "--grid", "1"], "--grid must be an integer >= 2"),
])
def test_basin_bad_input(capsys, args, fragment):
    assert main(args) == 2
    assert fragment in capsys.readouterr().err


def test_bench_reports_ratios_without_timing_assertions():
    from paa_mj.bench import format_bench, run_bench

    r = run_bench(batch_size=8, batch_seconds=0.05, repeats=1)
    for key in ("bare_mj_step_us", "single_step_ratio", "batch_step_ratio", "analytic_to_mujoco_ratio"):
        assert np.isfinite(r[key]) and r[key] > 0
    assert "single_step_ratio" in format_bench(r)


def test_batch_noise_is_seeded(gymnast):
    x0 = np.tile(X0_HANGING, (2, 1))
    a = simulate_batch(gymnast, x0, 1.0, noise_std=[0.01, 0.01], seed=3)
    b = simulate_batch(gymnast, x0, 1.0, noise_std=[0.01, 0.01], seed=3)
    c = simulate_batch(gymnast, x0, 1.0, noise_std=[0.01, 0.01], seed=4)
    np.testing.assert_array_equal(a.final_state, b.final_state)
    assert np.max(np.abs(a.final_state - c.final_state)) > 1e-6
    assert np.max(np.abs(a.final_state[0] - a.final_state[1])) > 1e-6  # each rollout draws its own noise


def test_batch_delay_applies_the_torque_computed_d_steps_before(gymnast):
    d = 4
    batch = simulate_batch(gymnast, X0_HANGING[None], 0.2, delay_steps=[d], record=True, sample_dt=0.001)
    q, qd, tau = batch.trajectories["q"][0], batch.trajectories["qd"][0], batch.trajectories["tau"][0]
    ctrl = SwitchingController.for_model(gymnast.analytic, **GAINS1)
    computed = np.array([ctrl.torque(q[s], qd[s]) for s in range(len(q))])
    np.testing.assert_array_equal(tau[:d], 0.0)
    np.testing.assert_allclose(tau[d:], computed[:-d], rtol=1e-9)


def test_robustness_cli(capsys, tmp_path):
    code = main(["robustness", "--trials", "2", "--t-final", "1", "--json", "--out", str(tmp_path),
                 "--model-error", "0", "3", "7", "15", "--scheduler", "inline"])
    s = json.loads(capsys.readouterr().out)
    assert code == 0
    assert set(s["factors"]) == {"noise", "torque_limit", "model_error", "delay"}
    for factor, data in s["factors"].items():
        assert len(data["levels"]) == 4
        assert all(0 <= lv["success_rate"] <= 1 for lv in data["levels"])
        assert (tmp_path / f"robustness_{factor}.png").exists()
    assert (tmp_path / "summary.json").exists() and (tmp_path / "robustness.npz").exists()
    # (the levels asked for are the ones reported)


def test_robustness_model_error_levels(capsys):
    assert main(["robustness", "--trials", "1", "--t-final", "0.5", "--json", "--scheduler", "inline",
                 "--model-error", "0", "12.5"]) == 0
    s = json.loads(capsys.readouterr().out)
    assert [lv["level"] for lv in s["factors"]["model_error"]["levels"]] == [0.0, 12.5]
    assert main(["robustness", "--model-error", "150"]) == 2
    assert "[0, 100)" in capsys.readouterr().err
