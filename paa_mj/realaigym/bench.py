"""RealAIGym's row of ``paa-mj bench``: the CPU time of one controller's whole robustness v2, its cost per step, and
the ``mpc`` controller's cost per control call."""
from __future__ import annotations

import time

import numpy as np

from ..control.registry import ControllerSpec
from ..model.robot import load_robot
from ..studies.bench import _whole
from ..task import as_task
from .study import T_FINAL, global_v3, run_protocol, their_times


def realaigym_rows(bare_step, progress) -> dict:
    """CPU time of one controller's whole robustness v2 of RealAIGym (Spong's swing-up on their acrobot, compiled),
    and its cost per simulated step against a bare mj_step (``bare_step`` [s])."""
    acrobot = load_robot("realaigym_acrobot")
    spec = ControllerSpec("spong", task=as_task("stretched", acrobot))
    run_protocol("performance-v2", acrobot, spec, "stretched")  # compile (or load) the kernels first
    start = time.process_time()
    summary, _ = _whole(run_protocol("robustness-v2", acrobot, spec, "stretched", progress=progress))
    cpu = time.process_time() - start
    steps = summary["result"]["runs"] * (len(their_times(T_FINAL)) - 1)
    return {"realaigym_robustness_v2_cpu_s": cpu, "realaigym_robustness_v2_runs": summary["result"]["runs"],
            "realaigym_step_ratio": cpu / steps / bare_step, **mpc_call_cost(acrobot)}


class _TimedLaw:
    """A compiled law called once per control step, each call's CPU time on its thread (one core) kept [ns]."""

    def __init__(self, form):
        self.form, self.times = form, []
        self.reset()

    def reset(self):
        self.memory, self.tau = self.form.memory.copy(), np.empty(1)

    def torque(self, q, qd, t):
        x = np.concatenate([q, qd])
        start = time.thread_time_ns()
        self.form.kernel(x, float(t), self.form.params, self.memory, self.tau)
        self.times.append(time.thread_time_ns() - start)
        return self.tau.copy()


def mpc_call_cost(acrobot) -> dict:
    """The ``mpc`` controller's cost per control call on their acrobot [us of one core's CPU time]: its compiled law
    timed at every call of their global v3 test (seed 777: the swing-up from hanging, 15 resets to random states
    with their cold starts, and the balance), median, 99th percentile and worst, against their 2 ms control period.
    The law's first call (loading its compiled code) is not counted."""
    from ..control.registry import make_controller

    task = as_task("stretched", acrobot)
    form = make_controller("mpc", acrobot, task=task).compiled()
    law = _TimedLaw(form)
    law.torque(np.array([-np.pi, 0.0]), np.zeros(2), 0.0)
    law.times.clear()
    global_v3(acrobot, law, task)
    us = np.asarray(law.times, float) / 1e3
    return {"mpc_call_median_us": float(np.median(us)), "mpc_call_p99_us": float(np.percentile(us, 99)),
            "mpc_call_max_us": float(np.max(us)), "mpc_calls": int(us.size)}
