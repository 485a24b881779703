"""Rollouts: MuJoCo single and batch through one compiled engine, and the exact analytic closed loop.

- :mod:`~paa_mj.sim.records`: the records the compiled engine reads and writes;
- :mod:`~paa_mj.sim.step`: one step of a rollout, compiled;
- :mod:`~paa_mj.sim.engine`: the rollout engine (controller + ``mj_step`` in compiled code);
- :mod:`~paa_mj.sim.batch`: :func:`simulate_batch`, many rollouts with per-rollout plants and :class:`Disturbances`;
- :mod:`~paa_mj.sim.rollout`: :func:`simulate_mujoco`, one rollout recorded as a :class:`Trajectory`;
- :mod:`~paa_mj.sim.analytic`: :func:`simulate_analytic`, (1) integrated by ``solve_ivp``;
- :mod:`~paa_mj.sim.trajectory`: the record and its files.

Every entry point takes the :class:`~paa_mj.task.Task` its runs aim at and are judged by.
"""
from ..lazy import lazy_exports

_EXPORTS = {
    "simulate_analytic": ".analytic",
    "BatchResult": ".batch",
    "Disturbances": ".batch",
    "simulate_batch": ".batch",
    "simulate_mujoco": ".rollout",
    "Trajectory": ".trajectory",
}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())

__all__ = ["BatchResult", "Disturbances", "Trajectory", "simulate_analytic", "simulate_batch", "simulate_mujoco"]
