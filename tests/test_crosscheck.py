"""Regression tests comparing the engine and the analytic dynamics of the paper."""
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from paa_mj.model import model_from_params
from paa_mj.model.crosscheck import cross_check
from paa_mj.model.params import RobotParams

TOL = 1e-9


@pytest.mark.parametrize("robot", ["gymnast", "example2"])
def test_engine_equals_analytic_model_at_1000_states(robot, request):
    result = cross_check(request.getfixturevalue(robot).model, samples=1000, seed=7)
    assert result.samples == 1000
    assert result.max_rel_err_M < TOL
    assert result.max_rel_err_bias < TOL
    assert result.max_rel_err_qacc < TOL
    assert result.max_rel_err_energy < TOL


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(m=st.lists(st.floats(0.1, 80), min_size=3, max_size=3),
       l=st.lists(st.floats(0.1, 3), min_size=3, max_size=3),
       frac=st.lists(st.floats(0, 1), min_size=3, max_size=3),
       jscale=st.lists(st.floats(0.05, 3), min_size=3, max_size=3),
       seed=st.integers(0, 2**16))
def test_engine_equals_analytic_model_for_random_robots(m, l, frac, jscale, seed):
    """M, the bias forces and the energy to 1e-9 relative. The accelerations solve M qacc = tau - bias, whose
    relative error is bounded by cond(M) times that of M and the bias (both ~1e-14 here): 1e-9, or 1e-13 cond(M)
    where a light link between heavy ones makes M ill-conditioned (a robot of masses 1, 0.3, 11 kg has cond(M)
    up to 2e5 and accelerations that agree to 2e-9)."""
    from paa_mj.model.crosscheck import random_states
    from paa_mj.model.dynamics import AnalyticModel

    m, l = np.array(m), np.array(l)
    params = RobotParams(m=m, l=l, lc=np.array(frac) * l, J=np.array(jscale) * m * l**2 / 12)
    result = cross_check(model_from_params(params), samples=200, seed=seed)
    assert max(result.max_rel_err_M, result.max_rel_err_bias, result.max_rel_err_energy) < TOL, result
    am = AnalyticModel.from_params(params)
    condition = np.max(np.linalg.cond(am.mass_matrix(random_states(200, seed, analytic=am)[0])))
    assert result.max_rel_err_qacc < max(TOL, 1e-13 * condition), (result, condition)


def test_an_ill_conditioned_robot_agrees_as_its_condition_number_allows():
    """The robot hypothesis found (masses 1, 0.3, 11 kg; the COMs of links 1 and 2 at their joints)."""
    m, l = np.array([1.0, 0.3, 11.0]), np.array([1.0, 0.25, 3.0])
    params = RobotParams(m=m, l=l, lc=np.array([0.0, 0.0, 1.0]) * l, J=np.array([1.0, 0.421875, 0.0625]) * m * l**2 / 12)
    from paa_mj.model.crosscheck import random_states
    from paa_mj.model.dynamics import AnalyticModel

    result = cross_check(model_from_params(params), samples=200, seed=0)
    am = AnalyticModel.from_params(params)
    condition = np.max(np.linalg.cond(am.mass_matrix(random_states(200, 0, analytic=am)[0])))
    assert condition > 1e5
    assert max(result.max_rel_err_M, result.max_rel_err_bias, result.max_rel_err_energy) < 1e-12
    assert result.max_rel_err_qacc < 1e-13 * condition


def test_cross_check_detects_a_wrong_analytic_model(gymnast):
    """The comparison is not vacuous: a 1e-6 change of one mass is seen."""
    from paa_mj.model.crosscheck import engine_quantities, random_states
    from paa_mj.model.dynamics import AnalyticModel

    p = gymnast.params
    wrong = AnalyticModel.from_params(RobotParams(m=p.m * [1, 1 + 1e-6, 1], l=p.l, lc=p.lc, J=p.J))
    q, qd, tau = random_states(50, 3, analytic=wrong)
    M, bias, _, _ = engine_quantities(gymnast.model, q, qd, tau)
    assert np.max(np.abs(M - wrong.mass_matrix(q))) > 1e-7


def test_the_check_command_fails_when_the_two_models_disagree(monkeypatch, capsys):
    """A gate: exit 2 and one line when an error passes the agreement (a feature the validation let through)."""
    import paa_mj.model.crosscheck as crosscheck
    from paa_mj.cli import main

    assert main(["check", "--samples", "20"]) == 0 and "agree within 1e-09    yes" in capsys.readouterr().out
    real = crosscheck.cross_check
    monkeypatch.setattr(crosscheck, "cross_check", lambda *a, **k: crosscheck.CrossCheck(
        **{**real(*a, **k).as_dict(), "max_rel_err_qacc": 2.6}))
    assert main(["check", "--samples", "20"]) == 2
    out, err = capsys.readouterr()
    assert "agree within 1e-09    NO" in out
    assert err.strip().splitlines()[-1].startswith("paa-mj: error: MuJoCo and the analytic model disagree on gymnast:")
