"""Rollouts: MuJoCo single and batch through one compiled engine, and the exact analytic closed loop.

- :mod:`~paa_mj.sim.engine`: the rollout engine (controller + ``mj_step`` in compiled code);
- :mod:`~paa_mj.sim.batch`: :func:`simulate_batch`, many rollouts with per-rollout plants and disturbances;
- :mod:`~paa_mj.sim.rollout`: :func:`simulate_mujoco`, one rollout recorded as a :class:`Trajectory`;
- :mod:`~paa_mj.sim.analytic`: :func:`simulate_analytic`, (1) integrated by ``solve_ivp``;
- :mod:`~paa_mj.sim.trajectory`: the record and its files.
"""
# Names are imported on first use (PEP 562), so that importing one light module of the package
# (the command line's help, a table of names) does not load MuJoCo, numba or SciPy.
import importlib

_EXPORTS = {
    "X0_HANGING": "..model.states",
    "simulate_analytic": ".analytic",
    "BatchResult": ".batch",
    "simulate_batch": ".batch",
    "simulate_mujoco": ".rollout",
    "Trajectory": ".trajectory",
}


def __getattr__(name):
    if name not in _EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(_EXPORTS[name], __name__), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(list(globals()) + list(_EXPORTS))


__all__ = ["BatchResult", "Trajectory", "X0_HANGING", "simulate_analytic", "simulate_batch", "simulate_mujoco"]
