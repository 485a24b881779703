"""The studies' settings: grids, ranges, factors and levels, the leaderboard's sizes.

Plain data, importable without MuJoCo, numba or SciPy: the command line's help
shows them, and each study module takes its own from here.
"""
from __future__ import annotations

import math

from ..control import catalog

# --- basin (:mod:`paa_mj.studies.basin`) ------------------------------------------------------------

#: The coordinates a basin grid can span (the state [q1, q2, q3, d1, d2, d3]).
BASIN_COORDINATES = ("q1", "q2", "q3", "d1", "d2", "d3")
#: Default range of each coordinate on the grid: angles over a full turn [rad], speeds +-5 rad/s.
BASIN_RANGE = {"q1": (-math.pi, math.pi), "q2": (-math.pi, math.pi), "q3": (-math.pi, math.pi),
               "d1": (-5.0, 5.0), "d2": (-5.0, 5.0), "d3": (-5.0, 5.0)}
#: The most points per axis of a basin grid.
BASIN_MAX_GRID = 2048

# --- robustness (:mod:`paa_mj.studies.robustness`) --------------------------------------------------

#: Each factor's meaning and default levels (the first is the nominal case).
ROBUSTNESS_FACTORS = {
    "noise": {"label": "measurement noise std on q [rad] and qd [rad/s]", "levels": [0.0, 0.01, 0.03, 0.1]},
    "torque_limit": {"label": "torque limit, fraction of the nominal peak |tau|", "levels": [math.inf, 1.0, 0.6, 0.3]},
    "model_error": {"label": "controller's masses and lengths off by [%]", "levels": [0.0, 2.0, 5.0, 10.0]},
    "delay": {"label": "control delay [ms]", "levels": [0.0, 2.0, 5.0, 10.0]},
    "torque_noise": {"label": "torque noise std, fraction of the nominal peak |tau|", "levels": [0.0, 0.01, 0.03, 0.1]},
    "pushes": {"label": "push peak on the hands, fraction of b1", "levels": [0.0, 0.05, 0.1, 0.2]},
    "initial_state": {"label": "start perturbed by +- [rad, rad/s]", "levels": [0.0, 0.01, 0.1, 0.3]},
}
ROBUSTNESS_DEFAULT_FACTORS = ("noise", "torque_limit", "model_error", "delay")
#: Where robustness runs start: random states, or the kip from (65).
STARTS = ("random", "hanging")

# --- the leaderboard (:mod:`paa_mj.studies.compare`) ------------------------------------------------

#: The leaderboard's controllers by default: those whose records say so (``compare=True``).
COMPARE_CONTROLLERS = catalog.COMPARE_CONTROLLERS
#: One level per random robustness factor (name in :data:`ROBUSTNESS_FACTORS`: level).
COMPARE_FACTORS = {"noise": 0.01, "torque_noise": 0.03, "pushes": 0.1, "initial_state": 0.1}
#: The levels of each deterministic factor, swept (full size; --quick takes every second one).
COMPARE_SWEEPS = {"model_error": tuple(float(v) for v in range(1, 11)),
                  "delay": tuple(float(v) for v in range(1, 11))}
#: The factors' labels; a swept factor's states its levels in its unit (:func:`factor_label`).
FACTOR_LABELS = {"model_error": "model error {levels}", "noise": "noise 0.01",
                 "torque_noise": "torque noise 3 % of the limit",
                 "delay": "delay {levels}", "pushes": "pushes 0.1 b1", "initial_state": "start +-0.1"}
SWEEP_UNITS = {"model_error": "%", "delay": "ms"}


def factor_label(factor, levels=None):
    """The label of a leaderboard factor, a swept one's with its ``levels`` (default: the full sweep): "1-10 %" for
    evenly spaced levels one apart, "2-10 %, every 2 %" for those of ``--quick``, else the list."""
    if factor not in SWEEP_UNITS:
        return FACTOR_LABELS[factor]
    levels, unit = COMPARE_SWEEPS[factor] if levels is None else tuple(levels), SWEEP_UNITS[factor]
    text = ", ".join(f"{v:g}" for v in levels) + f" {unit}"
    steps = {round(b - a, 12) for a, b in zip(levels, levels[1:])}
    if len(levels) > 2 and len(steps) == 1:
        step = steps.pop()
        text = f"{levels[0]:g}-{levels[-1]:g} {unit}" + ("" if step == 1 else f", every {step:g} {unit}")
    return FACTOR_LABELS[factor].format(levels=text)
#: The order of the robustness columns.
FACTOR_ORDER = ("model_error", "noise", "torque_noise", "delay", "pushes", "initial_state")
#: Draws per random factor and points per axis of the reach grid (each run lasts the task's horizon).
COMPARE_SIZES = {"quick": {"trials": 6, "grid": 6}, "full": {"trials": 48, "grid": 16}}

# --- the atlas (:mod:`paa_mj.studies.atlas`) -----------------------------------------------------------

#: The parameters an atlas can scale on the gymnast (any chain: :func:`atlas_parameters`).
ATLAS_PARAMETERS = ("m1", "m2", "m3", "l1", "l2", "l3")


def atlas_parameters(n_links=3):
    """The parameters an atlas can scale on a chain of ``n_links``: m1..mn, then l1..ln."""
    return tuple(f"m{i + 1}" for i in range(n_links)) + tuple(f"l{i + 1}" for i in range(n_links))
#: The default range of the scale factors (log-spaced).
ATLAS_RANGE = (0.25, 4.0)
#: The most factors per parameter.
ATLAS_MAX_GRID = 256

#: RealAIGym's protocols that ``paa-mj realaigym`` runs (:mod:`paa_mj.realaigym.study`).
REALAIGYM_PROTOCOLS = ("performance-v2", "robustness-v2", "global-v3")
#: The engines of RealAIGym's protocols: their simulator compiled on the CPU, or on a Warp device.
REALAIGYM_ENGINES = ("cpu", "warp")
