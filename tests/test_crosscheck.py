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
    m, l = np.array(m), np.array(l)
    params = RobotParams(m=m, l=l, lc=np.array(frac) * l, J=np.array(jscale) * m * l**2 / 12)
    result = cross_check(model_from_params(params), samples=200, seed=seed)
    assert result.worst() < TOL, result


def test_cross_check_detects_a_wrong_analytic_model(gymnast):
    """The comparison is not vacuous: a 1e-6 change of one mass is seen."""
    from paa_mj.model.crosscheck import engine_quantities, random_states
    from paa_mj.model.dynamics import AnalyticModel

    p = gymnast.params
    wrong = AnalyticModel.from_params(RobotParams(m=p.m * [1, 1 + 1e-6, 1], l=p.l, lc=p.lc, J=p.J))
    q, qd, tau = random_states(50, 3, analytic=wrong)
    M, bias, _, _ = engine_quantities(gymnast.model, q, qd, tau)
    assert np.max(np.abs(M - wrong.mass_matrix(q))) > 1e-7
