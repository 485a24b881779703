"""A leaderboard of kip controllers, scored the way the RealAIGym benchmark scores double-pendulum swing-ups.

Every controller kips the same robot from (65) in MuJoCo (RK4, 1 ms) under the
same torque limit (by default the peak torques of the paper's controller ``vcl``
there), and is scored on

- performance (:data:`METRICS`): when it first enters region (68) (``t_region``),
  from when it stays within 1e-3 of UDD (``t_balanced``), peak torques, the
  integral of :math:`|\\tau|^2` dt, the work integral of :math:`|\\tau \\cdot \\dot q_a|` dt, the RMS of the
  torque change per second (smoothness) and the peak joint speed; success means
  balanced at the end, and a failure says why;
- robustness (:data:`FACTORS`): the success rate, with its 95 % Wilson interval,
  under one level of each disturbance: controller model error, measurement
  noise, torque noise, control delay, pushes during the swing and a perturbed
  start (:mod:`paa_mj.studies.robustness`); the robustness score is their mean,
  as RealAIGym's;
- reach: the share of a (q1, q2) grid of starts from which it balances
  (:mod:`paa_mj.studies.basin`), which answers "from where?".

RealAIGym also folds the performance metrics into one score with normalisers
fixed for the double pendulum; none exist for the gymnast, so the leaderboard
shows the metrics themselves, and how each controller's time and effort compare
with ``vcl``'s.
"""
from __future__ import annotations

import numpy as np

from ..control.registry import OPTIONS, ControllerSpec
from ..errors import PaaError
from ..model.robot import Robot
from ..model.states import X0_HANGING
from ..sim.batch import kip_peak_torques, simulate_batch
from .basin import basin
from .robustness import robustness

DEFAULT_CONTROLLERS = ("vcl", "vc", "trajopt", "trajopt-effort")
#: One level per robustness factor (name in :data:`paa_mj.studies.robustness.FACTORS`: level).
FACTORS = {"model_error": 5.0, "noise": 0.01, "torque_noise": 0.03, "delay": 5.0, "pushes": 0.1,
           "initial_state": 0.1}
FACTOR_LABELS = {"model_error": "model error 5 %", "noise": "noise 0.01", "torque_noise": "torque noise 3 %",
                 "delay": "delay 5 ms", "pushes": "pushes 0.1 b1", "initial_state": "start +-0.1"}
METRICS = ("t_region", "t_balanced", "max_tau", "int_tau2", "work", "smoothness", "max_speed", "success")
SIZES = {"quick": {"trials": 6, "grid": 6, "t_final": 30.0}, "full": {"trials": 48, "grid": 16, "t_final": 30.0}}


def _spec(name, limit):
    options = (("limit", tuple(limit)),) if name in OPTIONS else ()
    return ControllerSpec(name, options=options)


def _why(result, i, t_final):
    if result.diverged[i]:
        return f"diverged at t = {result.t_end[i]:.3f} s"
    if not np.isfinite(result.t_region[i]):
        return f"never entered region (68) in {t_final:g} s"
    if not np.isfinite(result.switch_time[i]):
        return "entered region (68) but never switched to the balance controller"
    return "switched but was not balanced at the end"


def _none(value):
    return None if value is None or not np.isfinite(value) else float(value)


def performance(robot: Robot, controller, limit, t_final=30.0):
    """The metrics of one kip from (65), and its trajectory (t, q, qd, tau, mode)."""
    result = simulate_batch(robot, X0_HANGING[None], t_final, controller=controller, torque_limit=limit,
                            retire=False, record=True, sample_dt=0.01)
    if result.interrupted:  # a truncated kip would give wrong metrics: stop the study here
        raise KeyboardInterrupt
    n = int(result.trajectories["count"][0])
    trajectory = {k: result.trajectories[k][0, :n] for k in ("t", "q", "qd", "tau", "mode")}
    success = bool(result.success()[0])
    metrics = {"t_region": _none(result.t_region[0]), "t_balanced": _none(result.t_balanced[0]),
               "max_tau": result.max_abs_tau[0].tolist(), "int_tau2": float(result.int_tau2[0]),
               "work": float(result.work[0]), "smoothness": float(result.smoothness[0]),
               "max_speed": float(result.max_speed[0]), "success": success,
               "why": None if success else _why(result, 0, t_final)}
    return metrics, trajectory


def compare(robot: Robot, controllers=DEFAULT_CONTROLLERS, torque_limit=None, trials=None, quick=False,
            t_final=None, seed=0, scheduler="inline", out_dir=None, fresh=False, progress=False, grid=None):
    """The leaderboard; returns (summary, trajectories by controller, basins by controller).

    Parameters
    ----------
    controllers : sequence of str
        Built-in names or ``file.py:ClassName``.
    torque_limit : float, optional
        The same saturation [N m] for every controller (default: vcl's peak torques from (65)).
    """
    sizes = dict(SIZES["quick" if quick else "full"])
    if trials is not None:
        sizes["trials"] = trials
    if t_final is not None:
        sizes["t_final"] = t_final
    if grid is not None:
        sizes["grid"] = grid
    names = list(dict.fromkeys(controllers))
    if not names:
        raise PaaError("--controllers needs at least one controller")
    by_folder = {}
    for name in names:
        other = by_folder.setdefault(folder_name(name), name)
        if other != name:
            raise PaaError(f"controllers {other} and {name} would share the name {folder_name(name)} in the results:"
                           " rename one file or class")
    specs = {name: None for name in names}
    limit = np.full(2, float(torque_limit)) if torque_limit is not None else \
        np.minimum(kip_peak_torques(robot, "vcl"), robot.torque_limits)
    for name in names:
        specs[name] = _spec(name, limit)
        specs[name].build(robot)  # gains, files and solves checked (one line) before any study runs
    summary = {"robot": robot.name, "torque_limit": limit.tolist(), "t_final": sizes["t_final"],
               "trials": sizes["trials"], "grid": sizes["grid"], "seed": seed,
               "factors": {k: {"level": v, "label": FACTOR_LABELS[k]} for k, v in FACTORS.items()},
               "interrupted": False, "controllers": {}}
    trajectories, basins = {}, {}
    for name in names:
        spec = specs[name]
        controller = spec.build(robot)
        metrics, trajectories[name] = performance(robot, controller, limit, sizes["t_final"])
        folder = None if out_dir is None else f"{out_dir}/studies/{folder_name(name)}"
        rob, _ = robustness(robot, trials=sizes["trials"], t_final=sizes["t_final"], seed=seed, controller=spec,
                            factors=list(FACTORS), levels={k: [v] for k, v in FACTORS.items()}, start="hanging",
                            progress=progress, scheduler=scheduler, out_dir=folder, fresh=fresh, torque_limit=limit)
        rates = {}
        for factor, data in rob["factors"].items():
            level = data["levels"][0]
            rates[factor] = {"rate": level["success_rate"], "low": level["low"], "high": level["high"],
                             "trials": level["trials"]}
        complete = [r["rate"] for r in rates.values() if r["rate"] is not None]
        basin_summary, basins[name] = basin(robot, (0, 1), sizes["grid"], sizes["t_final"], controller=spec,
                                            progress=progress, scheduler=scheduler, out_dir=folder, fresh=fresh)
        summary["controllers"][name] = {
            **metrics, "robustness": rates,
            "robustness_score": float(np.mean(complete)) if len(complete) == len(rates) else None,
            "reach": basin_summary["success_fraction"],
            "describe": controller.describe() if hasattr(controller, "describe") else {},
        }
        summary["interrupted"] |= bool(rob["interrupted"] or basin_summary["interrupted"])
        if summary["interrupted"]:
            break
    summary["versus_vcl"] = _versus(summary["controllers"])
    return summary, trajectories, basins


def folder_name(name):
    return "".join(ch if ch.isalnum() or ch in "-_" else "_" for ch in name.rsplit("/", 1)[-1])


def _versus(rows):
    """Each controller's time to balance and effort as a ratio of vcl's (when both balanced)."""
    ref = rows.get("vcl")
    if not ref or not ref["success"]:
        return {}
    out = {}
    for name, row in rows.items():
        if name == "vcl" or not row["success"]:
            continue
        out[name] = {"t_balanced": row["t_balanced"] / ref["t_balanced"] if ref["t_balanced"] else None,
                     "int_tau2": row["int_tau2"] / ref["int_tau2"], "work": row["work"] / ref["work"]}
    return out
