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
    fast = solve_kip(gymnast.analytic, [470.0, 217.0], "min-time", duration=2.0, intervals=40)
    cheap = solve_kip(gymnast.analytic, [470.0, 217.0], "min-effort", duration=3.0, intervals=40)
    assert fast.duration < cheap.duration and cheap.effort() < fast.effort()
    assert max(fast.defects(gymnast.analytic), cheap.defects(gymnast.analytic)) < 1e-6
    again = solve_kip(gymnast.analytic, [470.0, 217.0], "min-time", duration=2.0, intervals=40)
    np.testing.assert_array_equal(again.u, fast.u)  # from the cache


def test_tvlqr_tracks_a_solved_kip_in_mujoco_from_perturbed_starts(gymnast):
    kip = solve_kip(gymnast.analytic, [300.0, 150.0], "min-effort", duration=3.0, intervals=40)
    controller = kip_controller(gymnast.analytic, kip)
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


def test_compare_quick_json_has_every_key(capsys):
    assert main(["compare", "--quick", "--controllers", "vcl,trajopt-effort", "--trials", "1", "--grid", "2",
                 "--t-final", "25", "--scheduler", "inline", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["robot"] == "gymnast" and set(summary["controllers"]) == {"vcl", "trajopt-effort"}
    for name, row in summary["controllers"].items():
        for key in ("t_region", "t_balanced", "max_tau", "int_tau2", "work", "smoothness", "max_speed", "success",
                    "robustness"):
            assert key in row, (name, key)
        assert set(row["robustness"]) == {"model_error", "noise", "torque_noise", "delay", "pushes", "initial_state"}
        for rate in row["robustness"].values():
            assert set(rate) == {"rate", "low", "high", "trials"}
    vcl, kip = summary["controllers"]["vcl"], summary["controllers"]["trajopt-effort"]
    assert vcl["success"] and kip["success"]
    assert max(kip["max_tau"]) <= max(summary["torque_limit"]) + 1e-9  # under the limit vcl itself uses
    assert kip["t_balanced"] < vcl["t_balanced"] and kip["int_tau2"] < vcl["int_tau2"]
