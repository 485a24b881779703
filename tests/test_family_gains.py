"""Gains when none are given: the family rule, the note that says so, refusals that name the gains that would do,
the outcome of a run in words, and the search behind the rule on a small case."""
import json
import warnings

import numpy as np
import pytest

from paa_mj.control import gains as G
from paa_mj.control.gains import resolve_gains
from paa_mj.control.registry import ControllerSpec
from paa_mj.model import load_robot
from paa_mj.studies.gain_search import gain_search, search_table
from paa_mj.task import Task
from paa_mj.theory.conditions import chain_kd_min, thresholds



def test_the_rule_is_its_ratios_over_the_bound_of_the_goal():
    gymnast = load_robot("gymnast")
    for goal in ("folded", "stretched"):
        task = Task.named(goal, gymnast)
        g = G.family_gains(gymnast.analytic, task, G.GainRule(1.5, 3.0, 0.25))
        bound = thresholds(gymnast.analytic)[0].value if goal == "folded" else chain_kd_min(gymnast.analytic, task).value
        assert g["kD"] == pytest.approx(1.5 * bound, rel=1e-12) and g["kV"] == pytest.approx(0.25 * g["kD"])
        if goal == "stretched":
            assert g["kP"] == pytest.approx(3.0 * g["kD"])
    _, e1, e2 = thresholds(gymnast.analytic)
    low_p = G.family_gains(gymnast.analytic, Task.named("folded", gymnast), G.GainRule(1.05, 1e-6, 1.0))
    assert low_p["kP"] == pytest.approx(1.05 * max(e1.value, e2.value))  # Theorem 1's bounds (59), (60) kept


def test_stored_gains_stand_where_they_meet_the_bound_and_the_rule_says_so_elsewhere():
    gymnast = load_robot("gymnast")
    folded, stretched = Task.named("folded", gymnast), Task.named("stretched", gymnast)
    with warnings.catch_warnings():
        warnings.simplefilter("error", G.GainsNote)
        assert resolve_gains(gymnast, folded) == resolve_gains(gymnast)
    G._NOTED.clear()
    with pytest.warns(G.GainsNote, match=r"not above kD_min = 10111.9 of \(41\) for the stretched goal"):
        chosen = resolve_gains(gymnast, stretched)
    assert chosen == G.family_gains(gymnast.analytic, stretched)
    assert resolve_gains(gymnast, stretched, kP=7.0)["kP"] == 7.0  # given gains stand, the rest from the rule
    controller = ControllerSpec("vcl", task=stretched).build(gymnast)
    assert controller.first.kD == chosen["kD"]


def test_a_run_without_gains_states_them_and_its_outcome(tmp_path, run):
    G._NOTED.clear()  # a note is said once a process: this one's first
    proc = run("simulate", "--robot", "gymnast", "--goal", "stretched", "--t-final", "0.5", "--json")
    assert proc.returncode == 0, proc.stderr
    notes = [line for line in proc.stderr.splitlines() if line.startswith("paa-mj: note: gains of the family rule")]
    gymnast = load_robot("gymnast")
    rule = G.gains_text(G.family_gains(gymnast.analytic, Task.named("stretched", gymnast)))
    assert len(notes) == 1 and rule in notes[0]
    summary = json.loads(proc.stdout)
    assert summary["outcome"].startswith("never entered region (68) in 0.5 s") and "try" in summary["outcome"]


def test_gains_below_the_bound_are_refused_with_the_gains_that_would_do(run):
    proc = run("simulate", "--robot", "gymnast", "--goal", "stretched", "--kD", "5000", "--kP", "1", "--kV", "1")
    assert proc.returncode == 2
    line = proc.stderr.strip().splitlines()[-1]
    gymnast = load_robot("gymnast")
    rule = G.gains_text(G.family_gains(gymnast.analytic, Task.named("stretched", gymnast)))
    assert "kD_min = 10111.9 of (41)" in line and f"would do: {rule}" in line
    assert rule.startswith("--kD 10617.4 ")  # 1.05 x kD_min = 10111.85


def test_make_model_writes_the_rule_into_the_header_and_its_robot_runs(tmp_path, run):
    out = tmp_path / "c4.xml"
    proc = run("make-model", "--links", "4", "--m", "30", "20", "15", "10", "--l", "1", "0.8", "0.7", "0.6",
               "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    robot = load_robot(str(out))
    rule = G.family_gains(robot.analytic, Task.named("folded", robot))
    assert robot.gains == pytest.approx(rule, rel=1e-9)
    header = out.read_text().split("-->")[0]
    assert "Gains of the family rule" in header and "stretched goal kD = " in header
    G._NOTED.clear()  # a note is said once a process: this one's first
    proc = run("simulate", "--robot", str(out), "--goal", "stretched", "--t-final", "0.2", "--json")
    assert proc.returncode == 0 and "paa-mj: note: gains of the family rule" in proc.stderr
    proc = run("simulate", "--robot", str(out), "--t-final", "0.2")  # the stored gains, stated as the rule's
    assert proc.returncode == 0, proc.stderr
    line = next(line for line in proc.stdout.splitlines() if line.strip().startswith("gains"))
    assert f"kD = {rule['kD']:.6g}" in line and "the model's stored gains, the family rule's for the folded goal" in line


def test_the_origin_of_a_run_s_gains_is_named():
    gymnast = load_robot("gymnast")
    folded, stretched = Task.named("folded", gymnast), Task.named("stretched", gymnast)
    model, stored = gymnast.analytic, gymnast.gains
    assert G.gains_origin(model, folded, stored, stored) == "the model's stored gains"
    assert G.gains_origin(model, stretched, stored, G.family_gains(model, stretched)).startswith(
        "the family rule's for the stretched goal: kD = 1.05 kD_min (41)")
    assert G.gains_origin(model, folded, stored, {**stored, "kV": 2 * stored["kV"]}) == \
        "kV as given; kD, kP the model's stored ones"
    assert G.gains_origin(model, folded, stored, {"kD": 1.0, "kP": 2.0, "kV": 3.0}) == "kD, kP, kV as given"
    rule = G.family_gains(model, stretched)
    assert G.gains_origin(model, stretched, stored, {**rule, "kD": 2 * rule["kD"]}) == \
        "kD as given; kP, kV the family rule's for the stretched goal"


def test_the_search_scores_rules_by_the_robots_they_balance():
    found = gain_search(robots=(("acrobot", "folded"),), grid=((2.0,), (2.0, 0.5), (0.5,)), t_final=30.0)
    assert found["success"].shape == (2, 1)
    best = int(np.argmax(found["success"].sum(axis=1)))
    assert found["best"] == found["rules"][best]
    assert search_table(found).count("\n") == 3


def test_an_interrupted_run_says_so_instead_of_judging_the_whole_run():
    from paa_mj.sim.rollout import simulate_mujoco

    gymnast = load_robot("gymnast")
    traj = simulate_mujoco(gymnast, t_final=0.2, task=Task.named("folded", gymnast))
    assert traj.outcome().startswith("never entered region (68) in 0.2 s")
    traj.meta.update(status=f"interrupted at t = {traj.t[-1]:.4f} s", interrupted=True, t_final=30.0)
    assert traj.outcome() == ("interrupted at t = 0.2000 s, before the end of its 30 s, not at the folded goal; run it"
                              " whole for its outcome")


def test_an_outcome_proposes_only_the_remedies_that_apply_to_the_run():
    from paa_mj.sim.rollout import simulate_mujoco

    gymnast = load_robot("gymnast")
    folded = Task.named("folded", gymnast)
    passive = simulate_mujoco(gymnast, "passive", t_final=0.2, task=folded).outcome()
    # no gains to change, no switch to speak of, and no torque: a longer run keeps the chain's energy
    assert passive == ("not at the folded goal at the end (never entered region (68) in 0.2 s); try a controller that"
                       " exerts torque (this one exerted none)")
    lqr = simulate_mujoco(gymnast, "lqr", t_final=0.2, task=folded).outcome()
    # no hand-over to move, and a balance alone started outside its region gets no nearer by running longer
    assert "--switch" not in lqr and "longer" not in lqr
    assert lqr.endswith("; try a start inside its region of attraction (paa-mj roa) or a swing-up controller")
    vcl = simulate_mujoco(gymnast, "vcl", t_final=0.2, task=folded).outcome()
    assert vcl.endswith("try a longer --t-final or other gains (paa-mj gain-search compares rules of gains)")


@pytest.mark.parametrize("covered, base", [(True, {"kD": 2.0, "kP": 8.0, "kV": 1.0}), (False, None),
                                           (False, {"kD": 2.0, "kP": 8.0, "kV": 1.0})])
def test_the_atlas_rule_in_words_is_the_rule(covered, base):
    from paa_mj.control.gains import MARGIN, gain_rule, gain_rule_words

    gains = gain_rule(10.0, 3.0 if covered else None, 5.0 if covered else None, base)
    words = gain_rule_words(covered, base)
    assert gains["kD"] == MARGIN * 10.0 and f"kD = {MARGIN:g} kD_min" in words
    kP = MARGIN * 5.0 if covered else gains["kD"] * (base["kP"] / base["kD"] if base else 2.0)
    kV = gains["kD"] * (base["kV"] / base["kD"] if base else 1.0)
    assert gains["kP"] == pytest.approx(kP) and gains["kV"] == pytest.approx(kV)
    assert ("max(eta1, eta2)" in words) == covered and ("base robot" in words) == bool(base)
    assert ("kP = 2 kD" in words) == (not covered and not base) and words.endswith("kV = kD") == (not base)


def test_the_family_rule_in_words_explains_the_gymnasts_kp():
    """Theorem 1 covers the gymnast's folded goal, and there kP is raised to 1.05 max(eta1, eta2) above 2 kD: the
    rule's words say so."""
    from paa_mj.control.gains import FAMILY_RULE, MARGIN, family_gains
    from paa_mj.theory.conditions import thresholds

    robot = load_robot("gymnast")
    gains = family_gains(robot.analytic, Task.named("folded", robot))
    _, e1, e2 = thresholds(robot.analytic)
    assert gains["kP"] == pytest.approx(MARGIN * max(e1.value, e2.value)) and gains["kP"] > FAMILY_RULE.p * gains["kD"]
    assert f"kP = {FAMILY_RULE.p:g} kD (at least {MARGIN:g} max(eta1 (59), eta2 (60))" in FAMILY_RULE.describe()


def test_a_gain_just_below_its_bound_is_not_written_as_equal_to_it():
    from paa_mj.control.gains import apart

    assert apart(4503.38, 4503.3819) == ("4503.38", "4503.382")
    assert apart(4503.3819, 4503.38195) == ("4503.3819", "4503.38195")
    assert apart(2.0, 2.0) == ("2", "2") and apart(1e300, 2e300) == ("1e+300", "2e+300")


def test_the_outcome_reads_the_engine_s_entry_into_region_68_not_the_samples():
    """Sparse samples miss the entry; the sentence states the step the engine judged, on both engines."""
    from paa_mj.sim.analytic.engine import simulate_analytic
    from paa_mj.sim.batch import simulate_batch
    from paa_mj.sim.rollout import simulate_mujoco

    gymnast = load_robot("gymnast")
    folded = Task.named("folded", gymnast)
    traj = simulate_mujoco(gymnast, "vcl-only", t_final=20.0, task=folded, sample_dt=5.0)
    entered = float(simulate_batch(gymnast, folded.start[None], 20.0, controller="vcl-only", task=folded).t_region[0])
    assert np.isfinite(entered) and not folded.in_switch_region(traj.q, traj.qd).any()  # the samples never show it
    assert traj.meta["t_region"] == entered
    # vcl-only has no hand-over to (67): where it went, not a switch it never had (paa_mj.sim.verdict)
    assert traj.outcome().startswith(f"not at the folded goal at the end (entered region (68) at t = {entered:.4f} s)")
    # the analytic engine (continuous control) follows its own chaotic swing: judged against its dense samples
    sparse, dense = (simulate_analytic(gymnast, "vcl-only", t_final=10.0, task=folded, sample_dt=every)
                     for every in (5.0, 0.001))
    inside = folded.in_switch_region(dense.q, dense.qd)
    assert inside.any() and not folded.in_switch_region(sparse.q, sparse.qd).any()
    assert sparse.meta["t_region"] == dense.meta["t_region"] == pytest.approx(dense.t[np.argmax(inside)], abs=1e-3)
    assert f"(entered region (68) at t = {dense.meta['t_region']:.4f} s)" in sparse.outcome()
