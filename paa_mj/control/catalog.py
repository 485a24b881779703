"""The built-in controllers by name: what each is, which take the gains of (40) and which take options.

Plain data, importable without MuJoCo, numba or SciPy (the command line's help
reads it); :mod:`paa_mj.control.registry` joins each name to its builder.
"""
from __future__ import annotations

#: Built-in controller names and what each is.
DESCRIPTIONS = {
    "vcl": "(40) swing-up, then LQR (67) on entering region (68): the paper's controller",
    "vcl-only": "(40) alone",
    "vcl-roa": "(40) swing-up, then LQR (67) once its cost-to-go is below the level of its region of attraction",
    "vc": "conventional candidate (12), then LQR (67) on entering (68)",
    "vc-only": "conventional candidate (12) alone",
    "vc-roa": "conventional candidate (12), then LQR (67) once its cost-to-go is below its region of attraction's level",
    "lqr": "LQR (67) alone",
    "passive": "zero torque",
    "trajopt": "minimum-time kip by collocation, tracked by TVLQR, then (67)",
    "trajopt-effort": "least-effort kip over a duration, tracked by TVLQR, then (67)",
    "spong": "Spong's acrobot swing-up, then LQR below a cost-to-go (Drake's defaults; 2 links, --goal stretched)",
    "mpc": "iLQR model-predictive control on the robot's own model over a receding horizon, then an LQR at the goal",
}
#: Controllers that take the gains kD, kP, kV of (40) / (12).
GAIN_CONTROLLERS = ("vcl", "vcl-only", "vcl-roa", "vc", "vc-only", "vc-roa")
#: Controllers that plan a kip, with options limit, duration and intervals.
PLANNERS = ("trajopt", "trajopt-effort")
#: Controllers that balance by the LQR (67), with the option lqr_weights = (q, r): Q = q I, R = r I (the paper's
#: q = 1e4, r = 1 by default).
LQR_CONTROLLERS = ("vcl", "vcl-roa", "vc", "vc-roa", "lqr", "trajopt", "trajopt-effort")
#: Controllers that switch from a swing-up to (67), with the option switch = "region" ((68), the default) or "roa"
#: (the LQR's cost-to-go below the level of its region of attraction, :mod:`paa_mj.theory.roa`).
SWITCHED = ("vcl", "vc")
#: Controllers that can hand over on the LQR's region of attraction, whose level takes the run's torque limits
#: (option limit: the model's actuator ranges capped by it).
ROA_SWITCHED = SWITCHED + ("vcl-roa", "vc-roa")


def hands_over_on_roa(name, switch=None) -> bool:
    """Whether the controller ``name`` (with the option ``switch``) hands over on the LQR's region of attraction,
    whose level depends on the run's torque limits (its option ``limit``)."""
    return name in set(ROA_SWITCHED) - set(SWITCHED) or (name in SWITCHED and switch == "roa")


#: The options of ``mpc`` (:data:`paa_mj.control.mpc.DEFAULTS`).
MPC_OPTIONS = ("horizon", "knot", "period", "iterations", "cold_iterations", "w_angle", "w_speed", "r", "r_rate",
               "terminal", "q_angle", "q_speed", "r_lqr", "rho_in", "rho_out", "pump", "pump_kp", "pump_kd", "restart")
#: Controllers that take options, and which.
OPTIONS = {name: (("limit", "duration", "intervals") if name in PLANNERS else ())
           + (("lqr_weights",) if name in LQR_CONTROLLERS else ()) + (("switch",) if name in SWITCHED else ())
           + (("limit",) if name in ROA_SWITCHED else ())
           for name in DESCRIPTIONS if name in PLANNERS or name in LQR_CONTROLLERS}
OPTIONS["mpc"] = MPC_OPTIONS
