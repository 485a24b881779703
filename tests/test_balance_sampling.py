"""The balance LQR (67) held over the time step: the largest stable step, the model's step make-model writes, the
warning a run gives where its balance cannot hold, and the outcome that names it."""
import numpy as np
import pytest

from paa_mj.model.robot import load_robot
from paa_mj.sim.compiled import retirement
from paa_mj.task import Task
from paa_mj.theory.linear import balance_time_step, lqr_gain, sampled_spectral_radius, stable_sampling_step


@pytest.fixture
def fresh_warnings(monkeypatch):
    monkeypatch.setattr(retirement, "_WARNED", set())


@pytest.mark.parametrize("name, goal", [("gymnast", "folded"), ("example2", "stretched"), ("acrobot", "stretched")])
def test_the_stable_step_is_the_largest_stable_halving(name, goal):
    am = load_robot(name).analytic
    task = Task.named(goal, am)
    K = lqr_gain(am, task)
    step = stable_sampling_step(am, K, 1e-3, task)
    assert step is not None and sampled_spectral_radius(am, K, step, task) < 1
    assert sampled_spectral_radius(am, K, step / 2, task) < 1
    if step < 1e-3:  # the halving before it is unstable
        assert sampled_spectral_radius(am, K, 2 * step, task) >= 1
    both = balance_time_step(am, [Task.named(g, am) for g in ("folded", "stretched")])
    assert both <= step


def test_example2_needs_a_shorter_step_at_the_stretched_goal_than_the_gymnast():
    """The paper's gymnast balances when sampled at its 1 ms; Table 2's robot at its stretched goal does not."""
    gymnast, example2 = (load_robot(n).analytic for n in ("gymnast", "example2"))
    assert balance_time_step(gymnast, [Task.named(g, gymnast) for g in ("folded", "stretched")]) == 1e-3
    assert stable_sampling_step(example2, lqr_gain(example2, Task.named("stretched", example2)), 1e-3,
                                Task.named("stretched", example2)) < 1e-3


def test_make_model_writes_the_step_its_balance_needs(tmp_path, run):
    path = tmp_path / "c4.xml"
    made = run("make-model", "--links", 4, "--m", 1, 1, 1, 1, "--l", 0.5, 0.5, 0.5, 0.5, "--out", path)
    assert made.returncode == 0, made.stderr
    robot = load_robot(str(path))
    dt = float(robot.model.opt.timestep)
    am = robot.analytic
    assert dt == balance_time_step(am, [Task.named(g, am) for g in ("folded", "stretched")]) < 1e-3
    assert f"Time step {dt * 1e3:g} ms" in made.stdout and f"Time step {dt * 1e3:g} ms" in path.read_text()
    for goal in ("folded", "stretched"):
        task = Task.named(goal, am)
        assert sampled_spectral_radius(am, lqr_gain(am, task), dt, task) < 1
    pinned = run("make-model", "--links", 4, "--m", 1, 1, 1, 1, "--l", 0.5, 0.5, 0.5, 0.5, "--timestep", 0.001,
                 "--out", tmp_path / "pinned.xml")
    assert pinned.returncode == 0 and "Time step" not in pinned.stdout
    assert float(load_robot(str(tmp_path / "pinned.xml")).model.opt.timestep) == 1e-3


def test_a_run_whose_balance_cannot_hold_says_so_once(run, fresh_warnings):
    args = ("simulate", "--robot", "example2", "--goal", "stretched", "--t-final", 0.05)
    first = run(*args)
    assert first.returncode == 0
    lines = [line for line in first.stderr.splitlines() if "unstable when sampled" in line]
    assert len(lines) == 1 and "at dt = 1 ms" in lines[0] and "stable from dt = " in lines[0]
    assert "unstable when sampled" not in run(*args).stderr  # once per robot, goal, step and gain
    stable = run(*args, "--dt", 1.25e-4)
    assert stable.returncode == 0 and "unstable when sampled" not in stable.stderr


def test_the_outcome_names_an_unstable_balance(fresh_warnings, monkeypatch):
    """RealAIGym's acrobot switches to its stretched goal's LQR (67), unstable at 1 ms: the outcome says so; its
    warning and its summary share one computation of the sampled loop."""
    import warnings

    from paa_mj.sim.rollout import simulate_mujoco
    from paa_mj.theory import linear

    radii, radius = [], linear.sampled_spectral_radius
    monkeypatch.setattr(linear, "sampled_spectral_radius", lambda *a: radii.append(a[2]) or radius(*a))
    monkeypatch.setattr(linear, "_SAMPLED_BALANCE", {})
    robot = load_robot("realaigym_acrobot")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        traj = simulate_mujoco(robot, task=Task.named("stretched", robot.analytic), t_final=15.0)
    assert any(issubclass(w.category, retirement.SamplingWarning) for w in caught)
    balance = traj.meta["balance_sampling"]
    assert balance["radius"] >= 1 and balance["stable_dt"] < 1e-3
    assert traj.switch_time is not None
    assert "unstable when sampled at dt = 1 ms" in traj.outcome() and "--switch roa" not in traj.outcome()
    assert np.isfinite(balance["radius"])
    assert radii[0] == 1e-3 and len(radii) == len(set(radii))  # each step's loop once


def test_theory_states_the_step_from_which_the_balance_holds(run):
    import json

    report = json.loads(run("theory", "--robot", "example2", "--goal", "stretched", "--json").stdout)
    am = load_robot("example2").analytic
    task = Task.named("stretched", am)
    assert report["lqr_sampled_radius"] >= 1
    assert report["lqr_stable_dt"] == stable_sampling_step(am, lqr_gain(am, task), 1e-3, task)
    text = run("theory", "--robot", "example2", "--goal", "stretched").stdout
    assert f"stable from dt = {report['lqr_stable_dt'] * 1e3:g} ms" in text
    assert json.loads(run("theory", "--json").stdout)["lqr_stable_dt"] == 1e-3


def test_which_stored_robots_hold_their_balance_at_their_step():
    """docs/family.md: of the stored robots, Table 2's and RealAIGym's acrobots hold the LQR (67) of neither goal
    at their 1 ms; the others hold both."""
    from paa_mj.model.robot import NAMED_ROBOTS

    holds = {}
    for name in NAMED_ROBOTS:
        robot = load_robot(name)
        am, dt = robot.analytic, float(robot.model.opt.timestep)
        tasks = [Task.named(goal, am) for goal in ("folded", "stretched")]
        holds[name] = [sampled_spectral_radius(am, lqr_gain(am, t), dt, t) < 1 for t in tasks]
    assert {n for n, h in holds.items() if not any(h)} == {"example2", "realaigym_acrobot", "realaigym_acrobot_v1"}
    assert {n for n, h in holds.items() if all(h)} == set(holds) - {"example2", "realaigym_acrobot",
                                                                     "realaigym_acrobot_v1"}
