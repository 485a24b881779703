"""The rollout engine: compiled and Python controllers, batch against single, retirement, disturbances."""
import json
import subprocess
import sys

import numpy as np
import pytest

from paa_mj.cli import main
from paa_mj.control import ControllerSpec, make_controller
from paa_mj.errors import PaaError
from paa_mj.model.states import Q_UDD, X0_HANGING
from paa_mj.sim import Disturbances, simulate_batch, simulate_mujoco
from paa_mj.sim.noise import gaussian

from .helpers import Uncompiled


def test_compiled_rollout_equals_python_controller_rollout(gymnast):
    ctrl = make_controller("vcl", gymnast)
    fast = simulate_mujoco(gymnast, ctrl, X0_HANGING, 1.5)  # 1,500 calls of the law from Python: 3 s twice the CPU
    slow = simulate_mujoco(gymnast, Uncompiled(make_controller("vcl", gymnast)), X0_HANGING, 1.5)
    np.testing.assert_allclose(fast.q, slow.q, rtol=0, atol=1e-10)
    np.testing.assert_allclose(fast.tau, slow.tau, rtol=1e-9, atol=1e-7)
    x0 = np.concatenate([Q_UDD + [0.3, -0.2, 0.1], [0.2, 0.0, 0.0]])
    fast = simulate_mujoco(gymnast, ctrl, x0, 1.0)
    slow = simulate_mujoco(gymnast, Uncompiled(make_controller("vcl", gymnast)), x0, 1.0)
    assert fast.switch_time == slow.switch_time == 0.0
    np.testing.assert_allclose(fast.q, slow.q, atol=1e-10)


@pytest.fixture(scope="module")
def random_starts():
    rng = np.random.default_rng(5)
    x0 = np.zeros((6, 6))
    x0[:, 0] = -np.pi + rng.uniform(-1.0, 1.0, 6)
    x0[:, 1:3] = rng.uniform(-1.0, 1.0, (6, 2))
    return x0


@pytest.mark.parametrize("retire", [False, True])
def test_batch_equals_single_rollouts_bit_for_bit(gymnast, random_starts, retire):
    # three of the six starts (half the CPU): one switches and balances (retired at 19.3 s), one switches and never
    # balances (runs to the end), one balances early (retired at 16.7 s)
    starts = random_starts[[2, 4, 5]]
    batch = simulate_batch(gymnast, starts, 20.0, record=True, retire=retire, nthread=2)
    assert np.all(np.isfinite(batch.switch_time)) and not batch.balanced.all() and batch.balanced.any()
    for i, x0 in enumerate(starts):
        single = simulate_mujoco(gymnast, "vcl", x0, 20.0, sample_dt=0.01, retire=retire)
        assert (single.switch_time or np.nan) == pytest.approx(batch.switch_time[i], nan_ok=True)
        assert single.balanced() == batch.balanced[i]
        np.testing.assert_array_equal(batch.final_state[i], single.final_state)
        count = int(batch.trajectories["count"][i])
        np.testing.assert_array_equal(batch.trajectories["q"][i, :count], single.q)
        np.testing.assert_array_equal(batch.trajectories["tau"][i, :count], single.tau)
    if retire:
        assert np.any(batch.t_end < 20.0)  # some rollouts balanced for good before the end


@pytest.mark.slow  # 16 kips of 22 s twice, about 11 CPU-s; its small form is the next test
def test_retirement_changes_no_outcome(gymnast):
    """Rollouts stopped once their balance can no longer fail end as they would have (4 x 4 basin, 22 s)."""
    from paa_mj.studies.basin import basin_grid

    x0, _, _ = basin_grid((0, 1), 4)  # 13 of its 16 starts balance for good before 22 s
    full = simulate_batch(gymnast, x0, 22.0, retire=False)
    early = simulate_batch(gymnast, x0, 22.0, retire=True)
    for key in ("switch_time", "balanced", "diverged", "max_abs_tau", "success", "t_region", "t_balanced"):
        np.testing.assert_array_equal(getattr(early, key), getattr(full, key), err_msg=key)
    retired = early.t_end < 22.0
    assert retired.sum() > 10  # the test is not vacuous
    assert np.all(np.abs(early.final_state[retired][:, 3:]) < 1e-3)


@pytest.mark.parametrize("window", [1.0, 0.2])
def test_retirement_changes_no_success_under_a_tight_success_region(gymnast, window):
    """A success region tighter than the balance tolerance, and a start that enters it late: a run stopped early
    is judged as the whole run is (over the last window of the run it stands for, within the region)."""
    from paa_mj.task import Region, Task

    task = Task.named("folded", gymnast, success_region=Region(1e-4, 1e-4), success_window=window)
    x0 = np.concatenate([task.goal + [[2e-3, 0, 0], [-1e-3, 2e-3, 0], [0, 0, 1e-4]], np.zeros((3, 3))], axis=1)
    full = simulate_batch(gymnast, x0, 3.0, task=task, controller="lqr", retire=False)
    early = simulate_batch(gymnast, x0, 3.0, task=task, controller="lqr", retire=True)
    assert np.any(early.t_end < 3.0)  # some retired
    np.testing.assert_array_equal(early.success, full.success)
    inside = task.distance(early.final_state[:, :3], early.final_state[:, 3:]) < 1e-4
    assert np.all(inside[early.t_end < 3.0])  # retired only inside the success region


def test_batch_per_rollout_controllers_and_model_error(gymnast):
    x0 = np.tile(X0_HANGING, (2, 1))
    wrong = gymnast.params.scaled(mass_factor=1.05, length_factor=0.98)
    specs = [ControllerSpec("vcl", (4600.0, 17000.0, 4000.0)), ControllerSpec("vcl", None, wrong, check=False)]
    batch = simulate_batch(gymnast, x0, 3.0, controller=specs, record=True)
    one = simulate_mujoco(gymnast, specs[0], x0[0], 3.0)
    np.testing.assert_array_equal(batch.trajectories["q"][0, :len(one)], one.q)
    two = simulate_mujoco(gymnast, specs[1], x0[1], 3.0)
    np.testing.assert_array_equal(batch.trajectories["q"][1, :len(two)], two.q)
    assert np.max(np.abs(two.q - one.q)) > 1e-3


def test_batch_plant_perturbation(gymnast):
    heavier = gymnast.params.scaled(mass_factor=1.1)
    batch = simulate_batch(gymnast, X0_HANGING[None], 2.0, plants=[heavier], record=True)
    plant = gymnast.with_params(heavier)
    # the controller believes in the nominal robot on purpose; one built for the nominal robot is refused on another
    with pytest.raises(PaaError, match="was built for robot gymnast"):
        simulate_mujoco(plant, make_controller("vcl", gymnast), X0_HANGING, 2.0)
    single = simulate_mujoco(plant, ControllerSpec("vcl", believed=gymnast.params), X0_HANGING, 2.0)
    np.testing.assert_array_equal(batch.trajectories["q"][0, :len(single)], single.q)


def test_python_controllers_run_in_the_batch_engine(gymnast, random_starts):
    compiled = simulate_batch(gymnast, random_starts[:3], 2.0)
    slow = simulate_batch(gymnast, random_starts[:3], 2.0, controller=Uncompiled(make_controller("vcl", gymnast)))
    np.testing.assert_allclose(slow.final_state, compiled.final_state, atol=1e-9)


class _Kick:
    """Torques far beyond any motor: the rollout runs away at once."""

    def torque(self, q, qd, t=0.0):
        return np.full(np.shape(q)[:-1] + (2,), 1e12)


def test_batch_divergence_is_contained(gymnast):
    x0 = np.tile(X0_HANGING, (3, 1))
    batch = simulate_batch(gymnast, x0, 0.5, controller=["vcl", _Kick(), "vcl"])
    assert list(batch.diverged) == [False, True, False]
    assert np.all(np.isfinite(batch.final_state))
    np.testing.assert_array_equal(batch.final_state[0], batch.final_state[2])


def test_batch_bad_input(gymnast):
    with pytest.raises(PaaError, match=r"\(N, 6\)"):
        simulate_batch(gymnast, np.zeros((3, 5)), 1.0)
    with pytest.raises(PaaError, match="kD_min"):
        simulate_batch(gymnast, X0_HANGING[None], 1.0, controller=ControllerSpec("vcl", (100.0, 16000.0, 5000.0)))
    with pytest.raises(PaaError, match="one controller per rollout"):
        simulate_batch(gymnast, np.zeros((2, 6)), 1.0, controller=["vcl"] * 3)
    with pytest.raises(PaaError, match="torque limits must be > 0"):
        simulate_batch(gymnast, np.zeros((2, 6)), 1.0, torque_limit=-1.0)


def test_noise_is_seeded_per_rollout_not_per_chunk(gymnast):
    x0 = np.tile(X0_HANGING, (3, 1))
    a = simulate_batch(gymnast, x0, 1.0, disturbances=Disturbances(noise_std=[0.01, 0.01], seed=3))
    b = simulate_batch(gymnast, x0, 1.0, disturbances=Disturbances(noise_std=[0.01, 0.01], seed=3), nthread=1)
    c = simulate_batch(gymnast, x0, 1.0, disturbances=Disturbances(noise_std=[0.01, 0.01], seed=4))
    np.testing.assert_array_equal(a.final_state, b.final_state)
    assert np.max(np.abs(a.final_state - c.final_state)) > 1e-6
    assert np.max(np.abs(a.final_state[0] - a.final_state[1])) > 1e-6  # each rollout draws its own noise
    # rollout 2 alone, with its global number, draws what it drew in the batch
    alone = simulate_batch(gymnast, x0[2:], 1.0,
                           disturbances=Disturbances(noise_std=[0.01, 0.01], seed=3, rollout_ids=[2]))
    np.testing.assert_array_equal(alone.final_state[0], a.final_state[2])


def test_counter_based_noise_is_standard_normal():
    z = np.array([gaussian(7, r, s, k) for r in range(20) for s in range(250) for k in range(4)])
    assert abs(z.mean()) < 0.03 and abs(z.std() - 1) < 0.03
    assert abs(np.mean(np.abs(z) > 1.959964) - 0.05) < 0.01


def test_the_all_zero_counter_draws_no_outlier():
    """Seed 0 (every study's default), rollout 0, step 0, k 0 once mixed to 0 and drew 8.57 sigma every time."""
    z = np.array([gaussian(0, r, s, k) for r in range(3) for s in range(3) for k in range(3)])
    assert np.max(np.abs(z)) < 4.0


def test_delay_applies_the_torque_computed_d_steps_before(gymnast):
    d = 4
    batch = simulate_batch(gymnast, X0_HANGING[None], 0.2, disturbances=Disturbances(delay_steps=[d]), record=True,
                           sample_dt=0.001)
    n = int(batch.trajectories["count"][0])
    q, qd, tau = (batch.trajectories[k][0, :n] for k in ("q", "qd", "tau"))
    ctrl = make_controller("vcl", gymnast)
    computed = np.array([ctrl.torque(q[s], qd[s]) for s in range(len(q))])
    np.testing.assert_array_equal(tau[:d], 0.0)
    np.testing.assert_allclose(tau[d:], computed[:-d], rtol=1e-9)


def test_torque_limit_and_torque_noise(gymnast):
    clipped = simulate_batch(gymnast, X0_HANGING[None], 1.0, torque_limit=[50.0, 20.0])
    assert clipped.max_abs_tau[0, 0] == pytest.approx(50.0) and clipped.max_abs_tau[0, 1] == pytest.approx(20.0)
    quiet = simulate_batch(gymnast, X0_HANGING[None], 1.0, controller="passive", record=True, sample_dt=0.001)
    noisy = simulate_batch(gymnast, X0_HANGING[None], 1.0, controller="passive",
                           disturbances=Disturbances(torque_noise=2.0), record=True, sample_dt=0.001)
    assert np.all(quiet.trajectories["tau"] == 0)
    assert np.std(noisy.trajectories["tau"][0, :1000]) == pytest.approx(2.0, rel=0.1)
    assert np.all(noisy.trajectories["tau"][0, :1000] != 0)


def test_a_push_swings_the_passive_robot(gymnast):
    pushes = np.array([[[0.5, 0.1, 50.0, 0.0, 0.0]]])
    still = simulate_batch(gymnast, X0_HANGING[None], 2.0, controller="passive")
    pushed = simulate_batch(gymnast, X0_HANGING[None], 2.0, controller="passive",
                            disturbances=Disturbances(pushes=pushes))
    assert np.max(np.abs(still.final_state[0] - X0_HANGING)) < 1e-9
    assert pushed.max_speed[0] > 0.1


def test_effort_integrals_match_the_recorded_torques(gymnast):
    batch = simulate_batch(gymnast, X0_HANGING[None], 2.0, record=True, sample_dt=0.001, retire=False)
    n = int(batch.trajectories["count"][0])
    tau, qd = batch.trajectories["tau"][0, :n - 1], batch.trajectories["qd"][0, :n]
    dt = 1e-3
    np.testing.assert_allclose(batch.int_tau2[0], np.sum(tau**2) * dt, rtol=1e-9)
    # work over each step uses the speed after the step (the torque acts over the step)
    np.testing.assert_allclose(batch.work[0], np.sum(np.abs(np.sum(tau * qd[1:, 1:], 1))) * dt, rtol=1e-9)
    smooth = np.sqrt(np.sum(np.diff(batch.trajectories["tau"][0, :n], axis=0) ** 2) / dt**2 / 2000)
    np.testing.assert_allclose(batch.smoothness[0], smooth, rtol=1e-9)


def test_basin_cli(capsys, tmp_path):
    code = main(["basin", "--grid", "3", "--t-final", "2", "--axes", "q1,d2", "--json", "--out", str(tmp_path),
                 "--scheduler", "inline"])
    out = capsys.readouterr().out
    assert code == 0
    s = json.loads(out)
    assert s["cells"] == 9 and s["axes"] == ["q1", "d2"]
    assert 0.0 <= s["success"] <= 1.0
    assert "median_switch_time" in s and sum(s["outcomes"].values()) == 9
    data = np.load(tmp_path / "basin.npz")
    assert data["switch_time"].shape == (9,) and data["x0"].shape == (9, 6)
    assert np.all(data["x0"][:, [1, 2, 3, 5]] == 0)
    assert (tmp_path / "basin.png").read_bytes()[:4] == b"\x89PNG"
    assert (tmp_path / "basin.svg").read_text().lstrip().startswith("<?xml")


@pytest.mark.parametrize("args, fragment", [
    (["basin", "--axes", "q1"], "two different coordinates"),
    (["basin", "--axes", "q1,q1"], "two different coordinates"),
    (["basin", "--grid", "1"], "--grid must be an integer in [2,"),
    (["basin", "--controller", "lqr", "--kD", "5000"], "apply to the controllers"),
])
def test_basin_bad_input(capsys, args, fragment):
    assert main(args) == 2
    assert fragment in capsys.readouterr().err


def test_bench_reports_ratios_without_timing_assertions():
    from paa_mj.studies.bench import format_bench, run_bench

    r = run_bench(batch_size=8, batch_seconds=0.05, repeats=1, basin_grid=2, basin_seconds=0.1, vector_envs=4,
                  vector_steps=5, rollout_seconds=2.0, python_seconds=0.2, bare_steps=2000, realaigym=False,
                  kd_links=4)
    for key in ("bare_mj_step_us", "single_step_ratio", "batch_step_ratio", "basin_effective_ratio",
                "analytic_to_mujoco_ratio", "python_step_vs_hand_loop"):
        assert np.isfinite(r[key]) and r[key] > 0
    assert "basin_effective_ratio" in format_bench(r) and "python_step_vs_hand_loop" in format_bench(r)
    assert r["rollout_t_final"] == 2.0 and r["kd_min_certified"] and r["kd_min_boxes"] > 0
    if "mujoco_batch_vs_engine_ratio" in r:  # MuJoCo with its batch API: the head to head, and the two agree
        assert r["mujoco_batch_agreement"]["identical"] and "mujoco_batch_vs_engine_ratio" in format_bench(r)


def test_compile_leaves_no_kernel_to_compile_later():
    """``paa-mj compile`` reaches every cached kernel of the package (a new kernel needs a stage that calls it), and
    compiles each for one signature (a helper called with two array layouts would be compiled twice).

    In a process of its own: the signatures a process holds include those of every call it made before.
    """
    from paa_mj.precompile import cached_kernels

    proc = subprocess.run([sys.executable, "-m", "paa_mj.cli", "compile", "--json"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    report = json.loads(proc.stdout)
    assert report["uncached"] == [] and len(report["stages"]) == 6
    assert report["several_signatures"] == {}
    kernels = cached_kernels()
    assert len(kernels) >= 50 and report["cache"] in str(next(iter(kernels.values()))._cache._cache_path)


def test_robustness_cli(capsys, tmp_path):
    code = main(["robustness", "--trials", "2", "--t-final", "1", "--json", "--out", str(tmp_path),
                 "--model-error", "0", "3", "7", "15", "--scheduler", "inline"])
    s = json.loads(capsys.readouterr().out)
    assert code == 0
    assert set(s["factors"]) == {"noise", "torque_limit", "model_error", "delay"}
    for factor, data in s["factors"].items():
        assert len(data["levels"]) == 4
        for lv in data["levels"]:
            assert 0 <= lv["low"] <= lv["success_rate"] <= lv["high"] <= 1 and lv["trials"] == 2
        assert (tmp_path / f"robustness_{factor}.png").exists() and (tmp_path / f"robustness_{factor}.svg").exists()
    assert (tmp_path / "summary.json").exists() and (tmp_path / "robustness.npz").exists()


def test_robustness_every_factor_from_hanging(capsys):
    code = main(["robustness", "--trials", "1", "--t-final", "0.5", "--json", "--scheduler", "inline",
                 "--start", "hanging", "--factors", "torque_noise,pushes,initial_state"])
    s = json.loads(capsys.readouterr().out)
    assert code == 0 and s["start"] == "hanging"
    assert set(s["factors"]) == {"torque_noise", "pushes", "initial_state"}


def test_robustness_model_error_levels(capsys):
    assert main(["robustness", "--trials", "1", "--t-final", "0.5", "--json", "--scheduler", "inline",
                 "--model-error", "0", "12.5"]) == 0
    s = json.loads(capsys.readouterr().out)
    assert [lv["level"] for lv in s["factors"]["model_error"]["levels"]] == [0.0, 12.5]
    assert main(["robustness", "--model-error", "150"]) == 2
    assert "[0, 90]" in capsys.readouterr().err


def test_wilson_interval():
    from paa_mj.studies.robustness import wilson_interval

    low, high = wilson_interval(8, 10)
    assert low == pytest.approx(0.4902, abs=1e-4) and high == pytest.approx(0.9433, abs=1e-4)
    assert wilson_interval(0, 5)[0] == 0.0 and wilson_interval(5, 5)[1] == 1.0


USER_CONTROLLER = '''\
import numpy as np


class Damped:
    """A user's controller: PD towards the hanging posture on the motors."""

    def __init__(self, robot):
        self.gain = 0.05 * robot.analytic.b1

    def torque(self, q, qd, t):
        q, qd = np.asarray(q), np.asarray(qd)
        return -self.gain * (q[..., 1:] + 0.5 * qd[..., 1:])
'''


def test_users_controller_runs_from_the_command_line(tmp_path, capsys):
    path = tmp_path / "mine.py"
    path.write_text(USER_CONTROLLER)
    out = tmp_path / "run"
    assert main(["simulate", "--controller", f"{path}:Damped", "--t-final", "1", "--x0", "-3", "0.5", "-0.3", "0",
                 "0", "0", "--out", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["controller"] == "mine.py:Damped"  # as the user named it, as the studies say too
    data = np.load(out / "trajectory.npz")
    b1 = 289.53234
    expected = -0.05 * b1 * (data["q"][:, 1:] + 0.5 * data["qd"][:, 1:])
    np.testing.assert_allclose(data["tau"], expected, rtol=1e-12)  # the recorded torques are the class's
    assert main(["basin", "--controller", f"{path}:Damped", "--grid", "2", "--t-final", "1", "--json",
                 "--scheduler", "inline"]) == 0
    basin = json.loads(capsys.readouterr().out)
    assert basin["cells"] == 4 and basin["controller"] == "mine.py:Damped"


def test_users_controller_failures_are_one_line(tmp_path, capsys):
    path = tmp_path / "bad.py"
    path.write_text("import numpy as np\nclass Wrong:\n    def __init__(self, robot):\n        pass\n"
                    "    def torque(self, q, qd, t):\n        return np.zeros(3)\n")
    assert main(["simulate", "--controller", f"{path}:Wrong", "--t-final", "0.1"]) == 2
    err = capsys.readouterr().err
    assert "returned shape (3,)" in err and len(err.strip().splitlines()) == 1


def test_evaluate_from_a_given_switch_flag_keeps_the_laws_scratch():
    """``evaluate(..., memory=[0.0])`` (swing-up) and ``[1.0]`` (switched) on the chain's law, whose matrices live in
    the rest of the memory: the law's torques and the LQR's, and a memory longer than the controller's refused."""
    import warnings

    from paa_mj.model import load_robot
    from paa_mj.sim.compiled.engine import evaluate

    chain = load_robot("chain4")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        vcl = make_controller("vcl", chain)
    form = vcl.compiled()
    q, qd = np.array([[-3.0, -3.0, 0.1, 0.2]]), np.array([[0.1, 0.0, 0.0, 0.0]])
    swing, mode = evaluate(form, q, qd, memory=[0.0])
    assert mode[0] == 0 and np.array_equal(swing, vcl.first.torque(q, qd, 0.0))
    balance, mode = evaluate(form, q, qd, memory=[1.0])
    assert mode[0] == 1 and np.array_equal(balance, vcl.second.torque(q, qd, 0.0))
    with pytest.raises(PaaError, match="memory of 1001 numbers given; this controller keeps"):
        evaluate(form, q, qd, memory=np.zeros(1001))
