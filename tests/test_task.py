"""The task (paa_mj/task.py): one definition of the goal, the regions and success, and the binding of a controller
to the robot and task it was built for; properties over chains of 2 to 6 links."""
import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from paa_mj.control import make_controller
from paa_mj.errors import PaaError
from paa_mj.model.dynamics import AnalyticModel
from paa_mj.model.params import RobotParams
from paa_mj.task import BOOK, GOALS, Region, Task, as_task, book_rows, goal_angles



@pytest.mark.parametrize("n", range(2, 7))
def test_goal_angles_are_the_folded_and_the_stretched_postures(n):
    folded, stretched = goal_angles("folded", n), goal_angles("stretched", n)
    assert folded[1] == -math.pi and not np.any(np.delete(folded, 1)) and not np.any(stretched)
    assert Task.named("folded", n).goal.tolist() == folded.tolist()


def test_a_task_is_frozen_checked_and_compared_by_every_field():
    task = Task.named("folded", 3)
    with pytest.raises(dataclasses.FrozenInstanceError):
        task.horizon = 10.0
    with pytest.raises(ValueError):
        task.goal[0] = 1.0  # read-only: no layer can move another's goal
    assert task == Task("folded", 3) and hash(task) == hash(Task("folded", 3))
    longer = task.with_(horizon=40.0)
    assert longer != task and longer.aim() == task.aim() and longer.horizon == 40.0
    assert task.with_(switch_region=Region(0.3, 0.5)).aim() != task.aim()
    for bad, fragment in [(dict(name="upside"), "unknown goal 'upside'"),
                          (dict(name="folded", n_links=3, start=[0.0] * 5), "needs 6 finite numbers"),
                          (dict(name="folded", n_links=3, horizon=-1.0), "horizon must be a positive finite"),
                          (dict(name="folded", n_links=3, success_window=math.nan), "success_window must be"),
                          (dict(name="folded", n_links=1), "links")]:
        with pytest.raises(PaaError, match=fragment):
            Task(**{"n_links": 3, **bad})


@pytest.mark.parametrize("goal", GOALS)
def test_every_summary_states_the_task_it_was_judged_by(goal):
    task = Task.named(goal, 4)
    described = task.describe()
    assert described["goal"] == goal and "last 1 s" in described["success_definition"]
    assert described["task"]["goal_angles"] == task.goal.tolist()
    assert Task.from_description(described["task"], 4) == task


def test_the_regions_wrap_angles_and_judge_states_of_the_tasks_width_only():
    task = Task.named("folded", 3)
    q = task.goal + np.array([0.1, 2 * np.pi - 0.1, -4 * np.pi])
    assert task.in_switch_region(q, np.zeros(3)) and task.balanced(task.goal, np.zeros(3))
    assert not task.in_switch_region(q, [0, 0, 0.6]) and not task.in_switch_region(task.goal + [0, 0, 0.53], 0.0)
    np.testing.assert_allclose(task.error(q, np.zeros(3))[:3], [0.1, -0.1, 0.0], atol=1e-12)
    with pytest.raises(PaaError, match="states of 4 angles given to the folded task of a 3-link robot"):
        task.in_switch_region(np.zeros(4), np.zeros(4))
    with pytest.raises(PaaError, match="the stretched task is for a 2-link robot, not for this one of 3 links"):
        as_task(Task.named("stretched", 2), 3)



@settings(max_examples=60, deadline=None)
@given(outside=st.lists(st.booleans(), min_size=2, max_size=40), window=st.integers(1, 45))
def test_the_compiled_book_of_success_is_the_definition_in_words(outside, window):
    """States inside or outside the success region, step by step: the book's verdict is what the definition says
    (inside over the last ``window`` steps), whatever the sequence."""
    task = Task.named("folded", 3)
    far = task.goal + [1.0, 0, 0]
    q = np.array([far if o else task.goal for o in outside])
    book = np.full(len(BOOK), -1, np.int64)
    steps = np.arange(len(q), dtype=np.int64)
    book_rows(task.params, q, np.zeros_like(q), steps, book)
    end = len(q) - 1
    verdict = task.succeeded(book, end, True, False, task.success_window / window)[0]
    last_exit = max((k for k, o in enumerate(outside) if o), default=-1)
    assert verdict == (last_exit < end - min(window, end))
    assert not task.succeeded(book, end, False, False, task.success_window / window)[0]  # diverged: never


def _chain(m, l, frac, jscale, g):
    m, l = np.array(m), np.array(l)
    return AnalyticModel.from_params(RobotParams(m=m, l=l, lc=np.array(frac) * l, J=np.array(jscale) * m * l**2 / 12,
                                                 g=g))


@settings(max_examples=25, deadline=None)
@given(n=st.integers(2, 6), data=st.data(), goal=st.sampled_from(GOALS), g=st.floats(1.0, 20.0))
def test_every_goal_of_every_chain_is_an_equilibrium_at_its_energy(n, data, goal, g):
    """For random chains of 2 to 6 links: the goal is an equilibrium (G(q*) = 0), its energy at rest is the task's
    goal energy, and the task's error is periodic in every angle."""
    floats = lambda lo, hi: st.lists(st.floats(lo, hi), min_size=n, max_size=n)  # noqa: E731
    am = _chain(data.draw(floats(0.1, 80)), data.draw(floats(0.1, 3)), data.draw(floats(0, 1)),
                data.draw(floats(0.05, 3)), g)
    task = Task.named(goal, n)
    scale = float(np.sum(np.abs(am.beta)))
    np.testing.assert_allclose(am.gravity(task.goal), 0.0, atol=1e-12 * scale)
    assert am.energy(task.goal, np.zeros(n)) == pytest.approx(task.goal_energy(am), abs=1e-12 * scale)
    q = data.draw(st.lists(st.floats(-10, 10), min_size=n, max_size=n))
    turns = data.draw(st.lists(st.integers(-3, 3), min_size=n, max_size=n))
    np.testing.assert_allclose(task.error(np.add(q, 2 * np.pi * np.array(turns)), np.zeros(n)),
                               task.error(q, np.zeros(n)), atol=1e-9)


# --- a controller is bound to its robot and its task --------------------------------------------------------


def test_a_controller_run_on_another_robot_is_refused_naming_both(gymnast):
    from paa_mj.model import load_robot
    from paa_mj.sim import simulate_batch, simulate_mujoco

    chain4 = load_robot("chain4")
    controller = make_controller("vcl", gymnast)
    for run in (lambda: simulate_mujoco(chain4, controller, t_final=0.1),
                lambda: simulate_batch(chain4, Task.named("folded", chain4).start[None], 0.1, controller=controller)):
        with pytest.raises(PaaError, match=r"built for robot gymnast \(3 links.*not for robot chain4 \(4 links"):
            run()


def test_a_controller_judged_by_another_task_is_refused(gymnast):
    from paa_mj.sim import simulate_mujoco

    controller = make_controller("vcl", gymnast, task="folded")
    with pytest.raises(PaaError, match="folded.*stretched|stretched.*folded"):
        simulate_mujoco(gymnast, controller, t_final=0.1, task="stretched")


@pytest.mark.parametrize("name", ["vcl", "vc", "lqr", "passive"])
def test_every_built_in_controller_refuses_states_of_another_width(name, gymnast):
    controller = make_controller(name, gymnast)
    with pytest.raises(PaaError, match="4 angles"):
        controller.torque(np.zeros(4), np.zeros(4), 0.0)
    assert np.shape(controller.torque(np.zeros((5, 3)), np.zeros((5, 3)), 0.0)) == (5, 2)


def test_a_users_controller_that_runs_another_robots_controller_is_one_line(tmp_path, run):
    (tmp_path / "mine.py").write_text(
        "from paa_mj.control import make_controller\n"
        "from paa_mj.model import load_robot\n\n\n"
        "class Borrowed:\n"
        "    def __init__(self, robot):\n"
        "        self.inner = make_controller('vcl', load_robot('gymnast'))\n\n"
        "    def torque(self, q, qd, t):\n"
        "        return self.inner.torque(q, qd, t)\n")
    proc = run("simulate", "--robot", "chain4", "--controller", f"{tmp_path / 'mine.py'}:Borrowed",
               "--t-final", "0.1", cwd=tmp_path)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and "4 angles" in proc.stderr, proc.stderr


def test_a_given_t_final_is_the_horizon_the_run_states(run):
    """--t-final is the run's length and the task's horizon in what the run states; without it, the task's."""
    import json

    given = json.loads(run("simulate", "--t-final", "0.2", "--json").stdout)
    assert given["t_final"] == given["task"]["horizon"] == 0.2
    study = run("basin", "--grid", "2", "--t-final", "0.05", "--scheduler", "inline", "--json")
    assert json.loads(study.stdout)["task"]["horizon"] == 0.05, study.stderr


@pytest.mark.parametrize("command", [["basin", "--grid", "2", "--scheduler", "inline"], ["simulate", "--engine",
                                                                                         "analytic"]])
def test_a_t_final_between_two_steps_is_refused_by_every_command(command, run):
    """Every engine ends at the nearest step: a time between two is refused, as MuJoCo's simulate refuses it."""
    result = run(*command, "--t-final", "0.0015")
    assert result.returncode == 2 and result.stderr == (
        "paa-mj: error: final time 0.0015 s is not a whole number of time steps (dt = 0.001 s): give 0.001 or"
        " 0.002\n")


def test_the_times_a_refusal_offers_are_whole_steps_as_written(tmp_path, run):
    """A 62.5 us robot: the two times offered are k dt and (k + 1) dt to 12 digits, each accepted as given."""
    robot = tmp_path / "fine.xml"
    made = run("make-model", "--links", "3", "--m", "1", "1", "1", "--l", "1", "1", "1", "--timestep", "6.25e-5",
               "--out", str(robot))
    assert made.returncode == 0, made.stderr
    refused = run("simulate", "--robot", str(robot), "--t-final", "0.30005", "--kD", "1e3", "--kP", "1e3", "--kV",
                  "1e3")
    assert refused.returncode == 2 and refused.stderr.endswith("give 0.3 or 0.3000625\n"), refused.stderr
    assert "give 1000 or 1000.001" in run("simulate", "--t-final", "1000.0005").stderr


def test_a_run_shorter_than_the_success_window_is_judged_over_all_of_it_and_says_so():
    """A 0.5 s run at 1 ms against a 1 s window: a success only if it never left the success region, as stated."""
    from paa_mj.task import book_succeeded

    task = Task.named("folded", 3)
    assert "the last 1 s of the run, or all of it when shorter" in task.success_definition
    window, end = task.window_steps(1e-3), 500
    assert window == 1000
    never_out, out_at_start = np.array([0, -1, -1]), np.array([0, 0, 0])
    assert book_succeeded(never_out, end, True, False, window)
    assert not book_succeeded(out_at_start, end, True, False, window)
