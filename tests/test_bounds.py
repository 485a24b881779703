"""kD_min of (41) by the certified branch and bound (paa_mj.theory.kd_search): sound bounds, the grid's values on
2 to 6 links, a closed form, brackets for long chains, progress."""
import numpy as np
import pytest

from paa_mj.model.dynamics import AnalyticModel
from paa_mj.model.params import RobotParams
from paa_mj.model.robot import load_robot
from paa_mj.task import Task
from paa_mj.theory.conditions import chain_kd_min, chain_kd_min_grid
from paa_mj.theory.kd_search import BoundFunction, kd_min_search

from .test_family import random_chain

#: The grid's kD_min (chain_kd_min_grid, 9^5 points and zoomed grids, 4.4 CPU-s each) of random_chain(rng(6), 6).
GRID_6_LINKS = {"folded": 12195820.496401468, "stretched": 54492007.15548284}


def _model(n, seed):
    return AnalyticModel.from_params(random_chain(np.random.default_rng(seed), n))


def _search(am, goal, **kwargs):
    return kd_min_search(am, Task.named(goal, am).goal_energy(am), **kwargs)


@pytest.mark.parametrize("n", [2, 3, 4, 5, 7])
def test_the_bound_on_a_box_is_above_f_everywhere_in_it(n):
    """The soundness of the certificate: on random boxes, from a hundredth of a radian to the whole torus, every
    bound is at least f at random points and corners of its box."""
    rng = np.random.default_rng(n)
    am = _model(n, 40 + n)
    for goal in ("folded", "stretched"):
        f = BoundFunction(am, Task.named(goal, am).goal_energy(am))
        d = n - 1
        centres = rng.uniform(-np.pi, np.pi, (120, d))
        radii = np.exp(rng.uniform(np.log(0.01), np.log(np.pi), (120, d)))
        upper, value, _ = f.bound(centres, radii, -np.inf)  # -inf: every bound computed, the second-order too
        assert np.allclose(value, f.values(centres), rtol=1e-12)
        inside = centres[:, None] + radii[:, None] * np.concatenate(
            [rng.uniform(-1, 1, (300, d)), rng.choice([-1.0, 1.0], (60, d))])[None]
        sampled = f.values(inside.reshape(-1, d)).reshape(len(centres), -1).max(axis=1)
        assert np.all(upper >= sampled), np.max(sampled - upper)
        assert np.all(upper <= f.global_bound() * (1 + 1e-9))


@pytest.mark.parametrize("n", [2, 3, 4, 5])
def test_the_branch_and_bound_gives_the_grids_kd_min_on_random_chains(n):
    """Random chains (damping, armature, g from 1 to 20), both goals: the grid's maximum within its 1e-4, in fact to
    rounding, and the certificate: value <= max f <= upper <= value (1 + 1e-6)."""
    am = _model(n, 200 + n)
    for goal in ("folded", "stretched"):
        grid = chain_kd_min_grid(am, Task.named(goal, am).goal_energy(am))
        kd = _search(am, goal)
        assert kd.certified and kd.value <= kd.upper <= kd.value * (1 + kd.tol)
        assert kd.value == pytest.approx(grid.value, rel=1e-9) and kd.upper >= grid.value
        assert kd.method.startswith("a branch and bound") and kd.boxes > 0


def test_the_branch_and_bound_gives_the_grids_kd_min_on_six_links():
    am = _model(6, 6)
    for goal, grid in GRID_6_LINKS.items():
        kd = _search(am, goal)
        assert kd.certified and kd.value == pytest.approx(grid, rel=1e-9) and kd.upper >= grid


@pytest.mark.parametrize("name", ["acrobot", "gymnast", "example2", "chain4", "realaigym_acrobot"])
def test_the_stored_robots_kd_min_is_the_grids(name):
    robot = load_robot(name)
    for goal in ("folded", "stretched"):
        task = Task.named(goal, robot)
        kd = chain_kd_min(robot.analytic, task, progress=False)
        grid = chain_kd_min_grid(robot.analytic, task.goal_energy(robot.analytic))
        assert kd.certified and kd.value == pytest.approx(grid.value, rel=1e-9) and kd.upper >= grid.value
    if name == "gymnast":
        assert round(chain_kd_min(robot.analytic, Task.named("folded", robot), progress=False).value) == 4503  # Table 1


def test_the_inertia_wheel_pendulum_has_its_closed_form():
    """Link 2 a wheel on joint 2 (lc2 = 0): M is constant, b2 = 0 and mu = b1, so f is the constant
    (E_r + b1) a1 a2 / (a1 + a2) with a1 = J1 + m1 lc1^2 + m2 l1^2, a2 = J2 and E_r = b1 for both goals."""
    p = RobotParams(m=[2.0, 3.0], l=[1.0, 0.4], lc=[0.5, 0.0], J=[0.2, 0.15], g=9.81)
    am = AnalyticModel.from_params(p)
    b1 = p.g * (2.0 * 0.5 + 1.0 * 3.0)
    a1, a2 = 0.2 + 2.0 * 0.25 + 3.0 * 1.0, 0.15
    for goal in ("folded", "stretched"):
        kd = _search(am, goal)
        assert kd.value == pytest.approx(2 * b1 * a1 * a2 / (a1 + a2), rel=1e-12) and kd.certified


def test_a_spent_budget_gives_a_certified_bracket_and_the_gains_above_it(monkeypatch, tmp_path):
    """Past its budget the search stops with value <= kD_min <= upper: kD above upper is accepted, between the two
    refused with the bracket, at or below value refused as singular."""
    from paa_mj.control.gains import check_chain_gains
    from paa_mj.errors import PaaError
    from paa_mj.theory import kd_search

    monkeypatch.setitem(kd_search._BUDGET, "cpu_s", 1.0)  # the process's budget; a certificate takes about 15
    monkeypatch.setattr(kd_search, "certificate_dir", lambda: tmp_path)  # none kept by an earlier command
    am = AnalyticModel.from_params(RobotParams.uniform_rods(np.ones(8), np.ones(8)))
    task = Task.named("folded", am)
    kd = chain_kd_min(am, task, progress=False)
    assert not kd.certified and kd.value < kd.upper < BoundFunction(am, task.goal_energy(am)).global_bound()
    assert kd.boxes > 0 and kd.value == pytest.approx(4282.208825, rel=1e-9)  # the value certified with more time
    check_chain_gains(am, 1.01 * kd.upper, 1.0, 1.0, task)
    with pytest.raises(PaaError, match=r"not certified singularity-free: kD_min of \(41\) is only bracketed, in \["):
        check_chain_gains(am, 0.5 * (kd.value + kd.upper), 1.0, 1.0, task)
    with pytest.raises(PaaError, match=r"is not above kD_min = .* of \(41\)"):
        check_chain_gains(am, kd.value, 1.0, 1.0, task)


def test_a_certificate_is_kept_for_later_commands_and_one_that_is_wrong_is_not_used(monkeypatch, tmp_path):
    import json

    from paa_mj.theory import conditions, kd_search

    monkeypatch.setattr(kd_search, "certificate_dir", lambda: tmp_path)
    monkeypatch.setattr(conditions, "_KD_MIN_CACHE", {})
    am = _model(5, 8)
    task = Task.named("stretched", am)
    first = chain_kd_min(am, task, progress=False)
    kept, = tmp_path.glob("*.json")
    assert first.certified and first.boxes > 0
    searches, search = [], kd_search.kd_min_search
    monkeypatch.setattr(kd_search, "kd_min_search", lambda *a, **k: searches.append(1) or search(*a, **k))
    conditions._KD_MIN_CACHE.clear()  # a later command: nothing in memory
    assert chain_kd_min(am, task, progress=False) == first and not searches
    fields = json.loads(kept.read_text())
    kept.write_text(json.dumps({**fields, "value": 1.01 * fields["value"], "upper": 1.01 * fields["upper"]}))
    conditions._KD_MIN_CACHE.clear()
    assert chain_kd_min(am, task, progress=False) == first and searches == [1]  # f at argmax is not that value


def test_a_bracket_is_kept_with_its_budget_and_reused_for_no_larger_one(monkeypatch, tmp_path):
    from paa_mj.theory import conditions, kd_search

    monkeypatch.setattr(kd_search, "certificate_dir", lambda: tmp_path)
    monkeypatch.setattr(conditions, "_KD_MIN_CACHE", {})
    am = AnalyticModel.from_params(RobotParams.uniform_rods(np.ones(8), np.ones(8)))
    task = Task.named("folded", am)
    first = chain_kd_min(am, task, budget_cpu_s=0.8, progress=False)  # a certificate: ~15 (searched from 0.75)
    assert not first.certified and first.boxes > 0
    searches, search = [], kd_search.kd_min_search
    monkeypatch.setattr(kd_search, "kd_min_search", lambda *a, **k: searches.append(k["budget_cpu_s"]) or search(*a, **k))
    conditions._KD_MIN_CACHE.clear()
    assert chain_kd_min(am, task, budget_cpu_s=0.75, progress=False) == first and not searches  # no larger a budget
    conditions._KD_MIN_CACHE.clear()
    chain_kd_min(am, task, budget_cpu_s=1.2, progress=False)
    assert searches == [1.2]  # a larger budget searches again


def test_a_hopeless_certificate_is_not_searched_and_says_what_it_would_take():
    am = AnalyticModel.from_params(RobotParams.uniform_rods(np.ones(20), np.ones(20)))
    task = Task.named("stretched", am)
    kd = chain_kd_min(am, task, progress=False)
    assert kd.boxes == 0 and not kd.certified and kd.value < kd.upper
    assert kd.upper == pytest.approx(BoundFunction(am, task.goal_energy(am)).global_bound(), rel=1e-12)
    assert "a certificate would take about" in kd.method and "years" in kd.method


def test_the_search_shows_its_progress_and_bracket_in_a_log(monkeypatch, capsys):
    import paa_mj.progress as progress

    monkeypatch.delenv("PAA_MJ_PROGRESS", raising=False)  # the suite leaves progress out of logs
    monkeypatch.setattr(progress, "LOG_DELAY", 0.0)
    monkeypatch.setattr(progress, "LOG_INTERVAL", 0.0)
    _search(_model(5, 5), "folded", desc="kD_min (41), 5 links")
    lines = [line for line in capsys.readouterr().err.splitlines() if line.startswith("kD_min (41), 5 links: max in [")]
    assert len(lines) >= 2 and "box" in lines[-1]
