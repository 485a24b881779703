"""``paa-mj bench``: costs measured in one process, reported as ratios of things measured together.

* bare: ``mj_step`` alone from a Python loop (RK4, 1 ms, Table 1 robot), one thread;
* single: a closed-loop MuJoCo rollout (compiled controller + step + recording), per step;
* numpy: the same with the plain NumPy controller, per step (for comparison);
* batch: :func:`paa_mj.batch.simulate_batch`, per state-step, all cores;
* analytic: the ``solve_ivp`` reference of the 30 s Table 1 run against the MuJoCo rollout.
"""
from __future__ import annotations

import os
import time

import mujoco
import numpy as np

from .controllers import SwitchingController
from .model import load_robot
from .rollout import X0_HANGING, simulate_analytic, simulate_mujoco


def _best_of(fn, repeats):
    """The fastest of ``repeats`` runs (the least disturbed by other work on the machine)."""
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def run_bench(batch_size=1024, batch_seconds=2.0, repeats=3, progress=False):
    from .batch import simulate_batch

    robot = load_robot("gymnast")
    model = robot.model
    data = mujoco.MjData(model)
    n_bare = 20000

    def bare():
        data.qpos[:], data.qvel[:] = [-2.0, -1.0, 0.5], [1.0, -2.0, 0.5]
        for _ in range(n_bare):
            mujoco.mj_step(model, data)

    ctrl = SwitchingController.for_model(robot.analytic, **robot.gains)
    t_single = 30.0
    simulate_mujoco(robot, ctrl, X0_HANGING, 0.01)  # compile (or load) the kernel first
    bare_step = _best_of(bare, repeats) / n_bare
    single = _best_of(lambda: simulate_mujoco(robot, ctrl, X0_HANGING, t_single), repeats)
    single_step = single / round(t_single / model.opt.timestep)
    t_numpy = 2.0
    numpy_step = _best_of(lambda: simulate_mujoco(robot, ctrl, X0_HANGING, t_numpy, compiled=False), 1) \
        / round(t_numpy / model.opt.timestep)

    rng = np.random.default_rng(0)
    x0 = np.zeros((batch_size, 6))
    x0[:, :3] = rng.uniform(-np.pi, np.pi, (batch_size, 3))
    simulate_batch(robot, x0[:4], 0.01)
    batch = _best_of(lambda: simulate_batch(robot, x0, batch_seconds, stop_when_settled=False, progress=progress),
                     repeats)
    batch_state_step = batch / (batch_size * round(batch_seconds / model.opt.timestep))

    analytic = _best_of(lambda: simulate_analytic(robot, SwitchingController.for_model(robot.analytic, **robot.gains),
                                                  X0_HANGING, t_single), 1)
    return {
        "machine_cores": os.cpu_count(),
        "mujoco_version": mujoco.__version__,
        "bare_mj_step_us": bare_step * 1e6,
        "single_step_us": single_step * 1e6,
        "single_step_ratio": single_step / bare_step,
        "numpy_controller_step_us": numpy_step * 1e6,
        "numpy_step_ratio": numpy_step / bare_step,
        "batch_size": batch_size,
        "batch_state_step_us": batch_state_step * 1e6,
        "batch_step_ratio": batch_state_step / bare_step,
        "analytic_30s_seconds": analytic,
        "mujoco_30s_seconds": single,
        "analytic_to_mujoco_ratio": analytic / single,
    }


def format_bench(r) -> str:
    return "\n".join([
        f"paa-mj bench ({r['machine_cores']} cores, MuJoCo {r['mujoco_version']}, Table 1 robot, RK4 1 ms)",
        f"  bare mj_step                     {r['bare_mj_step_us']:8.2f} us/step            = 1",
        f"  closed loop, compiled controller {r['single_step_us']:8.2f} us/step  single_step_ratio = {r['single_step_ratio']:.2f}",
        f"  closed loop, NumPy controller    {r['numpy_controller_step_us']:8.2f} us/step  ratio = {r['numpy_step_ratio']:.2f}",
        f"  batch of {r['batch_size']}, all cores       {r['batch_state_step_us']:8.2f} us/state-step batch_step_ratio = {r['batch_step_ratio']:.2f}",
        f"  30 s Table 1 run: solve_ivp {r['analytic_30s_seconds']:.2f} s, MuJoCo {r['mujoco_30s_seconds']:.2f} s"
        f" (ratio {r['analytic_to_mujoco_ratio']:.1f})",
    ])
