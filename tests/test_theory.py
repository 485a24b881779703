"""The paper's theory made computable, checked against the paper's Table 1 numbers."""
import numpy as np
import pytest

from paa_mj import theory
from paa_mj.control.closed_loop import closed_loop_jacobian, duu_eigenvalues
from paa_mj.model.states import Q_UDD
from paa_mj.outputs.theory_report import theory_report
from paa_mj.theory import constraint_54, eta1_function, eta2_function, kd_bound_function, thresholds
from paa_mj.theory.linear import linear_controllability
from paa_mj.task import Task

from .conftest import GAINS1, GAINS2


def test_beta_and_E_r_table1(gymnast):
    # the paper: b1 = 289.5323 J, b2 = 148.6215 J, b3 = 59.8901 J
    np.testing.assert_allclose(gymnast.analytic.beta, [289.5323, 148.6215, 59.8901], atol=5e-5)
    assert gymnast.analytic.E_r > 0


def test_beta_table2(example2):
    # the paper: b1 = 44.1450, b2 = 3.6788, b3 = 1.2263 J
    np.testing.assert_allclose(example2.analytic.beta, [44.1450, 3.6788, 1.2263], atol=5e-5)
    assert example2.analytic.E_r > 0


def test_thresholds_table1_match_the_paper(gymnast):
    kd, e1, e2 = thresholds(gymnast.analytic)
    # the paper: kD > 4503 (41), kP > 15863 (62), kP > 3591 (63)
    assert kd.value == pytest.approx(4503, rel=1e-3)
    assert e1.value == pytest.approx(15863, rel=1e-3)
    assert e2.value == pytest.approx(3591, rel=1e-3)


@pytest.mark.parametrize("robot", ["gymnast", "example2"])
def test_maxima_are_accurate_to_1e4_against_a_fine_brute_force_grid(robot, request):
    am = request.getfixturevalue(robot).analytic
    kd, e1, e2 = thresholds(am)
    y = np.linspace(0, 2 * np.pi, 1501)
    Y, Z = np.meshgrid(y, y, indexing="ij")
    fine = np.max(kd_bound_function(am, Y, Z))
    assert fine <= kd.value * (1 + 1e-12)
    assert kd.value <= fine * (1 + 1e-4)
    Y, Z = np.meshgrid(np.linspace(0, np.pi, 1501), y, indexing="ij")
    fine = np.max(eta1_function(am, Y, Z))
    assert fine <= e1.value * (1 + 1e-12) and e1.value <= fine * (1 + 1e-4)
    z = np.linspace(np.pi, 2 * np.pi, 200001)
    fine = np.max(eta2_function(am, z))
    assert fine <= e2.value * (1 + 1e-12) and e2.value <= fine * (1 + 1e-4)


def test_refined_maximum_equals_function_at_argmax(gymnast):
    kd, e1, _ = thresholds(gymnast.analytic)
    assert kd_bound_function(gymnast.analytic, *kd.argmax) == pytest.approx(kd.value, rel=1e-14)
    assert eta1_function(gymnast.analytic, *e1.argmax) == pytest.approx(e1.value, rel=1e-14)


def test_constraint_54_table1_holds_with_f_between_0_and_1(gymnast):
    c = constraint_54(gymnast.analytic)
    assert c.holds
    assert 0 < c.f_min < c.f_max < 1  # the paper's Fig. 5


def test_constraint_54_reports_the_least_distance_of_f_from_1(gymnast):
    """closest_to_one is min |f - 1| over z (not the least of the residual Gamma beta2bar - (Eps cos z + Lam), whose
    denominator is not f's): on Table 1, where f stays in (0, 1), it is 1 - max f."""
    c = constraint_54(gymnast.analytic)
    z = np.linspace(0, 2 * np.pi, 200001)
    distance = np.abs(theory.f54(gymnast.analytic, z) - 1)
    assert c.closest_to_one == pytest.approx(distance.min(), abs=1e-9) and c.closest_to_one <= distance.min()
    assert c.closest_to_one == pytest.approx(1 - c.f_max, abs=1e-9)  # f_max is its grid's
    assert abs(c.z_closest - z[np.argmin(distance)]) < 1e-3


def test_constraint_54_table2_fails_at_z_0(example2):
    c = constraint_54(example2.analytic)
    assert not c.holds
    assert c.closest_to_one < 1e-12
    assert min(c.z_closest, 2 * np.pi - c.z_closest) < 1e-6  # f = 1 at z = 0 and 2 pi (Fig. 11)
    assert theory.f54(example2.analytic, 0.0) == pytest.approx(1.0, abs=1e-12)


def test_deltabar_zero_exactly_where_54_fails(example2, gymnast):
    """(54) and (30) both describe the frozen Acrobot: f(z) = 1 where deltabar(z) = 0."""
    assert abs(theory.deltabar(example2.analytic, 0.0)) < 1e-9
    z = np.linspace(0, 2 * np.pi, 1001)
    assert np.all(theory.deltabar(gymnast.analytic, z) > 0)


@pytest.mark.parametrize("robot", ["gymnast", "example2"])
def test_udd_linearly_controllable_and_lqr_stabilises(robot, request):
    am = request.getfixturevalue(robot).analytic
    assert theory.udd_controllability(am).controllable
    A, B = theory.udd_linearization(am)
    K = theory.lqr_gain(am, Task.named("folded", am))
    assert K.shape == (2, 6)
    assert np.max(np.linalg.eigvals(A - B @ K).real) < 0
    assert np.max(np.linalg.eigvals(A).real) > 0  # UDD is open-loop unstable


def test_uncontrollable_pair_is_detected(gymnast):
    """The rank and PBH tests fail when one mode is out of the motors' reach."""
    A, B = theory.udd_linearization(gymnast.analytic)
    A_big = np.block([[A, np.zeros((6, 2))], [np.zeros((2, 6)), np.array([[0.0, 1.0], [3.0, 0.0]])]])
    B_big = np.vstack([B, np.zeros((2, 2))])
    result = linear_controllability(A_big, B_big)
    assert not result.controllable
    assert result.rank == 6


def _central_jacobian(field, x0, h=1e-5):
    n = len(x0)
    J = np.empty((n, n))
    for i in range(n):
        dx = np.zeros(n)
        dx[i] = h
        J[:, i] = (field(x0 + dx) - field(x0 - dx)) / (2 * h)
    return J


def test_linearisation_matches_finite_differences(gymnast):
    am = gymnast.analytic
    A, B = theory.udd_linearization(am)

    def field(x):
        return am.state_derivative(x + np.concatenate([Q_UDD, np.zeros(3)]), np.zeros(2))

    np.testing.assert_allclose(A, _central_jacobian(field, np.zeros(6)), atol=1e-7)


@pytest.mark.parametrize("law, name", [("vcl", "vcl-only"), ("conventional", "vc-only")])
def test_exact_closed_loop_jacobian_matches_finite_differences(gymnast, law, name):
    """The automatic-differentiation Jacobian at DUU against central differences of the NumPy controller."""
    from paa_mj.control import make_controller
    from paa_mj.model.states import Q_DUU

    am = gymnast.analytic
    ctrl = make_controller(name, gymnast)

    def field(x):
        return am.state_derivative(x, ctrl.torque(x[:3], x[3:], 0.0))

    x0 = np.concatenate([Q_DUU, np.zeros(3)]) + [0.05, -0.02, 0.03, 0.1, 0.0, -0.1]
    exact = closed_loop_jacobian(am, **GAINS1, law=law, state=x0)
    np.testing.assert_allclose(exact, _central_jacobian(field, x0, 1e-6), rtol=1e-5, atol=1e-5 * np.abs(exact).max())


@pytest.mark.parametrize("law", ["vcl", "conventional"])
def test_the_dual_number_jacobian_is_casadi_s_and_needs_no_casadi(gymnast, law, monkeypatch):
    """The closed loop's Jacobian by dual numbers equals CasADi's automatic differentiation of the same formulas
    (at DUU, at another state, with Lambda's E - E_r given); it imports no CasADi (``paa-mj reproduce`` runs
    without the extra ``plan``), and without CasADi what needs it says so in one line naming the install."""
    import sys

    from paa_mj.control.energy import conventional_law, energy_terms, vcl_law
    from paa_mj.errors import PaaError
    from paa_mj.model import equations as eq

    ca = eq.casadi_module()
    x, c = ca.SX.sym("x", 6), ca.SX.sym("c", len(eq.CONSTANTS))
    q1, q2, q3, d1, d2, d3 = (x[i] for i in range(6))
    am = gymnast.analytic
    for state, given in ((None, None), ([-3.0, -3.0, 0.1, 0.2, -0.3, 0.5], None), (None, -2.0)):
        de, k22, k23, k33, u1, u2 = energy_terms(c, GAINS1["kD"], GAINS1["kV"], q1, q2, q3, d1, d2, d3)
        de = de if given is None else given
        tau = (vcl_law if law == "vcl" else conventional_law)(c, GAINS1["kP"], de, k22, k23, k33, u1, u2, q2, q3)
        field = ca.vertcat(d1, d2, d3, *eq.acceleration(c, q1, q2, q3, d1, d2, d3, *tau))
        point = np.concatenate([[-np.pi, -np.pi, 0.0], np.zeros(3)]) if state is None else np.array(state)
        expected = np.array(ca.Function("J", [x, c], [ca.jacobian(field, x)])(point, am.constants), dtype=float)
        with monkeypatch.context() as patch:
            patch.setitem(sys.modules, "casadi", None)  # unimportable
            exact = closed_loop_jacobian(am, **GAINS1, law=law, state=state, lambda_energy=given)
            with pytest.raises(PaaError) as refusal:
                eq.casadi_module()
        np.testing.assert_allclose(exact, expected, rtol=1e-12, atol=1e-12 * np.abs(expected).max())
    assert "\n" not in str(refusal.value) and "pip install 'paa_mj[plan]'" in str(refusal.value)


def test_duu_is_unstable_in_closed_loop_table1(gymnast):
    eig, poly = duu_eigenvalues(gymnast.analytic, **GAINS1)
    assert len(eig) == 6
    assert np.max(eig.real) > 0
    np.testing.assert_allclose(np.sort_complex(np.roots(poly)), np.sort_complex(eig), rtol=1e-6)


def test_theory_report_flags_failed_conditions(example2):
    r = theory_report(example2.analytic, **GAINS2)
    assert r.theorem1["(54) holds"] is False
    assert r.theorem1["all hold"] is False
    assert r.udd_controllable


def test_bounded_minimum_is_scipys_bounded_brent_number_for_number():
    """(54)'s closest approach uses a port of SciPy's bounded minimiser (no scipy.optimize import at start-up):
    on smooth and kinked functions, short and long intervals and three tolerances it returns SciPy's x and f(x)
    exactly."""
    from scipy.optimize import minimize_scalar

    from paa_mj.theory.maxima import bounded_minimum

    rng = np.random.default_rng(0)
    for k in range(120):
        a, b, c, d = rng.normal(size=4)
        low = rng.uniform(-3.0, 0.0)
        high = low + rng.uniform(0.01, 4.0)
        tol = (1e-5, 1e-9, 1e-13)[k % 3]
        if k % 2:
            def f(s):
                return abs(a * np.sin(s) - (b * np.cos(s) + c))
        else:
            def f(s):
                return (s - d) ** 2 + a * np.sin(3.0 * s)
        reference = minimize_scalar(f, bounds=(low, high), method="bounded", options={"xatol": tol})
        assert bounded_minimum(f, low, high, xatol=tol) == (reference.x, reference.fun), k
