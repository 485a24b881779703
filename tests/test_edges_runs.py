"""A run's outcome is said from its own records, in one place (:mod:`paa_mj.sim.verdict`), the same in every
command; a diverged run is said the same way, and exits the same way, wherever it ran."""
from __future__ import annotations

import numpy as np
import pytest

from paa_mj.sim.compiled.step import MAX_SPEED
from paa_mj.sim.verdict import divergence, diverged_words, ending_words, near_duu, outcome_words
from paa_mj.task import Task

CONTROLLERS = '''
import numpy as np


class LateNaN:
    def __init__(self, robot=None):
        self.m = robot.params.n_links - 1

    def torque(self, q, qd, t=0.0):
        return np.full(np.shape(q)[:-1] + (self.m,), np.nan if t > 0.05 else 0.0)


class Holds:
    """A user's controller without a switch."""
    def __init__(self, robot=None):
        self.m = robot.params.n_links - 1

    def torque(self, q, qd, t=0.0):
        return -5.0 * np.asarray(qd)[..., 1:]
'''


@pytest.fixture
def mine(tmp_path):
    path = tmp_path / "mine.py"
    path.write_text(CONTROLLERS)
    return path


def test_divergence_is_found_in_any_simulator_s_records():
    T = np.arange(5) * 0.1
    X = np.zeros((5, 4))
    U = np.zeros((4, 1))
    assert divergence(T, X, U, 2) is None
    U[2] = np.nan
    assert divergence(T, X, U, 2) == (pytest.approx(0.2), "the controller returned a non-finite torque")
    X[1, 3] = 2 * MAX_SPEED
    assert divergence(T, X, U, 2) == (pytest.approx(0.1), f"joint speeds above {MAX_SPEED:g} rad/s")
    assert diverged_words(0.1, "why") == "diverged at t = 0.1000 s: why"


def test_the_ending_is_judged_over_the_last_second_not_one_instant(gymnast):
    folded = Task.named("folded", gymnast)
    turning_point = [3.0, 0.0, 0.0, 0.0, 0.0, 0.0]  # a swing's turning point: at rest for an instant
    assert ending_words(turning_point, folded) == ("", True)
    assert ending_words(turning_point, folded, recent_speeds=[1.0, 0.0])[1]
    words, longer = ending_words(turning_point, folded, recent_speeds=[0.01, 0.0])
    assert "at rest" in words and not longer
    duu = [-np.pi, -np.pi, 0.0, 0.0, 0.0, 0.0]
    assert near_duu(duu, folded)[0] and ending_words(duu, folded)[0].startswith("stuck at DUU")
    assert not near_duu(duu, Task.named("stretched", gymnast))[0]  # DUU is the folded goal's other limit only


def test_an_lqr_alone_that_spins_is_not_told_of_a_switch_nor_of_a_longer_run(gymnast):
    task = Task.named("stretched", gymnast)
    words = outcome_words(status="ok", success=False, task=task, t_final=30.0, switch_time=0.0, t_region=None,
                          hands_over=False, final_state=[575.0, -2535.0, 1.0, -56.0, -78.7, 3.0],
                          recent_speeds=[80.0, 79.0])
    assert words.startswith("not at the stretched goal at the end under the balance (67) from the start (never"
                            " entered region (68) in 30 s), spinning at 78.7 rad/s")
    assert "after switching" not in words and "longer --t-final" not in words
    moving = outcome_words(status="ok", success=False, task=task, t_final=2.0, switch_time=0.0, t_region=None,
                           hands_over=False, final_state=[3.0, 0.5, 0.2, 2.0, -1.0, 0.5], recent_speeds=[2.0, 1.0])
    assert "longer --t-final" not in moving and "region of attraction (paa-mj roa)" in moving  # a balance alone


def test_simulate_from_duu_says_stuck_at_duu_as_basin_does(run):
    result = run("simulate", "--x0", -np.pi, -np.pi, 0, 0, 0, 0, "--t-final", "1.2", "--sample-dt", "0.1")
    outcome = next(line for line in result.stdout.splitlines() if "outcome" in line)
    assert "stuck at DUU" in outcome and "longer --t-final" not in outcome


def test_a_user_controller_without_a_switch_is_not_told_of_one(run, mine):
    result = run("simulate", "--controller", f"{mine}:Holds", "--t-final", "1.2", "--sample-dt", "0.1")
    assert result.returncode == 0, result.stderr
    text = result.stdout
    assert "switch to balance    none (the controller hands over to no balance)" in text
    outcome = next(line for line in text.splitlines() if "outcome" in line)
    assert outcome.split("outcome", 1)[1].strip().startswith("not at the folded goal at the end (never entered")


def test_realaigym_says_a_diverged_run_as_simulate_does_and_exits_3(run, mine):
    """A controller returning NaN: simulate and realaigym both exit 3 naming the non-finite torque, in the same
    words, and NumPy says nothing; realaigym's score stays their code's (NaN, null in JSON: 0 x their costs of
    NaN), its summary says why."""
    sim = run("simulate", "--robot", "realaigym_acrobot", "--goal", "stretched", "--controller", f"{mine}:LateNaN",
              "--t-final", "0.2")
    gym = run("realaigym", "--protocol", "performance-v2", "--controller", f"{mine}:LateNaN", "--json")
    assert sim.returncode == gym.returncode == 3
    for result in (sim, gym):
        said = [line for line in result.stderr.splitlines() if line.startswith("paa-mj: error: ")]
        assert len(said) == 1 and "Warning" not in result.stderr  # NumPy's RuntimeWarnings included
        assert said[0].startswith("paa-mj: error: simulation diverged at t = 0.05")
        assert said[0].endswith(": the controller returned a non-finite torque; try a controller whose torque is"
                                " finite at every state")
    import json

    summary = json.loads(gym.stdout)
    assert summary["result"]["score"] is None and summary["result"]["criteria"]["success"] is False
    assert summary["result"]["diverged"].startswith("diverged at t = ")
