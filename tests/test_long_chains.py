"""Every robot that make-model writes (2 to 64 links) runs; the bound (41) of a long chain is bracketed at once."""
import numpy as np
import pytest

from paa_mj.model.params import MAX_LINKS, RobotParams
from paa_mj.model.robot import model_from_params
from paa_mj.task import Task



def _chain(n):
    ones = np.ones(n)
    return RobotParams(m=ones, l=ones, lc=ones / 2, J=ones / 12)


@pytest.mark.parametrize("n", [12, 33])
def test_the_bound_41_of_a_chain_beyond_reach_is_bracketed_with_what_a_certificate_would_need(n):
    from paa_mj.model.dynamics import AnalyticModel
    from paa_mj.theory.conditions import chain_kd_min

    kd = chain_kd_min(AnalyticModel.from_params(_chain(n)), Task.named("folded", n), progress=False)
    assert not kd.certified and 0 < kd.value < kd.upper < np.inf and kd.boxes == 0
    assert "a certificate would take about" in kd.method


def test_the_longest_chain_runs_without_gains_and_is_refused_one_line_where_it_needs_them(tmp_path, run):
    from paa_mj.model.robot import load_robot
    from paa_mj.model.mjcf import mjcf_from_params
    from paa_mj.sim import simulate_mujoco

    path = tmp_path / "long.xml"
    path.write_text(mjcf_from_params(_chain(MAX_LINKS), name="long"))
    robot = load_robot(str(path))
    traj = simulate_mujoco(robot, "passive", t_final=0.2, task=Task.named("folded", robot))
    assert traj.q.shape[1] == MAX_LINKS and np.all(np.isfinite(traj.q))
    assert model_from_params(_chain(MAX_LINKS)).nq == MAX_LINKS
    proc = run("simulate", "--robot", path, "--controller", "vcl", "--kD", "1e6", "--kP", "1e6", "--kV", "1e6",
               "--t-final", "0.1", cwd=tmp_path)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr and len(proc.stderr.strip().splitlines()) == 1
    assert "is not above kD_min" in proc.stderr and "controller (40) can become singular" in proc.stderr, proc.stderr


@pytest.mark.parametrize("n", [16, pytest.param(MAX_LINKS, marks=pytest.mark.slow)])  # 64 links: 63 CPU-s
def test_the_controllability_of_the_longest_chain_is_decided_without_overflow(n):
    """The Kalman matrix's powers A^(2n - 1) B overflowed at 64 links: each power is rescaled, and PBH decides."""
    import warnings

    from paa_mj.model.dynamics import AnalyticModel
    from paa_mj.theory.linear import goal_controllability

    am = AnalyticModel.from_params(_chain(n))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ctrb = goal_controllability(am, Task.named("folded", am))
    assert ctrb.controllable is True and ctrb.pbh_min > 1e3 * np.finfo(float).eps and np.isfinite(ctrb.sigma_min_ratio)
