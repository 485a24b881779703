"""Controllers (40), (12), (67), (68): the Lyapunov identity (36), the interface, the registry."""
import warnings

import numpy as np
import pytest

from paa_mj.control import (CombinedController, ConventionalController, ControllerSpec, EnergyVCLController,
                            LQRController, RegionCondition, TheoryWarning, TimeCondition, make_controller)
from paa_mj.errors import PaaError
from paa_mj.model.states import Q_UDD, wrap_angle
from paa_mj.model.vcl import psi, theta
from paa_mj.sim.compiled.engine import evaluate
from paa_mj.task import Task

from .conftest import GAINS1, GAINS2

FOLDED = Task.named("folded", 3)


def _random_states(rng, n):
    q = rng.uniform(-2 * np.pi, 2 * np.pi, (n, 3))
    qd = rng.uniform(-5, 5, (n, 3))
    return q, qd


@pytest.mark.parametrize("cls", [EnergyVCLController, ConventionalController])
@pytest.mark.parametrize("robot, gains", [("gymnast", GAINS1), ("example2", GAINS2)])
def test_lyapunov_rate_equals_minus_kV_qd_a_squared(cls, robot, gains, request, rng):
    """(36) via the chain rule with the analytic dynamics: relative 1e-8, for (40) and for (12)."""
    am = request.getfixturevalue(robot).analytic
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TheoryWarning)
        ctrl = cls(am, **gains)
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


def test_conventional_and_vcl_differ_where_q3_is_not_zero(gymnast, rng):
    q, qd = _random_states(rng, 50)
    a = make_controller("vcl-only", gymnast).torque(q, qd)
    b = make_controller("vc-only", gymnast).torque(q, qd)
    assert np.median(np.abs(a - b)) > 1e-3
    q[:, 1], q[:, 2] = -np.pi, 0.0  # q_a = q_ar: both errors vanish, the rest of the law is common
    c, d = make_controller("vcl-only", gymnast).torque(q, qd), make_controller("vc-only", gymnast).torque(q, qd)
    np.testing.assert_allclose(c, d, rtol=1e-12, atol=1e-9)


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
    assert FOLDED.in_switch_region(q, np.zeros(3))
    assert FOLDED.switch_margin(q, np.zeros(3)) < 0
    assert not FOLDED.in_switch_region(q, np.array([0.0, 0.6, 0.0]))
    assert not FOLDED.in_switch_region(Q_UDD + [0, np.pi / 6 + 1e-9, 0], np.zeros(3))


def test_switch_is_one_way(gymnast):
    ctrl = make_controller("vcl", gymnast)
    assert ctrl.mode == 0
    ctrl.torque(Q_UDD, np.zeros(3))
    assert ctrl.mode == 1
    ctrl.torque(np.array([-np.pi, 0, 0]), np.zeros(3))
    assert ctrl.mode == 1
    ctrl.reset()
    assert ctrl.mode == 0


def test_time_condition_hands_over_at_its_time(gymnast):
    ctrl = CombinedController(make_controller("passive", gymnast), LQRController.for_model(gymnast.analytic, FOLDED),
                              TimeCondition(0.5))
    q = Q_UDD + [0.1, 0, 0]
    assert np.all(ctrl.torque(q, np.zeros(3), t=0.2) == 0) and ctrl.mode == 0
    assert np.any(ctrl.torque(q, np.zeros(3), t=0.5) != 0) and ctrl.mode == 1
    tau, modes = evaluate(ctrl.compiled(), np.tile(q, (2, 1)), np.zeros((2, 3)), t=0.7)
    assert list(modes) == [1, 1] and np.all(tau != 0)


def test_combined_of_a_python_controller_has_no_compiled_form(gymnast):
    class Half:
        def torque(self, q, qd, t):
            return 0.5 * make_controller("lqr", gymnast).torque(q, qd, t)

    ctrl = CombinedController(Half(), make_controller("lqr", gymnast), RegionCondition(FOLDED))
    assert ctrl.compiled() is None
    assert ctrl.torque(np.tile(Q_UDD, (3, 1)), np.zeros((3, 3))).shape == (3, 2)


def test_lqr_gain_shape_is_checked():
    with pytest.raises(PaaError, match="2 x 6"):
        LQRController(np.ones((2, 5)), FOLDED)


@pytest.mark.parametrize("spec, fragment", [
    ("nosuch", "unknown controller 'nosuch'"),
    ("/nonexistent/ctrl.py:Foo", "controller file not found"),
])
def test_registry_errors(spec, fragment, gymnast):
    with pytest.raises(PaaError, match=fragment):
        make_controller(spec, gymnast)


def test_gains_only_for_gain_controllers():
    with pytest.raises(PaaError, match="apply to the controllers"):
        ControllerSpec("lqr", (1.0, 2.0, 3.0))


def test_user_controller_from_a_file(tmp_path, gymnast):
    path = tmp_path / "mine.py"
    path.write_text("import numpy as np\n\nclass Push:\n    def __init__(self, robot):\n        self.b1 = robot.analytic.b1\n"
                    "    def torque(self, q, qd, t):\n        return np.full(np.shape(q)[:-1] + (2,), 1e-3 * self.b1)\n")
    ctrl = make_controller(f"{path}:Push", gymnast)
    np.testing.assert_allclose(ctrl.torque(np.zeros((4, 3)), np.zeros((4, 3)), 0.0), 1e-3 * gymnast.analytic.b1)
    with pytest.raises(PaaError, match="has no class 'Nope'"):
        make_controller(f"{path}:Nope", gymnast)
    broken = tmp_path / "broken.py"
    broken.write_text("def oops(:\n")
    with pytest.raises(PaaError, match="cannot load controller file"):
        make_controller(f"{broken}:X", gymnast)
