"""The engine's plans through MuJoCo's batch API (paa_mj.sim.compiled.mujoco_batch): the engine's outcome, bit for bit."""
import numpy as np
import pytest

from paa_mj.control import make_controller
from paa_mj.errors import PaaError
from paa_mj.sim import Disturbances
from paa_mj.sim.compiled import engine
from paa_mj.sim.batch import build_plan
from paa_mj.task import as_task

from .helpers import Uncompiled

mujoco_batch = pytest.importorskip("paa_mj.sim.compiled.mujoco_batch")
pytestmark = pytest.mark.skipif(not mujoco_batch.available(), reason="MuJoCo without mujoco.batch")


def _starts(task, n=6, seed=0):
    rng = np.random.default_rng(seed)
    x0 = np.zeros((n, 6))
    x0[:, :3] = rng.uniform(-np.pi, np.pi, (n, 3))
    x0[0] = task.start
    x0[1] = np.concatenate([task.goal + 0.01, [0.0, 0.0, 0.0]])  # balances at once: retires before 3 s
    return x0


def _both(plan, controllers):
    return engine.run(plan, controllers), mujoco_batch.run(plan, controllers)


def test_vcl_on_the_gymnast_equals_the_engine_bit_for_bit(gymnast):
    task = as_task(None, gymnast)
    vcl = make_controller("vcl", gymnast, task=task)
    x0 = _starts(task)
    plan = build_plan(gymnast, task, x0, 3.0, [vcl] * len(x0), every=7)
    ours, theirs = _both(plan, [vcl] * len(x0))
    agreement = mujoco_batch.agreement(ours, theirs)
    assert agreement == {"identical": True, "same_outcomes": True, "max_abs_final_state_diff": 0.0}
    status = ours.state.rollouts["status"]
    assert engine.RETIRED in status and engine.FINISHED in status  # both ways of ending, early and at the end
    assert np.array_equal(ours.samples["q"], theirs.samples["q"]) and not theirs.interrupted


def test_disturbances_plants_and_two_controllers_equal_the_engine(gymnast):
    task = as_task(None, gymnast)
    vcl, lqr = (make_controller(name, gymnast, task=task) for name in ("vcl", "lqr"))
    x0 = _starts(task, 8, seed=1)
    x0[2, 3:] = [2e4, 0.0, 0.0]  # a runaway: stopped as diverged, its last good state kept
    n = len(x0)
    pushes = np.zeros((n, 1, 5))
    pushes[:, 0] = [0.3, 0.05, 5.0, 2.0, -1.0]
    disturbances = Disturbances(noise_std=(1e-3, 1e-2), torque_noise=np.linspace(0, 0.5, n),
                                delay_steps=np.arange(n) % 3, pushes=pushes, seed=7)
    controllers = [vcl, lqr] * (n // 2)
    plan = build_plan(gymnast, task, x0, 0.8, controllers, plants=[None, gymnast.params.scaled(1.1, 0.95)] * (n // 2),
                      torque_limit=np.full((n, 2), 300.0), disturbances=disturbances, every=5)
    assert len(plan.models) == 2
    ours, theirs = _both(plan, controllers)
    assert mujoco_batch.agreement(ours, theirs)["identical"]
    assert ours.state.rollouts["status"][2] in engine.DIVERGED


def test_a_controller_without_compiled_form_is_refused(gymnast):
    task = as_task(None, gymnast)
    slow = Uncompiled(make_controller("vcl", gymnast, task=task))
    plan = build_plan(gymnast, task, task.start[None], 0.01, [slow])
    with pytest.raises(PaaError, match="compiled controllers only"):
        mujoco_batch.run(plan, [slow])


def test_the_bench_rows_report_the_ratio_and_the_agreement(gymnast):
    from paa_mj.studies.bench import mujoco_batch_rows

    task = as_task(None, gymnast)
    rows = mujoco_batch_rows(gymnast, task, make_controller("vcl", gymnast, task=task), _starts(task, 4), 0.02, 1)
    assert rows["mujoco_batch_vs_engine_ratio"] > 0 and rows["mujoco_batch_vs_engine_ratio_1thread"] > 0
    assert rows["mujoco_batch_agreement"]["identical"] and rows["mujoco_batch_rollouts"] == 4
