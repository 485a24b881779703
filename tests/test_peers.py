"""Spong's acrobot swing-up (``spong``) and ``paa-mj peers``: paa_mj against Drake.

The tests that need Drake are skipped, with the reason, where pydrake is not installed.
"""
import json
import math
import sys

import numpy as np
import pytest

from paa_mj.cli import main
from paa_mj.control.registry import make_controller
from paa_mj.errors import PaaError
from paa_mj.model.robot import load_robot

NEEDS_DRAKE = 'Drake is not installed (pip install "paa_mj[peers]")'


@pytest.fixture(scope="module")
def acrobot():
    return load_robot("acrobot")


@pytest.fixture(scope="module")
def spong(acrobot):
    return make_controller("spong", acrobot, task="stretched")


# --- an independent statement of Drake's law, in Drake's coordinates, from AcrobotParams' defaults ---------

M1, M2, L1, LC1, LC2, IC1, IC2, B1, B2, G = 1.0, 1.0, 1.0, 0.5, 1.0, 0.083, 0.33, 0.1, 0.1, 9.81


def drake_mass(t2):
    I1, I2, k = IC1 + M1 * LC1**2, IC2 + M2 * LC2**2, M2 * L1 * LC2
    m12 = I2 + k * math.cos(t2)
    return np.array([[I1 + I2 + M2 * L1**2 + 2 * k * math.cos(t2), m12], [m12, I2]])


def drake_bias(t1, t2, w1, w2):
    k = M2 * L1 * LC2
    s1, s2, s12 = math.sin(t1), math.sin(t2), math.sin(t1 + t2)
    return np.array([-2 * k * s2 * w2 * w1 - k * s2 * w2**2 + G * M1 * LC1 * s1 + G * M2 * (L1 * s1 + LC2 * s12)
                     + B1 * w1,
                     k * s2 * w1**2 + G * M2 * LC2 * s12 + B2 * w2])


def drake_derivative(x, u):
    t1, t2, w1, w2 = x
    return np.concatenate([[w1, w2], np.linalg.solve(drake_mass(t2), np.array([0.0, u]) - drake_bias(*x))])


def drake_swing_up(x, k_e=5.0, k_p=50.0, k_d=5.0):
    """spong_controller.h's swing-up law, clamped at 20 N m."""
    t1, t2, w1, w2 = x
    M = drake_mass(t2)
    bias = drake_bias(*x)
    inverse = np.linalg.inv(M)
    energy = 0.5 * np.array([w1, w2]) @ M @ np.array([w1, w2]) \
        - M1 * G * LC1 * math.cos(t1) - M2 * G * (L1 * math.cos(t1) + LC2 * math.cos(t1 + t2))
    desired = (M1 * LC1 + M2 * (L1 + LC2)) * G
    y = -k_p * t2 - k_d * w2
    u = -k_e * (energy - desired) * w2 + (inverse[0, 1] * bias[0] + y) / inverse[1, 1] + bias[1]
    return float(np.clip(u, -20.0, 20.0))


def drake_lqr_by_differences():
    """S, K of the LQR at (pi, 0, 0, 0) with Q = diag(10, 10, 1, 1), R = 1, on a central-difference linearisation."""
    from scipy.linalg import solve_continuous_are

    x0, h = np.array([math.pi, 0.0, 0.0, 0.0]), 1e-6
    A = np.column_stack([(drake_derivative(x0 + h * e, 0.0) - drake_derivative(x0 - h * e, 0.0)) / (2 * h)
                         for e in np.eye(4)])
    B = ((drake_derivative(x0, h) - drake_derivative(x0, -h)) / (2 * h))[:, None]
    S = solve_continuous_are(A, B, np.diag([10.0, 10.0, 1.0, 1.0]), np.eye(1))
    return S, B.T @ S


def to_drake(q, qd):
    return np.array([q[0] + math.pi, q[1], qd[0], qd[1]])


def test_spong_swing_up_is_drakes_law_in_paa_coordinates(spong):
    rng = np.random.default_rng(3)
    q = rng.uniform(-7, 7, (300, 2))
    qd = rng.uniform(-6, 6, (300, 2))
    tau = spong.torque(q, qd)
    assert tau.shape == (300, 1) and spong.mode.shape == (300,)
    swinging = spong.mode == 0
    assert swinging.sum() > 250  # far from the upright: the swing-up law acts
    expected = np.array([drake_swing_up(to_drake(a, b)) for a, b in zip(q, qd)])
    assert np.max(np.abs(tau[swinging, 0] - expected[swinging])) < 1e-9
    assert np.any(np.abs(expected) >= 20.0) and np.max(np.abs(tau)) <= 20.0  # the clamp acts and holds


def test_spong_balances_with_drakes_lqr_and_wrapping(spong):
    S, K = drake_lqr_by_differences()
    assert np.allclose(spong.S, S, rtol=1e-5) and np.allclose(spong.K, K, rtol=1e-5)
    rng = np.random.default_rng(4)
    q = rng.normal(0.0, 0.05, (200, 2)) + 2 * np.pi * rng.integers(-3, 4, (200, 2))  # upright, whole turns away
    qd = rng.normal(0.0, 0.1, (200, 2))
    tau = spong.torque(q, qd)
    assert np.all(spong.mode == 1)
    e = np.concatenate([(q + np.pi) % (2 * np.pi) - np.pi, qd], axis=1)
    assert np.allclose(tau[:, 0], np.clip(-(e @ K.T)[:, 0], -20, 20), rtol=1e-5, atol=1e-8)
    cost = np.einsum("ni,ij,nj->n", e, S, e)
    assert np.allclose(spong.cost_to_go(q, qd), cost, rtol=1e-5)
    # the switch is the cost-to-go against 1e3, state by state, without memory
    far = np.array([0.0, 0.0]), np.array([0.0, 3.0])
    assert spong.cost_to_go(*far) > 1e3
    spong.torque(np.stack([q[0], far[0]]), np.stack([qd[0], far[1]]))
    assert spong.mode.tolist() == [1, 0]
    spong.torque(q[:1], qd[:1])
    assert spong.mode.tolist() == [1]


def test_spong_compiled_form_gives_the_same_torques(spong):
    from paa_mj.sim.compiled.engine import evaluate

    rng = np.random.default_rng(5)
    q = np.concatenate([rng.uniform(-4, 4, (50, 2)), rng.normal(0, 0.05, (50, 2))])
    qd = np.concatenate([rng.uniform(-4, 4, (50, 2)), rng.normal(0, 0.1, (50, 2))])
    tau, modes = evaluate(spong.compiled(), q, qd)
    assert np.array_equal(tau, spong.torque(q, qd)) and np.array_equal(modes, spong.mode)


def test_spong_refuses_other_robots_and_goals(acrobot):
    with pytest.raises(PaaError, match="2 links"):
        make_controller("spong", load_robot("gymnast"), task="stretched")
    with pytest.raises(PaaError, match="--goal stretched"):
        make_controller("spong", acrobot)


def test_spong_balances_the_acrobot_in_mujoco(acrobot, spong):
    """From a corner of Drake's example_stochastic_scenario.yaml: switched at 1.127 s, balanced for good."""
    from paa_mj.sim.rollout import simulate_mujoco

    theta0 = np.array([1.1, -0.1, -0.1, -0.1])
    x0 = np.concatenate([[theta0[0] - np.pi], theta0[1:]])
    traj = simulate_mujoco(acrobot, spong, x0, t_final=7.0, task="stretched")
    assert traj.switch_time == pytest.approx(1.127, abs=2e-3)
    assert traj.balanced() and np.all(traj.mode[traj.t > 2.0] == 1)


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    pytest.importorskip("pydrake", reason=NEEDS_DRAKE)
    out = tmp_path_factory.mktemp("peers")
    code = main(["peers", "--out", str(out), "--quick", "--samples", "40"])
    assert code == 0
    return out, json.loads((out / "peers.json").read_text())


def test_spong_is_drakes_controller(spong):
    pytest.importorskip("pydrake", reason=NEEDS_DRAKE)
    from pydrake.examples import AcrobotSpongController

    drake = AcrobotSpongController()
    context = drake.CreateDefaultContext()
    rng = np.random.default_rng(6)
    worst = 0.0
    for i in range(400):
        x = np.concatenate([rng.uniform(-7, 7, 2), rng.uniform(-6, 6, 2)]) if i % 2 else \
            np.array([np.pi, 0, 0, 0]) + rng.normal(0, 0.1, 4)
        drake.get_input_port(0).FixValue(context, x)
        u = drake.get_output_port(0).Eval(context)[0]
        worst = max(worst, abs(u - spong.torque(np.array([x[0] - np.pi, x[1]]), x[2:])[0]))
    assert worst < 1e-9


def test_peers_quick_writes_its_files_and_meets_the_targets(quick):
    out, summary = quick
    for name in ("peers.json", "peers.md", "peers_closed_loop.png", "peers_closed_loop.svg"):
        assert (out / name).stat().st_size > 0
    assert "| drake-example" in (out / "peers.md").read_text()
    rows = summary["dynamics"]
    assert {"acrobot", "gymnast", "random3", "acrobot (Drake's AcrobotPlant)"} <= {r["robot"] for r in rows}
    for row in rows:
        for pair in ("drake_vs_analytic", "drake_vs_mujoco"):
            for key, value in row.get(pair, {}).items():
                assert value < 1e-9, (row["robot"], pair, key, value)
    loop = summary["closed_loop"]
    assert loop["lqr"]["S_relative_difference"] < 1e-9 and loop["lqr"]["K_relative_difference"] < 1e-9
    for row in loop["starts"]:
        assert row["max_angle_difference"] < 1e-5 and row["max_speed_difference"] < 1e-5, row["start"]
        assert row["same_outcome"] and row["switch_split"] is None
        assert row["first_lqr"]["drake"] == pytest.approx(row["first_lqr"]["paa_mj"], abs=1e-9)
    # without the hold, off the elbow's invariant rest, the difference before the first switch shrinks with dt
    theta = next(r for r in loop["starts"] if r["start"] == "theta-1-1")
    coarse, fine = (case["before_first_switch"]["max_angle_difference"]
                    for case in sorted(theta["no_hold"], key=lambda c: -c["dt"]))
    assert fine < 0.7 * coarse
    # what is left with the hold is MuJoCo's integration error: it falls with the step
    check = loop["integration_check"]["max_difference"]
    assert check["0.0005"] < check["0.001"] / 8


def test_peers_without_drake_says_how_to_install_it(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "pydrake", None)  # import pydrake raises ImportError
    assert main(["peers", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert err == 'paa-mj: error: paa-mj peers needs Drake: pip install "paa_mj[peers]"'
    assert not (tmp_path / "out").exists()


def test_spong_wraps_as_drake_so_its_lqr_set_meets_the_elbows_wrap(spong):
    """theta2 wrapped to [-pi, pi): just below -pi is +pi - 1e-5, where (with the elbow folded back, link 1 far from
    up) the cost-to-go is below 1e3; just above, it is 1.3e5. Where the loops split at 14.578 s from paa-stretched."""
    from paa_mj.studies.peers import split_kind

    below = np.array([-10.17461314, -np.pi - 1.1e-5]), np.array([-10.76027066, 4.24208211])
    above = np.array([-10.17461314, -np.pi + 1.1e-5]), below[1]
    assert spong.cost_to_go(*below) < 200 and spong.cost_to_go(*above) > 1e5
    spong.torque(np.stack([below[0], above[0]]), np.stack([below[1], above[1]]))
    assert spong.mode.tolist() == [1, 0]
    theta = [np.concatenate([[q[0] + np.pi], [q[1]], qd]) for q, qd in (below, above)]
    assert split_kind(theta[0], theta[1], 163.0, 1.3e5, 1e3) == "wrap of theta2"
    assert split_kind(theta[0], theta[0] + [0.5, 0, 0, 0], 990.0, 1010.0, 1e3) == "threshold"
    assert split_kind(theta[0], theta[0] + [0.5, 0, 0, 0], 500.0, 5000.0, 1e3) == "grown difference"
