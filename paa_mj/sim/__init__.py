"""Rollouts: MuJoCo single and batch through one compiled engine, the exact analytic closed loop, MuJoCo Warp.

The engines, each in a room of its own:

- :mod:`~paa_mj.sim.compiled`: the compiled CPU engine and its step (records, step, engine, retirement, MuJoCo from
  numba, ``mujoco.batch`` head to head);
- :mod:`~paa_mj.sim.analytic`: :func:`simulate_analytic`, (1) integrated by ``solve_ivp``, and the RK4 of the
  robot's own equations;
- :mod:`~paa_mj.sim.warp`: the engine on MuJoCo Warp (extra ``gpu``), the compiled step translated to Warp.

What they share, here:

- :mod:`~paa_mj.sim.batch`: :func:`simulate_batch`, many rollouts with per-rollout plants and :class:`Disturbances`,
  on the engine asked for;
- :mod:`~paa_mj.sim.rollout`: :func:`simulate_mujoco`, one rollout recorded as a :class:`Trajectory`;
- :mod:`~paa_mj.sim.trajectory`: the record and its files;
- :mod:`~paa_mj.sim.inputs`, :mod:`~paa_mj.sim.noise`, :mod:`~paa_mj.sim.integrators`: starts and durations, the
  counter-based noise, MuJoCo's integrators.

Every entry point takes the :class:`~paa_mj.task.Task` its runs aim at and are judged by. RealAIGym's own simulator
is in :mod:`paa_mj.realaigym`.
"""
from ..lazy import lazy_exports

_EXPORTS = {
    "simulate_analytic": ".analytic.engine",
    "BatchResult": ".batch",
    "Disturbances": ".batch",
    "simulate_batch": ".batch",
    "simulate_mujoco": ".rollout",
    "Trajectory": ".trajectory",
}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())

__all__ = ["BatchResult", "Disturbances", "Trajectory", "simulate_analytic", "simulate_batch", "simulate_mujoco"]
