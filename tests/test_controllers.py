"""Controller (40), (67), (68): the Lyapunov identity (36) and the pieces around it."""
import warnings

import numpy as np
import pytest

from paa_mj.controllers import (EnergyVCLController, LQRController, SwitchingController, TheoryWarning,
                                in_switch_region, switch_margin, wrap_angle)
from paa_mj.errors import PaaError
from paa_mj.theory import Q_UDD
from paa_mj.vcl import psi, theta

from .conftest import GAINS1, GAINS2


def _random_states(rng, n):
    q = rng.uniform(-2 * np.pi, 2 * np.pi, (n, 3))
    qd = rng.uniform(-5, 5, (n, 3))
    return q, qd


@pytest.mark.parametrize("robot, gains", [("gymnast", GAINS1), ("example2", GAINS2)])
def test_lyapunov_rate_equals_minus_kV_qd_a_squared(robot, gains, request, rng):
    """(36) via the chain rule with the analytic dynamics: relative 1e-8."""
    am = request.getfixturevalue(robot).analytic
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TheoryWarning)
        ctrl = EnergyVCLController(am, **gains)
    q, qd = _random_states(rng, 2000)
    expected = -gains["kV"] * np.sum(qd[:, 1:] ** 2, -1)
    got = ctrl.lyapunov_rate(q, qd)
    assert np.max(np.abs(got - expected) / np.abs(expected)) < 1e-8


def test_lyapunov_rate_by_finite_differences_along_the_flow(gymnast, rng):
    """(36) again, with V differentiated numerically along x_dot (5-point stencil)."""
    am = gymnast.analytic
    ctrl = EnergyVCLController(am, **GAINS1)
    q, qd = _random_states(rng, 200)
    tau = ctrl.torque(q, qd)
    qdd = am.acceleration(q, qd, tau)
    h = 1e-4

    def V_at(s):
        # tau held fixed: V's rate along the flow depends on tau only through qdd.
        return ctrl.lyapunov(q + s * h * qd, qd + s * h * qdd)

    dV = (V_at(-2) - 8 * V_at(-1) + 8 * V_at(1) - V_at(2)) / (12 * h)
    expected = -GAINS1["kV"] * np.sum(qd[:, 1:] ** 2, -1)
    assert np.max(np.abs(dV - expected) / np.abs(expected)) < 1e-6


def test_a_wrong_torque_breaks_the_identity(gymnast, rng):
    am = gymnast.analytic
    ctrl = EnergyVCLController(am, **GAINS1)
    q, qd = _random_states(rng, 100)
    rate = ctrl.lyapunov_rate(q, qd, tau=ctrl.torque(q, qd) * 1.001)
    expected = -GAINS1["kV"] * np.sum(qd[:, 1:] ** 2, -1)
    assert np.median(np.abs(rate - expected) / np.abs(expected)) > 1e-6


def test_psi_is_the_derivative_of_theta(gymnast):
    b2, b3 = gymnast.analytic.b2, gymnast.analytic.b3
    z = np.linspace(-6, 6, 101)
    h = 1e-6
    numeric = (theta(b2, b3, z + h) - theta(b2, b3, z - h)) / (2 * h)
    np.testing.assert_allclose(psi(b2, b3, z), numeric, rtol=1e-7, atol=1e-9)
    assert theta(b2, b3, 0.0) == 0.0


def test_batched_torque_equals_one_at_a_time(gymnast, rng):
    ctrl = EnergyVCLController(gymnast.analytic, **GAINS1)
    q, qd = _random_states(rng, 20)
    batch = ctrl.torque(q, qd)
    single = np.array([ctrl.torque(q[i], qd[i]) for i in range(20)])
    np.testing.assert_allclose(batch, single, rtol=1e-13)


def test_gain_validation(gymnast, example2):
    with pytest.raises(PaaError, match=r"kD = 4500 is not above kD_min = 4503\.\d+ of \(41\)"):
        EnergyVCLController(gymnast.analytic, kD=4500, kP=16000, kV=5000)
    with pytest.warns(TheoryWarning, match=r"kP = 10000 is not above eta1 = 1586\d\.\d+ of \(59\)"):
        EnergyVCLController(gymnast.analytic, kD=4550, kP=10000, kV=5000)
    with pytest.warns(TheoryWarning, match=r"constraint \(54\) fails"):
        EnergyVCLController(example2.analytic, **GAINS2)
    with pytest.raises(PaaError, match="kV"):
        EnergyVCLController(gymnast.analytic, kD=4550, kP=16000, kV=0)


def test_wrap_and_switch_region():
    assert wrap_angle(np.pi) == pytest.approx(np.pi)
    assert wrap_angle(-np.pi) == pytest.approx(np.pi)
    assert wrap_angle(3 * np.pi / 2) == pytest.approx(-np.pi / 2)
    q = Q_UDD + [2 * np.pi, 0.1, -0.1]
    assert in_switch_region(q, np.zeros(3))
    assert switch_margin(q, np.zeros(3)) < 0
    assert not in_switch_region(q, np.array([0.0, 0.6, 0.0]))
    assert not in_switch_region(Q_UDD + [0, np.pi / 6 + 1e-9, 0], np.zeros(3))


def test_switch_is_one_way(gymnast):
    ctrl = SwitchingController.for_model(gymnast.analytic, **GAINS1)
    assert ctrl.mode == 0
    ctrl.torque(Q_UDD, np.zeros(3))
    assert ctrl.mode == 1
    ctrl.torque(np.array([-np.pi, 0, 0]), np.zeros(3))
    assert ctrl.mode == 1
    ctrl.reset()
    assert ctrl.mode == 0


def test_lqr_and_torque_limit(gymnast):
    lqr = LQRController.for_model(gymnast.analytic, torque_limit=50.0)
    tau = lqr.torque(Q_UDD + [0.3, 0.0, 0.0], np.zeros(3))
    assert np.all(np.abs(tau) <= 50.0)
    assert np.all(lqr.torque(Q_UDD, np.zeros(3)) == 0)
