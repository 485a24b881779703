"""The analytic engine: the closed loop (1) integrated with continuous-time control (:mod:`~.engine`), and the RK4
of the robot's own equations the Gymnasium environments step (:mod:`~.rk4`)."""
from ...lazy import lazy_exports

_EXPORTS = {"simulate_analytic": ".engine"}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())

__all__ = ["simulate_analytic"]
