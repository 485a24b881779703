"""The paper's theory for one robot: the conditions of Theorem 1 and the linear analysis at UDD.

- :mod:`~paa_mj.theory.conditions`: kD_min (41), eta1 (59), eta2 (60), constraint (54), deltabar (30);
- :mod:`~paa_mj.theory.linear`: linearisation at UDD, controllability, the LQR gain of (67);
- :mod:`~paa_mj.theory.maxima`: the coarse-grid-plus-zoom maxima these need, and a certified branch and bound;
- :mod:`~paa_mj.theory.kd_search`: kD_min of (41) for any chain, certified (bounds in
  :mod:`~paa_mj.theory.bounds` and :mod:`~paa_mj.theory.second_order`);
- :mod:`~paa_mj.theory.merged`: deltabar (30) of the merged acrobot over every frozen posture, its sign decided.

The closed-loop analysis at DUU needs controller (40) and lives in
:mod:`paa_mj.control.closed_loop`; the whole report is
:func:`paa_mj.outputs.theory_report.theory_report`.
"""
from ..lazy import lazy_exports

_EXPORTS = {
    "Constraint54": ".conditions",
    "chain_kd_min": ".conditions",
    "constraint_54": ".conditions",
    "deltabar": ".conditions",
    "eta1": ".conditions",
    "eta1_function": ".conditions",
    "eta2": ".conditions",
    "eta2_function": ".conditions",
    "f54": ".conditions",
    "frozen_acrobot_controllable": ".conditions",
    "kd_bound_function": ".conditions",
    "kd_min": ".conditions",
    "thresholds": ".conditions",
    "LQR_Q": ".linear",
    "LQR_R": ".linear",
    "lqr_gain": ".linear",
    "udd_controllability": ".linear",
    "udd_linearization": ".linear",
    "kd_min_search": ".kd_search",
    "merged_acrobot": ".merged",
    "Maximum": ".maxima",
    "branch_and_bound": ".maxima",
    "grid_maximum": ".maxima",
}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())

__all__ = ["Constraint54", "LQR_Q", "LQR_R", "Maximum", "branch_and_bound", "chain_kd_min", "constraint_54", "deltabar",
           "eta1", "eta1_function", "eta2", "eta2_function", "f54", "frozen_acrobot_controllable", "grid_maximum",
           "kd_bound_function", "kd_min", "kd_min_search", "lqr_gain", "merged_acrobot", "thresholds",
           "udd_controllability", "udd_linearization"]
