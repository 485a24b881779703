"""Every registered controller, enrolled in the same checks (as dm_control's ``domains_test`` enrols every task).

Each built-in controller's record (:mod:`paa_mj.control.record`) declares the chains and goals it applies to; on
every stored robot and goal it applies to (its ``checked`` ones for a planner) it is built, bound to the robot and
task, run for a few steps on the compiled MuJoCo engine and on the analytic one (which agree over them), and its
compiled law equals its NumPy law state by state where it has one; where it does not apply it is refused in one
line. A controller added in its own module is found and checked here with nothing else to change.
"""
import warnings

import numpy as np
import pytest

from paa_mj.control import catalog
from paa_mj.control.base import Binding
from paa_mj.control.gains import GainsNote, TheoryWarning
from paa_mj.control.record import GOALS
from paa_mj.control.registry import RECORDS, ControllerSpec
from paa_mj.errors import PaaError, SimulationDiverged
from paa_mj.model.robot import NAMED_ROBOTS, load_robot
from paa_mj.sim.analytic.engine import simulate_analytic
from paa_mj.sim.compiled.engine import evaluate
from paa_mj.sim.rollout import simulate_mujoco
from paa_mj.task import Task
from tests import tiers

#: A run this long [s]: a few dozen steps of each engine.
T_RUN = 0.03
_ROBOTS = {}


def _robot(name):
    if name not in _ROBOTS:
        _ROBOTS[name] = load_robot(name)
    return _ROBOTS[name]


def _links(name):
    return _robot(name).params.n_links


def _passive(name):
    """The stored robot's passive joints, 1-based (as a record declares them)."""
    return tuple(j + 1 for j in _robot(name).params.passive)


def _cases():
    applies, refused = [], []
    for name, record in RECORDS.items():
        for robot in NAMED_ROBOTS:
            for goal in GOALS:
                if not record.applies_to(_links(robot), goal, _passive(robot)):
                    refused.append((name, robot, goal))
                elif record.checked is None or (robot, goal) in record.checked:
                    applies.append((name, robot, goal))
    return applies, refused


APPLIES, REFUSED = _cases()


def _build(name, robot, goal, check=True):
    """The controller ``name`` for the stored ``robot`` and ``goal``; a gain controller takes the robot's stored
    gains, unchecked (``check=False``: the law is checked here, the gains and their rule in test_family_gains)."""
    r, record = _robot(robot), RECORDS[name]
    task = Task.named(goal, r)
    gains = tuple(r.gains.values()) if record.gains and not check else None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", (TheoryWarning, GainsNote))
        return ControllerSpec(name, gains, check=check, options=record.check_options, task=task).build(r), task


def test_the_command_line_s_view_of_the_records_is_the_registry_s():
    """:mod:`~paa_mj.control.catalog` reads the records from the modules' text (no import); the registry imports
    them: the same controllers, capabilities and builders."""
    assert list(catalog.RECORDS) == list(RECORDS)
    for name, record in RECORDS.items():
        text = catalog.RECORDS[name]
        assert (text.module, text.build) == (record.module, record.build.__name__)
        assert text.kernels == tuple(k.__name__ for k in record.kernels)
        for field in ("description", "gains", "plans", "lqr", "switches", "roa", "device", "links", "passive",
                      "hands_over", "settings", "goals",
                      "compare", "checked", "check_options", "options"):
            assert getattr(text, field) == getattr(record, field), (name, field)


def test_every_controller_is_enrolled_somewhere():
    """Every controller has cases; the quick suite runs every one's but those that solve plans as they build or run
    (trajectory optimisation, mpc's solver), whose cases run under ``slow`` (tests/tiers.py says why)."""
    assert {case[0] for case in APPLIES} == set(RECORDS)
    slow = {name for name, robot, goal in APPLIES
            if tiers.reason(f"tests/test_registered_controllers.py::test_builds_binds_and_runs_on_both_engines"
                            f"[{name}-{robot}-{goal}]")}
    assert slow == {"mpc", "trajopt", "trajopt-effort"}


@pytest.mark.parametrize("name, robot, goal", APPLIES)
def test_builds_binds_and_runs_on_both_engines(name, robot, goal):
    """Built for the robot and task, bound to both; a short run from the task's start on the compiled MuJoCo engine
    and on the analytic one (or as much of each as it kept where it stopped, in one line) stays finite, and both
    start with the same torque (the law called the same way by both engines); a sampled-data law (one that says so,
    ``sampled_data``) is refused by the analytic engine in one line instead; where it has a compiled law, that law
    equals its NumPy law."""
    controller, task = _build(name, robot, goal, check=False)
    r = _robot(robot)
    assert controller.binding == Binding.of(r, task, name)
    if getattr(controller, "sampled_data", None):  # tied to time steps: the analytic engine refuses it, saying why
        with pytest.raises(PaaError, match=f"{name} .* \\(a sampled-data controller\\); use --engine cpu"):
            simulate_analytic(r, controller, t_final=T_RUN, task=task)
        engines = (simulate_mujoco,)
    else:
        engines = (simulate_mujoco, simulate_analytic)
    runs = [_run(simulate, r, controller, task) for simulate in engines]
    for run in runs:
        assert np.all(np.isfinite(run.q)) and np.all(np.isfinite(run.qd)) and run.t[0] == 0.0
    if len(runs) == 2:
        np.testing.assert_allclose(runs[1].tau[0], runs[0].tau[0], rtol=1e-9, atol=1e-12)
    if RECORDS[name].compiled:
        _compiled_equals_numpy(controller, task, r.params.n_links)


def _compiled_equals_numpy(controller, task, n):
    """The one definition, two paths: the numba kernel and NumPy, state by state, to rounding (random states, and
    states near the goal where a switched controller balances)."""
    rng = np.random.default_rng(7)
    q, qd = rng.uniform(-np.pi, np.pi, (60, n)), rng.uniform(-3, 3, (60, n))
    q[:20], qd[:20] = task.goal + rng.uniform(-0.2, 0.2, (20, n)), rng.uniform(-0.2, 0.2, (20, n))
    compiled, modes = evaluate(controller.compiled(), q, qd)
    expected = np.empty_like(compiled)
    expected_modes = np.empty(len(q), int)
    for i in range(len(q)):  # one state at a time, each from a fresh switch
        controller.reset()
        expected[i] = controller.torque(q[i], qd[i])
        expected_modes[i] = int(np.ravel(controller.mode)[0]) if hasattr(controller, "mode") else 0
    if hasattr(controller, "mode"):
        np.testing.assert_array_equal(modes, expected_modes)
    scale = np.maximum(1.0, np.abs(expected))
    assert np.max(np.abs(compiled - expected) / scale) < 1e-12


def _run(simulate, robot, controller, task):
    """A run of :data:`T_RUN`, or as much of it as the engine kept where it stopped (a loop unstable when sampled,
    a step size below the analytic integrator's least), the reason in one line."""
    try:
        run = simulate(robot, controller, t_final=T_RUN, task=task)
    except SimulationDiverged as stopped:
        assert "\n" not in str(stopped)
        return stopped.trajectory
    assert run.t[-1] == pytest.approx(T_RUN)
    return run


@pytest.mark.parametrize("name, robot, goal", REFUSED)
def test_refused_in_one_line_where_it_does_not_apply(name, robot, goal):
    with pytest.raises(PaaError) as refusal:
        _build(name, robot, goal)
    assert "\n" not in str(refusal.value) and name in str(refusal.value)


@pytest.mark.parametrize("name", [name for name, record in RECORDS.items() if record.device])
def test_a_device_law_translates_to_warp(name):
    """Where a record says its law runs on the device, each of its kernels translates (Warp's CPU device)."""
    pytest.importorskip("warp")
    from paa_mj.sim.warp.translate import device_function
    from paa_mj.sim.warp.device import load_warp

    wp, _ = load_warp(mujoco=False)  # the translation needs Warp alone
    for kernel in RECORDS[name].kernels:
        assert device_function(wp, kernel, real=wp.float64, state_size=6) is not None
