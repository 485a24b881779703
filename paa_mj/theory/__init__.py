"""The paper's theory for one robot: the conditions of Theorem 1 and the linear analysis at UDD.

- :mod:`~paa_mj.theory.conditions`: kD_min (41), eta1 (59), eta2 (60), constraint (54), deltabar (30);
- :mod:`~paa_mj.theory.linear`: linearisation at UDD, controllability, the LQR gain of (67);
- :mod:`~paa_mj.theory.maxima`: the coarse-grid-plus-zoom maxima these need.

The closed-loop analysis at DUU needs controller (40) and lives in
:mod:`paa_mj.control.closed_loop`; the whole report is
:func:`paa_mj.outputs.theory_report.theory_report`.
"""
from .conditions import (Constraint54, constraint_54, deltabar, eta1, eta1_function, eta2, eta2_function, f54,
                         frozen_acrobot_controllable, kd_bound_function, kd_min, thresholds)
from .linear import LQR_Q, LQR_R, lqr_gain, udd_controllability, udd_linearization
from .maxima import Maximum, grid_maximum

__all__ = ["Constraint54", "LQR_Q", "LQR_R", "Maximum", "constraint_54", "deltabar", "eta1", "eta1_function", "eta2",
           "eta2_function", "f54", "frozen_acrobot_controllable", "grid_maximum", "kd_bound_function", "kd_min",
           "lqr_gain", "thresholds", "udd_controllability", "udd_linearization"]
