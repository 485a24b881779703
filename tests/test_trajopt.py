"""The kip by optimal control: collocation, TVLQR tracking, and the leaderboard."""
import json

import numpy as np
import pytest

from paa_mj.cli import main
from paa_mj.control.trajopt import solve_kip
from paa_mj.control.tvlqr import kip_controller
from paa_mj.errors import PaaError
from paa_mj.model.states import Q_UDD, X0_HANGING
from paa_mj.sim import simulate_batch
from paa_mj.task import Task

UDD = np.concatenate([Q_UDD, np.zeros(3)])


@pytest.fixture(autouse=True)
def private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("PAA_MJ_CACHE", str(tmp_path / "cache"))


def test_a_short_collocation_solve_satisfies_the_equations_of_motion(gymnast):
    """Hermite-Simpson on a 1 s horizon: converged, the endpoints held, (1) met at the collocation points."""
    start = UDD + [0.05, -0.05, 0.02, 0.0, 0.1, 0.0]
    kip = solve_kip(gymnast.analytic, [300.0, 150.0], "min-effort", duration=1.0, intervals=20, x0=start,
                    use_cache=False)
    assert kip.defects(gymnast.analytic) < 1e-6  # (1) evaluated by NumPy, independently of CasADi
    np.testing.assert_allclose(kip.x[0], start, atol=1e-9)
    np.testing.assert_allclose(kip.x[-1], UDD, atol=1e-9)
    assert np.all(np.abs(kip.u) <= [300.0 + 1e-6, 150.0 + 1e-6])
    assert kip.cost == pytest.approx(kip.effort(), rel=1e-9)


def test_min_time_is_faster_and_min_effort_is_cheaper(gymnast):
    fast = solve_kip(gymnast.analytic, [470.0, 217.0], "min-time", duration=2.0, intervals=20)
    cheap = solve_kip(gymnast.analytic, [470.0, 217.0], "min-effort", duration=3.0, intervals=20)
    assert fast.duration < cheap.duration and cheap.effort() < fast.effort()
    assert max(fast.defects(gymnast.analytic), cheap.defects(gymnast.analytic)) < 1e-6
    again = solve_kip(gymnast.analytic, [470.0, 217.0], "min-time", duration=2.0, intervals=20)
    np.testing.assert_array_equal(again.u, fast.u)  # from the cache


def test_a_believed_model_plans_from_the_plant_s_kip(gymnast, monkeypatch):
    """A controller believing a perturbed model (the model-error factor) starts its solve from the plant's own kip:
    a feasible kip of the believed model, cached apart from the same problem solved from the straight line."""
    import paa_mj.control.trajopt as trajopt
    from paa_mj.control.registry import ControllerSpec

    believed = gymnast.params.scaled(1.05, 0.95)
    starts, solve = [], trajopt._solve
    monkeypatch.setattr(trajopt, "_solve", lambda *args: starts.append(args[8]) or solve(*args))  # its start
    spec = ControllerSpec("trajopt-effort", believed=believed, options=(("limit", (470.0, 217.0)),
                                                                      ("intervals", 30)), check=False)
    spec.build(gymnast)
    plant_kip, believed_start = starts
    assert plant_kip is None and believed_start is not None  # the plant's kip from the line, then the believed one
    assert believed_start.x.shape == (31, 6)
    from paa_mj.model.dynamics import AnalyticModel

    model = AnalyticModel.from_params(believed)
    warm = solve_kip(model, [0.9 * 470.0, 0.9 * 217.0], "min-effort", duration=3.0, intervals=30,
                     start=believed_start)
    assert len(starts) == 2 and warm.defects(model) < 1e-6  # the spec's solve, from the cache
    solve_kip(model, [0.9 * 470.0, 0.9 * 217.0], "min-effort", duration=3.0, intervals=30)
    assert len(starts) == 3 and starts[-1] is None  # from the line: another entry of the cache


@pytest.mark.slow  # three min-time solves: 10 CPU-s (one min-time solve is the quick suite's, above)
def test_the_minimum_time_grows_as_the_torque_bounds_shrink_and_is_not_a_bound(gymnast):
    """The min-time kip is limited by the torques, not by the time range of the solve."""
    from paa_mj.control.trajopt import TIME_RANGE

    times = [solve_kip(gymnast.analytic, np.array([470.0, 217.0]) * scale, "min-time", duration=2.0,
                       intervals=30).duration for scale in (1.0, 0.6, 0.4)]
    assert times[0] < times[1] < times[2]
    low, high = TIME_RANGE
    assert all(low * 1.01 < t < high * 0.99 for t in times)
    assert times[0] < 0.97  # about 0.9 s with 470 and 217 N m: the old bound held every kip at 1 s


def test_a_min_time_kip_at_the_time_bound_is_refused(gymnast, monkeypatch):
    import paa_mj.control.trajopt as trajopt

    monkeypatch.setattr(trajopt, "TIME_RANGE", (1.5, 20.0))  # above the true minimum of about 0.9 s
    with pytest.raises(PaaError, match="shortest time allowed"):
        solve_kip(gymnast.analytic, [470.0, 217.0], "min-time", duration=2.0, intervals=20, use_cache=False)


def test_a_kip_not_found_within_its_budget_is_refused_in_one_line(gymnast, run):
    """IPOPT's CPU time is bounded (``max_cpu_time``): a solve that spends it is refused, naming the budget and how to
    give more; a budget that is not a positive number, and --plan-budget for a controller that plans nothing, too."""
    with pytest.raises(PaaError, match=r"^the min-time kip was not found within its budget of 0\.001 CPU-s .*"
                                       r"--plan-budget"):
        solve_kip(gymnast.analytic, [470.0, 217.0], "min-time", duration=2.0, intervals=20, use_cache=False,
                  budget_cpu_s=0.001)
    for budget in (0.0, -1.0, float("nan"), (1.0, 2.0)):
        with pytest.raises(PaaError, match="budget is one number of CPU-seconds > 0"):
            solve_kip(gymnast.analytic, [470.0, 217.0], "min-time", intervals=20, use_cache=False,
                      budget_cpu_s=budget)
    refused = run("simulate", "--controller", "vcl", "--plan-budget", "5")
    assert refused.returncode == 2 and refused.stderr.strip().splitlines() == [
        "paa-mj: error: --plan-budget applies to the controllers trajopt, trajopt-effort, not to vcl"]


def test_simulate_json_reports_the_plan(capsys, monkeypatch):
    """The plan of simulate's controller in its JSON; planned on 30 intervals instead of the default 100 (a third of
    the solve and of its Riccati sweep, 11 -> 4 CPU-s): what is reported is the same either way."""
    import dataclasses

    from paa_mj.cli import simulate

    planned = simulate.spec_from_args
    monkeypatch.setattr(simulate, "spec_from_args", lambda *args: dataclasses.replace(
        spec := planned(*args), options=spec.options + (("intervals", 30),)))
    assert main(["simulate", "--controller", "trajopt", "--torque-limit", "400", "--t-final", "3", "--json"]) == 0
    plan = json.loads(capsys.readouterr().out)["plan"]
    assert set(plan) == {"objective", "duration", "torque_bounds", "intervals", "cost"} and plan["intervals"] == 30
    assert plan["objective"] == "min-time" and plan["cost"] == pytest.approx(plan["duration"], rel=1e-3)
    assert plan["torque_bounds"] == pytest.approx([360.0, 360.0])  # 90 % of the limit: the rest is the tracking's


def test_tvlqr_tracks_a_solved_kip_in_mujoco_from_perturbed_starts(gymnast):
    kip = solve_kip(gymnast.analytic, [300.0, 150.0], "min-effort", duration=3.0, intervals=40)
    controller = kip_controller(gymnast.analytic, kip, Task.named("folded", gymnast))
    starts = X0_HANGING + np.random.default_rng(0).uniform(-0.03, 0.03, (4, 6))
    result = simulate_batch(gymnast, starts, 6.0, controller=controller, torque_limit=[330.0, 165.0], record=True)
    assert result.balanced.all()
    assert np.all(result.switch_time == pytest.approx(kip.duration, abs=2e-3))  # handed to (67) at the end
    # tracking: at the end of the kip every run is within a few hundredths of the plan
    t = result.trajectories["t"][0]
    k = int(np.argmin(np.abs(t - kip.duration)))
    assert np.max(np.abs(result.trajectories["q"][:, k] - kip.x[-1, :3])) < 0.05


def test_a_failed_solve_is_one_line(gymnast):
    with pytest.raises(PaaError, match="did not converge .*IPOPT"):
        solve_kip(gymnast.analytic, [1.0, 1.0], "min-effort", duration=0.3, intervals=10, max_iter=30,
                  use_cache=False)
    with pytest.raises(PaaError, match="needs a duration"):
        solve_kip(gymnast.analytic, [100.0, 100.0], "min-effort")


def _compare_summary(capsys, monkeypatch, controllers, t_final=25.0):
    """``compare --quick --json`` of ``controllers`` on two levels per sweep, one trial each, and its summary."""
    import paa_mj.studies.compare as compare_module

    # two levels per sweep at --quick (every other level): every believed model of the sweep plans its own kip, a
    # solve each; 0 % is the true model, whose kip is the one planned already: one solve more, not two
    monkeypatch.setattr(compare_module, "SWEEPS", {"model_error": (1.0, 0.0, 3.0, 5.0), "delay": (1.0, 2.0, 3.0, 5.0)})
    assert main(["compare", "--quick", "--controllers", ",".join(controllers), "--trials", "1", "--grid", "2",
                 "--t-final", str(t_final), "--scheduler", "inline", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["robot"] == "gymnast" and set(summary["controllers"]) == set(controllers)
    _every_key(summary)
    return summary


def test_compare_quick_json_has_every_key_of_a_controller(capsys, monkeypatch):
    """The quick form of the next test: the keys of every row and factor, for the paper's controller alone over
    15 s (the planned kip, an IPOPT solve per believed model, and both successes are the slow test's)."""
    summary = _compare_summary(capsys, monkeypatch, ["vcl"], t_final=15.0)  # too short to count as balanced: the
    assert summary["controllers"]["vcl"]["plan"] is None                  # successes are the slow test's


@pytest.mark.slow  # an IPOPT solve per believed model of the sweep: 23 CPU-s
def test_compare_quick_json_has_every_key(capsys, monkeypatch):
    summary = _compare_summary(capsys, monkeypatch, ["vcl", "trajopt-effort"])
    vcl, kip = summary["controllers"]["vcl"], summary["controllers"]["trajopt-effort"]
    assert vcl["success"] and kip["success"]
    assert vcl["plan"] is None and kip["plan"]["objective"] == "min-effort"
    assert max(kip["max_tau"]) <= max(summary["torque_limit"]) + 1e-9  # under the limit vcl itself uses
    assert kip["t_balanced"] < vcl["t_balanced"] and kip["int_tau2"] < vcl["int_tau2"]


def _every_key(summary):
    for name, row in summary["controllers"].items():
        for key in ("t_region", "t_balanced", "max_tau", "int_tau2", "work", "smoothness", "max_speed", "success",
                    "robustness"):
            assert key in row, (name, key)
        assert set(row["robustness"]) == {"model_error", "noise", "torque_noise", "delay", "pushes", "initial_state"}
        for factor, rate in row["robustness"].items():
            assert {"rate", "low", "high", "trials", "random"} <= set(rate)
            if rate["random"]:  # an interval over independent draws, its bounds around the rate
                assert rate["low"] <= rate["rate"] <= rate["high"]
            else:  # a sweep: one run per level, no interval
                assert factor in ("model_error", "delay") and rate["low"] is None and rate["high"] is None
                assert rate["trials"] == len(summary["factors"][factor]["levels"]) > 1
        # every run, reach and robustness included, under the one torque limit
        assert all(t <= lim + 1e-9 for t, lim in zip(row["max_abs_tau"], summary["torque_limit"]))
    assert "region (68)" in summary["success_definition"]
    # the labels state the levels run: --quick's every other one (0 and 5 of 1, 0, 3, 5 here)
    assert [summary["factors"][f]["label"] for f in ("model_error", "delay")] == ["model error 0, 5 %",
                                                                                   "delay 2, 5 ms"]
