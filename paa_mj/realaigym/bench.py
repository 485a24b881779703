"""RealAIGym's row of ``paa-mj bench``: the CPU time of one controller's whole robustness v2, and its cost per step."""
from __future__ import annotations

import time

from ..control.registry import ControllerSpec
from ..model.robot import load_robot
from ..studies.bench import _whole
from ..task import as_task
from .study import T_FINAL, run_protocol, their_times


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
            "realaigym_step_ratio": cpu / steps / bare_step}
