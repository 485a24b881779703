"""A leaderboard of kip controllers, scored the way the RealAIGym benchmark scores double-pendulum swing-ups.

Every controller kips the same robot from the task's start ((65)) in MuJoCo (RK4, 1 ms)
under the same torque limit (by default the peak torques of the paper's controller ``vcl``
there), and is scored on

- performance (:data:`METRICS`): when it first enters region (68) (``t_region``),
  from when it stays within 1e-3 of UDD (``t_balanced``), peak torques, the
  integral of :math:`|\\tau|^2` dt, the work integral of :math:`|\\tau \\cdot \\dot q_a|` dt, the RMS of the
  torque change per second (smoothness) and the peak joint speed; success is
  the package's one definition, and a failure says why;
- robustness: the success rate under each disturbance
  (:mod:`paa_mj.studies.robustness`). Random disturbances (:data:`FACTORS`:
  measurement noise, torque noise, pushes during the swing, a perturbed start)
  are drawn ``trials`` times and their rate has a 95 % Wilson interval; the
  deterministic ones (:data:`SWEEPS`: controller model error, control delay)
  give one run per level, so they are swept over levels, as RealAIGym sweeps
  model parameters and delay, and their rate is the share of levels that
  succeed (no interval: nothing is drawn). The robustness score is the mean of
  the rates, as RealAIGym's;
- reach: the share of a (q1, q2) grid of starts from which it balances
  (:mod:`paa_mj.studies.basin`), which answers "from where?".

Every run of every part, reach included, is saturated at the same torque limit,
torque noise is a fraction of that same limit for every controller (so that
each meets the same disturbance), and success has one meaning throughout
(the task's, :attr:`~paa_mj.task.Task.success_definition`).

RealAIGym also folds the performance metrics into one score with normalisers
fixed for the double pendulum; none exist for the gymnast, so the leaderboard
shows the metrics themselves, and how each controller's time and effort compare
with ``vcl``'s.
"""
from __future__ import annotations

import numpy as np

from ..control.catalog import HANDS_OVER, PLANNERS, takes_run_limit
from ..control.registry import ControllerSpec
from ..errors import PaaError
from ..limits import physical_torque_scale
from ..progress import stage
from ..provenance import text_sha256
from ..model.robot import Robot
from ..sim.batch import kip_peak_torques, simulate_batch
from ..sim.integrators import integrator_name
from ..sim.compiled.step import STATUS_TEXT
from ..sim.verdict import diverged_words, outcome_words
from ..task import Task, as_task
from .basin import basin
from .robustness import MAX_TRIALS, check_model_error, robustness
from .runner import CHUNK
from .store import runs_done
from .settings import (BASIN_MAX_GRID, COMPARE_CONTROLLERS as DEFAULT_CONTROLLERS, COMPARE_FACTORS as FACTORS,
                       COMPARE_SIZES as SIZES, COMPARE_SWEEPS as SWEEPS, FACTOR_ORDER, factor_label)

METRICS = ("t_region", "t_balanced", "max_tau", "int_tau2", "work", "smoothness", "max_speed", "success")


def _spec(name, limit, task):
    """The spec of ``name`` run under the board's torque ``limit``, told it where it takes it
    (:func:`~paa_mj.control.catalog.takes_run_limit`)."""
    options = (("limit", tuple(limit)),) if takes_run_limit(name) else ()
    return ControllerSpec(name, options=options, task=task)


def _why(result, i, t_final, task: Task, controller):
    """Why run ``i`` of ``result`` did not succeed: the words of every command (:mod:`paa_mj.sim.verdict`)."""
    status = diverged_words(float(result.t_end[i]), STATUS_TEXT[int(result.status[i])]) if result.diverged[i] else "ok"
    return outcome_words(status=status, success=False, task=task, t_final=t_final,
                         switch_time=_none(result.switch_time[i]), t_region=_none(result.t_region[i]),
                         hands_over=getattr(controller, "name", controller) in HANDS_OVER,
                         final_state=result.final_state[i], remedies=False)


def _none(value):
    return None if value is None or not np.isfinite(value) else float(value)


def sweep_levels(factor, quick=False):
    """The levels of a swept factor at the leaderboard's size."""
    levels = SWEEPS[factor]
    return levels[1::2] if quick else levels


def performance(robot: Robot, controller, limit, task: Task, t_final=None):
    """The metrics of one run from the task's start (the kip from (65)), and its trajectory (t, q, qd, tau, mode)."""
    t_final = task.horizon if t_final is None else t_final
    result = simulate_batch(robot, task.start[None], t_final, task=task, controller=controller, torque_limit=limit,
                            retire=False, record=True, sample_dt=0.01)  # raises on Ctrl-C: a truncated kip is no kip
    n = int(result.trajectories["count"][0])
    trajectory = {k: result.trajectories[k][0, :n] for k in ("t", "q", "qd", "tau", "mode")}
    success = bool(result.success[0])
    metrics = {"t_region": _none(result.t_region[0]), "t_balanced": _none(result.t_balanced[0]),
               "max_tau": result.max_abs_tau[0].tolist(), "int_tau2": float(result.int_tau2[0]),
               "work": float(result.work[0]), "smoothness": float(result.smoothness[0]),
               "max_speed": float(result.max_speed[0]), "success": success, "balanced": bool(result.balanced[0]),
               "why": None if success else _why(result, 0, t_final, task, controller)}
    return metrics, trajectory


def _sizes(quick, trials, t_final, grid, task):
    sizes = dict(SIZES["quick" if quick else "full"])
    sizes["t_final"] = task.horizon
    for key, value in (("trials", trials), ("t_final", t_final), ("grid", grid)):
        if value is not None:
            sizes[key] = value
    if not (isinstance(sizes["grid"], (int, np.integer)) and 2 <= sizes["grid"] <= BASIN_MAX_GRID):
        raise PaaError(f"--grid must be an integer in [2, {BASIN_MAX_GRID}], got {sizes['grid']}")
    if not (isinstance(sizes["trials"], (int, np.integer)) and 1 <= sizes["trials"] <= MAX_TRIALS):
        raise PaaError(f"--trials must be an integer in [1, {MAX_TRIALS}], got {sizes['trials']}")
    return sizes


def _names(controllers):
    names = list(dict.fromkeys(controllers))
    if not names:
        raise PaaError("--controllers needs at least one controller")
    by_folder = {}
    for name in names:
        ControllerSpec(name)  # an unknown name is refused before any run (vcl's kip sets the torque limit)
        other = by_folder.setdefault(folder_name(name), name)
        if other != name:
            raise PaaError(f"controllers {other} and {name} would share the name {folder_name(name)} in the results:"
                           " rename one file or class")
    return names


def _limit(robot, task, torque_limit):
    """The leaderboard's torque limit [N m]: the one given, or the peak torques of vcl's run from the task's start,
    checked to be physical."""
    motors = robot.params.n_motors
    if torque_limit is not None:
        limit = np.full(motors, float(torque_limit))
    else:
        limit = kip_peak_torques(robot, ControllerSpec("vcl", task=task), task)
        physical_torque_scale(np.max(limit), robot, f"the peak torque of vcl's run from the {task.name} task's start"
                                                    " (the leaderboard's default torque limit)", "give --torque-limit")
    limit = robot.capped_torque_limits(limit)
    if not np.all(np.isfinite(limit)):
        raise PaaError("the leaderboard needs a finite torque limit: give --torque-limit (the default, vcl's peak"
                       " torques from the task's start, is not finite here)")
    return limit


def _specs(robot, names, limit, task, progress):
    """Every controller's recipe, each built once (gains, files, solves): the refusals of all of them in one line."""
    specs, refused = {}, []
    for name in names:
        specs[name] = _spec(name, limit, task)
        if name in PLANNERS:
            stage(f"compare: planning the {name} kip (collocation, IPOPT; cached after the first solve)", progress)
        try:
            specs[name].build(robot)
        except PaaError as err:
            refused.append(f"{name}: {err}")
    if refused:
        raise PaaError(f"{len(refused)} of {len(names)} controllers refused: " + "; ".join(refused))
    return specs


def compare(robot: Robot, controllers=DEFAULT_CONTROLLERS, torque_limit=None, trials=None, quick=False,
            t_final=None, seed=0, *, task: Task | str | None = None, scheduler="inline", out_dir=None, fresh=False,
            progress=False, grid=None, chunk=CHUNK):
    """The leaderboard; returns (summary, trajectories by controller, basins by controller).

    Parameters
    ----------
    controllers : sequence of str
        Built-in names or ``file.py:ClassName``.
    torque_limit : float, optional
        The same saturation [N m] for every controller (default: vcl's peak torques from the task's start).
    task : Task or str, optional
        What every controller aims at and is judged by; default the folded task.
    """
    task = as_task(task, robot)
    sizes = _sizes(quick, trials, t_final, grid, task)
    names = _names(controllers)
    check_model_error(robot, sweep_levels("model_error", quick), "the leaderboard's model-error sweep cannot run on"
                      " this robot: use paa-mj robustness with --factors that leave model_error out")
    if torque_limit is None:
        stage("compare: vcl's kip from the task's start, whose peak torques are the leaderboard's torque limit",
              progress)
    limit = _limit(robot, task, torque_limit)
    specs = _specs(robot, names, limit, task, progress)
    sweeps = {factor: sweep_levels(factor, quick) for factor in SWEEPS}
    summary = {"robot": robot.name, "robot_sha256": text_sha256(robot.xml), **task.describe(),
               "engine": f"MuJoCo, {integrator_name(robot.model)} at {robot.model.opt.timestep * 1e3:g} ms",
               "torque_limit": limit.tolist(),
               "t_final": sizes["t_final"], "trials": sizes["trials"], "grid": sizes["grid"], "seed": seed,
               "intervals": "95 % Wilson intervals over the independent draws of a random factor (random: true);"
                            " a swept deterministic factor's rate is the share of its levels that succeed, one run"
                            " each (random: false), without an interval",
               "torque_noise_scale": float(np.max(limit)),
               "factors": {k: {"label": factor_label(k, sweeps.get(k)), "random": k in FACTORS,
                               **({"level": FACTORS[k]} if k in FACTORS else {"levels": list(sweeps[k])})}
                           for k in FACTOR_ORDER},
               "interrupted": False, "controllers": {}}
    trajectories, basins = {}, {}
    for number, name in enumerate(names, start=1):
        stage(f"compare [{number}/{len(names)}] {name}: the kip from the task's start, then robustness and reach",
              progress)
        row, trajectories[name], basins[name], interrupted = _score(
            robot, task, specs[name], limit, sizes, sweeps, seed, scheduler, out_dir, fresh, progress, chunk)
        summary["controllers"][name] = row
        summary["interrupted"] |= interrupted
        if summary["interrupted"]:
            break
    rows = summary["controllers"]
    # a controller is run when all its runs are; one not reached (an interrupted leaderboard) has no row
    summary.update(runs_done([name in rows and rows[name]["not_run"] == 0 for name in names]))
    summary["controllers_not_run"] = [name for name in names if name not in rows]
    summary["success"] = {name: row["success"] for name, row in summary["controllers"].items()}
    summary["versus_vcl"] = _versus(summary["controllers"])
    return summary, trajectories, basins


def _score(robot, task, spec, limit, sizes, sweeps, seed, scheduler, out_dir, fresh, progress, chunk):
    """One controller's row: performance, robustness and reach; its trajectory and basin."""
    controller = spec.build(robot)
    metrics, trajectory = performance(robot, controller, limit, task, sizes["t_final"])
    folder = None if out_dir is None else f"{out_dir}/studies/{folder_name(spec.short_name)}"
    levels = {k: [v] for k, v in FACTORS.items()} | {k: list(v) for k, v in sweeps.items()}
    rob, _ = robustness(robot, trials=sizes["trials"], t_final=sizes["t_final"], seed=seed, controller=spec,
                        factors=list(FACTOR_ORDER), levels=levels, start="hanging", task=task, progress=progress,
                        scheduler=scheduler, out_dir=folder, fresh=fresh, torque_limit=limit, chunk=chunk,
                        torque_scale=float(np.max(limit)))
    rates = {factor: _factor_rate(rob["factors"][factor]["levels"], factor in sweeps) for factor in FACTOR_ORDER}
    complete = [r["rate"] for r in rates.values() if r["rate"] is not None]
    basin_summary, basin_arrays = basin(robot, (0, 1), sizes["grid"], sizes["t_final"], controller=spec, task=task,
                                        progress=progress, scheduler=scheduler, out_dir=folder, fresh=fresh,
                                        chunk=chunk, torque_limit=limit)
    peaks = [p for p in (metrics["max_tau"], rob["max_abs_tau"], basin_summary["max_abs_tau"]) if p is not None]
    description = controller.describe() if hasattr(controller, "describe") else {}
    row = {**metrics, "robustness": rates,
           "robustness_score": float(np.mean(complete)) if len(complete) == len(rates) else None,
           "reach": basin_summary["success"], "reach_runs": basin_summary["cells"],
           "not_run": rob["not_run"] + basin_summary["not_run"],
           "max_abs_tau": np.max(peaks, axis=0).tolist(), "plan": description.get("plan"), "describe": description}
    return row, trajectory, basin_arrays, bool(rob["interrupted"] or basin_summary["interrupted"])


def _factor_rate(levels, swept):
    """One factor's column: a random factor's rate over its draws, or a sweep's share of levels that succeed."""
    if not swept:
        level = levels[0]
        return {"rate": level["success_rate"], "low": level["low"], "high": level["high"], "trials": level["trials"],
                "random": level["random"]}
    done = [level for level in levels if level["success_rate"] is not None]
    if any(level["random"] for level in done):  # not a leaderboard setting: no share of levels to report
        raise PaaError("a swept factor must be deterministic")
    passed = sum(level["success_rate"] for level in done)
    return {"rate": passed / len(done) if len(done) == len(levels) else None, "low": None, "high": None,
            "trials": len(done), "random": False,
            "levels": {format(level["level"], "g"): bool(level["success_rate"]) for level in done}}


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
