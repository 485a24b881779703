"""The region of attraction of the balance LQR (67): paa_mj.theory.roa, paa_mj.theory.sos and ``paa-mj roa``."""
import json
import math

import numpy as np
import pytest

from paa_mj.errors import PaaError
from paa_mj.model import load_robot
from paa_mj.task import Task
from paa_mj.theory import roa, sos
from paa_mj.theory.linear import sampled_spectral_radius

CUBIC = [None, np.array([[-1.0]]), np.zeros((1, 1, 1)), np.ones((1, 1, 1, 1))]  # xdot = -x + x^3


def test_the_cubic_bound_along_rays_is_its_known_region():
    # V = x^2, dV/dt = -2 x^2 + 2 x^4 turns at |x| = 1: the region of attraction is exactly |x| < 1
    assert sos.sampled_bound(CUBIC, np.eye(1), samples=10) == pytest.approx(1.0)
    assert sos.polynomial_value(CUBIC, np.array([[0.5]]))[0, 0] == pytest.approx(-0.5 + 0.125)


def test_the_sos_certificate_tends_to_the_known_region_from_below():
    pytest.importorskip("pydrake")
    rho, at_top = sos.sos_level(np.eye(1), CUBIC, 1e-6, 1.0, bisections=10)
    assert not at_top and 0.98 < rho < 1.0
    rho, at_top = sos.sos_level(np.eye(1), CUBIC, 1e-6, 0.5)
    assert at_top and rho == 0.5


class _DoubleIntegrator:
    def linearize(self, goal):
        return np.array([[0.0, 1.0], [0.0, 0.0]]), np.array([[0.0], [1.0]])


def test_the_sampled_spectral_radius_by_hand():
    # zero-order hold of the double integrator: Ad = [[1, h], [0, 1]], Bd = [h^2 / 2, h]
    k1, k2, h = 40.0, 3.0, 0.1
    phi = np.array([[1 - k1 * h * h / 2, h - k2 * h * h / 2], [-k1 * h, 1 - k2 * h]])
    trace, det = np.trace(phi), np.linalg.det(phi)
    roots = np.roots([1.0, -trace, det])
    assert sampled_spectral_radius(_DoubleIntegrator(), [[k1, k2]], h, Task.named("folded", 2)) == \
        pytest.approx(max(abs(roots)), rel=1e-12)


def test_the_fraction_of_the_box_inside_a_ball():
    task = Task.named("folded", 2)
    a, s = task.switch_region.angle, task.switch_region.speed
    S = np.diag([1 / a**2, 1 / a**2, 1 / s**2, 1 / s**2])
    out = roa.fraction_inside(task, S, 1.0, samples=100000, seed=3)
    ball = math.pi**2 / 2 / 16  # the unit 4-ball in the cube [-1, 1]^4
    assert out["samples"] == 100000 and out["seed"] == 3
    assert abs(out["fraction"] - ball) < 4 * math.sqrt(ball * (1 - ball) / 100000)
    assert roa.fraction_inside(task, S, 4.0 + 1e-9, 1000)["fraction"] == 1.0
    assert roa.fraction_inside(task, S, 1e-12, 1000)["fraction"] == 0.0


def test_the_torque_level_just_reaches_the_limit():
    rng = np.random.default_rng(0)
    L = rng.standard_normal((4, 4))
    S, K = L @ L.T + 4 * np.eye(4), rng.standard_normal((1, 4))
    level = roa.torque_level(S, K, 2.0)
    x = roa.on_ellipsoid(S, level, 20000, rng)
    assert np.max(np.abs(x @ K.T)) <= 2.0 + 1e-9 and np.max(np.abs(x @ K.T)) > 1.99
    assert roa.torque_level(S, K, None) is None and roa.torque_level(S, K, np.inf) is None


def test_methods_refused_in_one_line():
    with pytest.raises(PaaError, match="use one of sos, sampling"):
        roa.choose_method("najafi", 2)
    if sos.drake_available():
        with pytest.raises(PaaError, match="limited to chains of 4 links"):
            roa.choose_method("sos", 5)


def test_the_compiled_level_condition_is_the_numpy_one():
    from paa_mj.control.combined import LevelCondition
    from paa_mj.control.region import level_value

    task = Task.named("folded", 3)
    rng = np.random.default_rng(1)
    L = rng.standard_normal((6, 6))
    condition = LevelCondition(task, L @ L.T, 2.0)
    q, qd = task.goal + rng.normal(0, 0.5, (20, 3)), rng.normal(0, 0.5, (20, 3))
    numpy_margin = condition.margin(q, qd, 0.0)
    compiled = [level_value(condition.params, np.concatenate([q[k], qd[k]])) for k in range(20)]
    assert np.allclose(numpy_margin, compiled, rtol=1e-12, atol=1e-12)


def _roa_json(capsys, *extra):
    from paa_mj.cli import main

    code = main(["roa", "--robot", "acrobot", "--goal", "stretched", "--check", "4", "--json", *extra])
    out = capsys.readouterr()
    return code, out.out, out.err


def test_the_command_states_its_set_and_gives_the_same_bytes_twice(capsys):
    pytest.importorskip("pydrake")
    code, first, _ = _roa_json(capsys, "--method", "sos")
    assert code == 0
    summary = json.loads(first)
    for key in ("S", "rho", "method", "certified", "spectral_radius", "dt", "fraction_of_switch_region_inside",
                "u_max", "mujoco_check", "rho_torque", "vdot_check", "goal", "task"):
        assert key in summary, key
    assert summary["method"] == "sos" and summary["certified"] is True and summary["u_max"] == [20.0]
    assert summary["rho"] == pytest.approx(min(summary["rho_sos"], summary["rho_torque"]))
    assert summary["fraction_of_switch_region_inside"]["samples"] > 0
    assert summary["mujoco_check"]["states"] == 4 and summary["mujoco_check"]["reached"] == 4
    assert summary["vdot_check"]["rising"] == 0
    assert _roa_json(capsys, "--method", "sos")[1] == first


@pytest.mark.parametrize("args, words", [(["--method", "najafi"], "invalid choice"),
                                          (["--samples", "0"], "must be >= 1"),
                                          (["--controller", "vcl"], "invalid choice"),
                                          (["--robot", "nowhere.xml"], "nowhere.xml")])
def test_bad_input_is_one_line_and_exit_2(capsys, args, words):
    from paa_mj.cli import main

    code = main(["roa", "--json", *args])
    err = capsys.readouterr().err
    assert code == 2 and words in err and len(err.strip().splitlines()) == 1


@pytest.mark.parametrize("name", ["vcl", "vc"])
def test_the_roa_named_controllers_are_the_switch_option(name):
    from paa_mj.control.combined import LevelCondition
    from paa_mj.control.registry import ControllerSpec
    from paa_mj.model import load_robot

    robot = load_robot("gymnast")
    task = Task.named("folded", robot)
    named = ControllerSpec(f"{name}-roa", task=task).build(robot)
    option = ControllerSpec(name, options=(("switch", "roa"),), task=task).build(robot)
    assert isinstance(named.condition, LevelCondition) and named.name == f"{name}-roa"
    assert np.array_equal(named.condition.S, option.condition.S) and named.condition.rho == option.condition.rho
    rng = np.random.default_rng(0)
    q, qd = task.goal + rng.normal(0, 0.3, (64, 3)), rng.normal(0, 0.5, (64, 3))
    assert np.array_equal(named.condition.holds(q, qd, 0.0), option.condition.holds(q, qd, 0.0))


def test_the_roa_hand_over_takes_the_runs_torque_limit():
    """simulate --switch roa --torque-limit T hands over on the level of the LQR's region of attraction with the
    limit T the run applies (paa-mj roa --torque-limit T's), not on the model's unlimited one."""
    from argparse import Namespace

    from paa_mj.cli.common import spec_from_args
    from paa_mj.control.registry import ControllerSpec
    from paa_mj.model import load_robot
    from paa_mj.theory.linear import lqr_solution, lqr_weight_matrices

    robot = load_robot("gymnast")  # no actuator ranges
    task = Task.named("folded", robot)
    args = Namespace(controller="vcl", switch="roa", torque_limit=20.0, lqr_weights=None, kD=None, kP=None, kV=None)
    limited = spec_from_args(args, robot, task).build(robot)
    Q, R = lqr_weight_matrices(3)
    K, S = lqr_solution(robot.analytic, task, Q, R)
    assert limited.condition.rho <= roa.torque_level(S, K, np.array([20.0, 20.0])) * (1 + 1e-12)
    assert limited.describe()["switch_level"] == limited.condition.rho
    free = ControllerSpec("vcl", options=(("switch", "roa"),), task=task).build(robot)
    assert free.condition.rho > limited.condition.rho
    named = spec_from_args(Namespace(**{**vars(args), "controller": "vcl-roa", "switch": None}), robot, task)
    assert named.build(robot).condition.rho == limited.condition.rho
    with pytest.raises(PaaError, match="region of attraction"):
        ControllerSpec("vcl", options=(("limit", (20.0, 20.0)),), task=task).build(robot)
    # the leaderboard runs each controller under its one torque limit: its roa hand-over takes the same level
    from paa_mj.studies.compare import _spec

    board = _spec("vcl-roa", np.array([20.0, 20.0]), task).build(robot)
    assert board.condition.rho == limited.condition.rho


def test_a_sampling_estimate_beyond_a_day_is_refused_in_one_line(capsys, monkeypatch, tmp_path):
    """Its steps counted before any is run: levels x horizon / dt at the cost of a step of a chain of n links."""
    from paa_mj.cli import main

    monkeypatch.setenv("PAA_MJ_CACHE", str(tmp_path))  # no region kept by an earlier run: this one is estimated

    monkeypatch.setattr(roa, "SIMULATED_STEP_SECONDS", 10.0)  # as a long chain at a tiny time step costs
    code = main(["roa", "--method", "sampling", "--json"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and "the sampling estimate would simulate up to 17 levels" in err
    assert "days of computing (the limit is 24 hours); use --method sos (up to 4 links)" in err


def test_the_sampling_estimate_drops_below_a_state_inside_that_fails(monkeypatch):
    """A boundary whose states all return says nothing of the states within: a band inside that never returns (a
    stand-in simulation) pulls the level below it."""
    robot = load_robot("acrobot")
    task = Task.named("stretched", robot)
    S, K = np.eye(4), np.zeros((1, 4))
    band = (0.4, 0.6)

    def stand_in(am, task, K, u_max, dt, x0, horizon, S=None, stop_level=None, bar=None):
        V = np.einsum("ki,ij,kj->k", x0, S, x0)
        return np.where(((V > band[0]) & (V < band[1]))[:, None], np.nan, 0.0 * x0)

    monkeypatch.setattr(roa, "simulate_errors", stand_in)
    estimate = roa.simulated_level(robot.analytic, task, K, S, None, 1e-3, 1.0, samples=256, horizon=1.0)
    assert 0.99 * 0.4 * 0.99 <= estimate["rho"] <= band[0] and not estimate["at_top"]
    monkeypatch.setattr(roa, "simulate_errors", lambda *args, **kwargs: 0.0 * args[5])
    assert roa.simulated_level(robot.analytic, task, K, S, None, 1e-3, 1.0, samples=16, horizon=1.0)["at_top"]


def test_a_check_that_finds_states_inside_failing_says_so_on_stderr(capsys, monkeypatch, tmp_path):
    from paa_mj.cli import main
    from paa_mj.cli import roa as roa_command

    monkeypatch.setenv("PAA_MJ_CACHE", str(tmp_path))  # the stand-in region is kept here, not in the user's cache

    monkeypatch.setattr(roa, "simulated_level", lambda *args, **kwargs: {"rho": 1.0, "at_top": False, "samples": 4,
                                                                          "seed": 0, "horizon": 1.0})
    monkeypatch.setattr(roa_command, "mujoco_check", lambda *args, **kwargs: ({"states": 5, "reached": 3}, []))
    code = main(["roa", "--robot", "acrobot", "--method", "sampling", "--json"])
    err = capsys.readouterr().err
    assert code == 0 and "2 of 5 states inside x'Sx <= 1 did not reach the goal in MuJoCo" in err
    assert "more --samples" in err
