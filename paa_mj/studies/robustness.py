"""Robustness: the success rate of a controller against model error, noise, limits, delay, pushes and starts.

Each factor has levels (the first is the nominal case), all (factor, level,
run) rollouts in one study (:func:`~paa_mj.studies.runner.run_study`). A level
whose runs differ from one another (random starts, or a factor that draws
random numbers: noise, torque noise, pushes, perturbed starts) runs ``trials``
times and its rate has a 95 % Wilson interval; a deterministic level (the kip
from (65) under model error, delay or a torque limit, or any factor at level 0)
is one run, without an interval: repeating it would repeat one number. The
draws of a run depend on (seed, factor, run) alone, the same whatever other
factors run beside it and shared by the factor's levels. Success is the
task's (:attr:`~paa_mj.task.Task.success_definition`): the true state inside
region (68) over the last second, without divergence, whatever the controller
says of itself. Every scale a factor is a fraction of comes from the study's own
task and robot, and is checked to be physical before anything runs.

Factors (:data:`FACTORS`):

- ``model_error``: the controller believes masses x (1 + e) and lengths x (1 - e)
  while MuJoCo simulates the true robot [%];
- ``noise``: Gaussian measurement noise on q [rad] and qd [rad/s];
- ``torque_noise``: Gaussian noise on each applied torque, as a fraction of the
  nominal peak torque of the controller's run from the task's start (the kip from (65));
- ``torque_limit``: saturation at a fraction of that peak;
- ``delay``: control delay [ms];
- ``pushes``: three Gaussian pulses of torque on the hands (joint 1) at random
  times during the first 10 s, width 0.1 s, peak a fraction of b1 (the gravity
  torque scale of the robot) with random sign;
- ``initial_state``: the start perturbed uniformly by +-level on every angle
  [rad] and speed [rad/s].

Starts: ``random`` (angles uniform over a full turn, speeds in +-1 rad/s) or
``hanging`` (the task's start: the kip from (65)).
"""
from __future__ import annotations

import math

import numpy as np

from ..control.registry import ControllerSpec
from ..errors import PaaError
from ..provenance import text_sha256
from ..limits import check_memory, check_seed, check_steps, physical_torque_scale
from ..model.robot import Robot
from ..sim.batch import kip_peak_torques
from ..task import Task, as_task
from .runner import CHUNK, RolloutSet, applied_limit, engine_definition, peak_torques, run_study
from .settings import ROBUSTNESS_DEFAULT_FACTORS as DEFAULT_FACTORS, ROBUSTNESS_FACTORS as FACTORS, STARTS
from .store import ChunkStore, runs_done, study_key

#: The largest controller model error tested [%].
MAX_MODEL_ERROR = 90.0
#: Factors that draw random numbers at levels above 0 (the others are deterministic from a fixed start).
RANDOM_FACTORS = ("noise", "torque_noise", "pushes", "initial_state")
PUSHES_PER_RUN, PUSH_WIDTH, PUSH_WINDOW = 3, 0.1, (1.0, 10.0)
MAX_TRIALS = 100_000
#: A stable number per factor: with the trial, it keys the factor's random draws.
FACTOR_CODES = {name: code for code, name in enumerate(FACTORS, start=1)}


def wilson_interval(successes, trials, z=1.959963984540054):
    """The 95 % Wilson score interval (low, high) of a success rate k / n, with low <= k / n <= high exactly.

    For n = 0 the interval is (0, 1). Rounding never puts a bound on the wrong side
    of the rate: at k = 0 the low bound is 0 and at k = n the high bound is 1.
    """
    if trials == 0:
        return 0.0, 1.0
    p = successes / trials
    denom = 1 + z * z / trials
    centre = (p + z * z / (2 * trials)) / denom
    half = z * math.sqrt(p * (1 - p) / trials + z * z / (4 * trials * trials)) / denom
    low = 0.0 if successes == 0 else min(p, max(0.0, centre - half))
    high = 1.0 if successes == trials else max(p, min(1.0, centre + half))
    return low, high


def is_random(factor, level, start) -> bool:
    """Whether the runs of a (factor, level) differ from one another: random starts, or draws of the factor's own.

    A deterministic setting (the kip from (65) under model error, delay or a torque
    limit, or any factor at level 0) is one run, whatever the number of trials.
    """
    return start == "random" or (factor in RANDOM_FACTORS and level > 0)


def rate_entry(successes, runs, random) -> dict:
    """A success rate as reported in every JSON: a Wilson interval over independent draws only."""
    low, high = wilson_interval(successes, runs) if random and runs else (None, None)
    return {"success_rate": successes / runs if runs else None, "low": low, "high": high, "trials": int(runs),
            "random": bool(random)}


def initial_states(trials, task: Task, seed=0, start="random"):
    """The trials' initial states: random over a full turn (speeds +-1 rad/s), or the task's start for every
    trial ((65) for the gymnast's kip)."""
    n_links = task.n_links
    if start == "hanging":
        return np.tile(task.start, (trials, 1))
    rng = np.random.default_rng(seed)
    x0 = np.empty((trials, 2 * n_links))
    x0[:, :n_links] = rng.uniform(-np.pi, np.pi, (trials, n_links))
    x0[:, n_links:] = rng.uniform(-1.0, 1.0, (trials, n_links))
    return x0


def _pushes(rng, level, b1, n_links=3):
    times = rng.uniform(*PUSH_WINDOW, PUSHES_PER_RUN)
    signs = rng.choice([-1.0, 1.0], PUSHES_PER_RUN)
    out = np.zeros((PUSHES_PER_RUN, 2 + n_links))
    out[:, 0], out[:, 1], out[:, 2] = times, PUSH_WIDTH, signs * level * b1
    return out


def nominal_peak(robot: Robot, spec: ControllerSpec, torque_limit=None, t_final=None) -> float:
    """The largest torque of the controller's run from its task's start (the kip from (65)): the scale of the
    torque factors [N m], checked to be physical (:func:`~paa_mj.limits.physical_torque_scale`)."""
    task = as_task(spec.task, robot)
    peak = float(np.max(kip_peak_torques(robot, spec.build(robot), task, torque_limit, t_final)))
    return physical_torque_scale(peak, robot, f"the peak torque of {spec.short_name}'s run from the {task.name}"
                                              " task's start (the scale of the torque_limit and torque_noise factors)",
                                 "give the scale with torque_scale (--torque-scale) or drop those factors")


#: The largest torque scale given for the torque factors [N m] (as the largest torque limit anywhere).
MAX_TORQUE_SCALE = 1e12


def delay_steps(level_ms, dt) -> int:
    """The steps of ``dt`` [s] a control delay of ``level_ms`` [ms] holds a torque for: the nearest, halves up."""
    return int(math.floor(level_ms * 1e-3 / dt + 0.5))


def _chosen_levels(factors, levels, model_error) -> dict:
    """The factors and their levels, checked (one-line errors)."""
    factors = [f for f in factors if f]
    if not factors:
        raise PaaError(f"no robustness factor given: use some of {', '.join(FACTORS)}")
    unknown = [f for f in factors if f not in FACTORS]
    if unknown:
        raise PaaError(f"unknown robustness factor(s) {unknown}: use {', '.join(FACTORS)}")
    chosen = {name: dict(FACTORS[name]) for name in factors}
    levels = dict(levels or {})
    if model_error is not None:
        levels["model_error"] = model_error
    for name, values in levels.items():
        if name not in chosen:
            raise PaaError(f"levels given for {name}, which is not among the factors {', '.join(chosen)}")
        values = [float(v) for v in values]
        if not values or any(not (math.isfinite(v) and v >= 0) for v in values):
            raise PaaError(f"levels of {name} must be finite numbers >= 0, got {values}")
        if name == "model_error" and any(v > MAX_MODEL_ERROR for v in values):
            raise PaaError(f"--model-error percentages must lie in [0, {MAX_MODEL_ERROR:g}], got {values}")
        chosen[name]["levels"] = values
    return chosen


def believed_params(params, percent):
    """The parameters a controller believes in at a model error of ``percent`` [%]: masses x (1 + e), lengths
    x (1 - e), e = percent / 100."""
    e = percent / 100
    return params.scaled(1 + e, 1 - e)


def check_model_error(robot: Robot, percents, lower: str):
    """Refuse, before any run, model-error levels ``percents`` [%] whose believed model (:func:`believed_params`)
    lies outside the plausible parameters of :class:`~paa_mj.model.params.RobotParams` (a robot made at the edge of
    that range, a 1e6-kg chain): one line naming the level and ``lower``, what to change."""
    for percent in sorted(set(float(p) for p in percents), reverse=True):
        try:
            believed_params(robot.params, percent)
        except PaaError as err:
            raise PaaError(f"a model error of {percent:g} % makes the controller's model non-physical:"
                           f" {str(err).removeprefix('non-physical parameters: ')}; {lower}") from None


def _rollouts(robot, spec, task, chosen, runs, base, base_limit, peak, seed):
    """Every (factor, level, run) rollout, and which (factor, level) each is."""
    links = robot.params.n_links
    quiet = ControllerSpec(spec.name, spec.gains, spec.believed, check=False, options=spec.options, task=task)
    dt = robot.model.opt.timestep
    x0, specs, limit, noise, tau_noise, delay, pushes, index, noise_ids = [], [], [], [], [], [], [], [], []
    for factor, fspec in chosen.items():
        code = FACTOR_CODES[factor]
        for level_i, level in enumerate(fspec["levels"]):
            for trial in range(runs[factor, level_i]):
                # The draws of a trial depend on (seed, factor, trial) alone: the same whatever other factors
                # run beside it, and shared by the levels of the factor (common random numbers).
                rng = np.random.default_rng([seed, code, trial])
                x_start = base[trial].copy()
                if factor == "initial_state" and level > 0:
                    x_start += rng.uniform(-level, level, 2 * links)
                x0.append(x_start)
                specs.append(ControllerSpec(spec.name, spec.gains, believed_params(robot.params, level), check=False,
                                            options=spec.options, task=task)
                             if factor == "model_error" and level else quiet)
                limit.append(np.minimum(base_limit, level * peak if factor == "torque_limit" else math.inf))
                noise.append([level, level] if factor == "noise" else [0.0, 0.0])
                tau_noise.append(level * peak if factor == "torque_noise" else 0.0)
                delay.append(delay_steps(level, dt) if factor == "delay" else 0)
                pushes.append(_pushes(rng, level, robot.analytic.gravity_constants[0], links)
                              if factor == "pushes" and level > 0 else np.zeros((PUSHES_PER_RUN, 2 + links)))
                index.append(f"{factor}:{level_i}")
                noise_ids.append(code << 32 | trial)
    rollouts = RolloutSet(np.array(x0), specs, task, torque_limit=np.array(limit), noise_std=np.array(noise),
                          torque_noise=np.array(tau_noise), delay_steps=np.array(delay),
                          pushes=np.array(pushes) if "pushes" in chosen else None, noise_ids=np.array(noise_ids))
    return rollouts, np.array(index)


def robustness(robot: Robot, trials=64, t_final=None, seed=0, controller: ControllerSpec | str = "vcl",
               factors=DEFAULT_FACTORS, levels=None, start="random", *, task: Task | str | None = None,
               progress=False, scheduler="inline", out_dir=None, fresh=False, model_error=None, chunk=CHUNK,
               torque_limit=None, torque_scale=None, engine="mujoco", device=None):
    """Success rate against each factor; returns (summary dict, arrays dict).

    Parameters
    ----------
    t_final : float, optional
        Each run's duration [s]; default the task's horizon.
    factors : sequence of names of :data:`FACTORS`
    levels : dict, optional
        Levels to use instead of a factor's defaults (``model_error`` also takes ``model_error=``).
    start : "random" or "hanging"
    task : Task or str, optional
        What the controller aims at and what success means (a controller given by name is built for it; a
        ControllerSpec built for another is refused); default the folded task.
    torque_limit : float or (n - 1,), optional
        A saturation [N m] for every rollout (the torque_limit factor goes below it).
    torque_scale : float, optional
        The torque [N m] the ``torque_limit`` and ``torque_noise`` levels are fractions of
        (default: the peak torque of the controller's own run from the task's start); a leaderboard gives
        every controller the same scale, so that each meets the same disturbance.
    engine, device : optional
        MuJoCo on the CPU (default) or MuJoCo Warp (:func:`~paa_mj.sim.batch.simulate_batch`); the torque scale is
        always MuJoCo's run.
    """
    task = as_task(task, robot)
    t_final = task.horizon if t_final is None else t_final
    spec = ControllerSpec(controller, task=task) if isinstance(controller, str) else controller
    if spec.task is None:
        spec = spec.for_task(task)
    if not (isinstance(trials, (int, np.integer)) and 1 <= trials <= MAX_TRIALS):
        raise PaaError(f"--trials must be an integer in [1, {MAX_TRIALS}], got {trials}")
    check_seed(seed, "--seed")
    if start not in STARTS:
        raise PaaError(f"--start must be one of {', '.join(STARTS)}, got {start!r}")
    chosen = _chosen_levels(factors, levels, model_error)
    if "model_error" in chosen:
        check_model_error(robot, chosen["model_error"]["levels"],
                          "lower --model-error, or leave model_error out of --factors")
    runs = {(factor, level_i): trials if is_random(factor, level, start) else 1
            for factor, fspec in chosen.items() for level_i, level in enumerate(fspec["levels"])}
    total = sum(runs.values())
    check_memory(total * 1000.0, "robustness rollouts", "--trials or the levels")
    if scheduler in ("inline", "local"):
        check_steps(total * t_final / float(robot.model.opt.timestep), f"{total} rollouts of {t_final:g} s",
                    "--trials, the levels or --t-final", links=robot.params.n_links, runs=total)
    spec.build(robot)  # checks the gains, and that it is built for this task (one line), before any work
    links = robot.params.n_links
    base_limit = np.broadcast_to(np.inf if torque_limit is None else np.asarray(torque_limit, float), (links - 1,))
    if torque_scale is not None:
        if not (math.isfinite(torque_scale) and 0 < torque_scale <= MAX_TORQUE_SCALE):
            raise PaaError(f"the torque scale must lie in (0, {MAX_TORQUE_SCALE:g}] N m, got {torque_scale}")
        physical_torque_scale(torque_scale, robot, "the torque scale given (--torque-scale)", "give a larger one")
    peak = None
    if {"torque_limit", "torque_noise"} & set(chosen):
        peak = float(torque_scale) if torque_scale is not None else nominal_peak(robot, spec, base_limit, t_final)
    levels = [v for v in chosen.get("torque_limit", {}).get("levels", ()) if math.isfinite(v)]
    saturation = float(np.min(robot.capped_torque_limits(base_limit)))  # --torque-limit and the actuator ranges
    if levels and peak is not None and max(levels) * peak > saturation:
        raise PaaError(f"the torque_limit levels reach {max(levels) * peak:g} N m (fractions of the torque scale"
                       f" {peak:g} N m), above the saturation of every run at {saturation:g} N m: they would be"
                       " that saturation, not their level; lower --torque-scale or raise --torque-limit")
    rollouts, index = _rollouts(robot, spec, task, chosen, runs, initial_states(trials, task, seed, start),
                                base_limit, peak, seed)
    key = study_key({"study": "robustness", "robot": robot.xml, "t_final": t_final, "seed": seed, "chunk": chunk,
                     **rollouts.definition(), **engine_definition(engine)})
    result = run_study(robot, rollouts, t_final, seed=seed, scheduler=scheduler, chunk=chunk,
                       store=ChunkStore(out_dir, key, fresh, study="robustness"), progress=progress,
                       desc="robustness", engine=engine, device=device)
    summary = _summary(robot, spec, task, result, index, chosen, start, trials, t_final, seed, base_limit, peak,
                       torque_scale)
    summary.update(engine_definition(engine))
    arrays = {"x0": rollouts.x0, "success": result.success, "diverged": result.diverged,
              "switch_time": result.switch_time, "final_state": result.final_state, "max_abs_tau": result.max_abs_tau,
              "completed": result.meta["completed"]}
    return summary, arrays


def _summary(robot, spec, task, result, index, chosen, start, trials, t_final, seed, base_limit, peak,
             torque_scale) -> dict:
    completed = result.meta["completed"]
    success = result.success
    summary = {"robot": robot.name, "robot_sha256": text_sha256(robot.xml), "controller": spec.short_name,
               "trials": trials, "t_final": t_final, "seed": seed,
               "torque_limit": applied_limit(robot, base_limit), "start": start, **task.describe(),
               **runs_done(completed),
               "success": float(np.mean(success[completed])) if completed.any() else None,
               "intervals": "95 % Wilson intervals over independent draws only (random: true); a deterministic"
                            " setting is one run (random: false) and has none",
               "max_abs_tau": peak_torques(result.max_abs_tau, completed),
               "torque_scale": peak, "torque_scale_is": None if peak is None else
               "given" if torque_scale is not None else "the peak torque of the controller's run from the task's start",
               "interrupted": result.interrupted, "factors": {}}
    for factor, fspec in chosen.items():
        rates = []
        for level_i, level in enumerate(fspec["levels"]):
            planned = index == f"{factor}:{level_i}"
            rows = np.flatnonzero(planned & completed)
            entry = rate_entry(int(np.sum(success[rows])), len(rows), is_random(factor, level, start))
            rates.append({"level": None if not math.isfinite(level) else float(level), **entry,
                          "not_run": int(np.count_nonzero(planned) - len(rows)),
                          "diverged_rate": float(np.mean(result.diverged[rows])) if len(rows) else None})
            if factor == "delay":  # the delay the engines held: whole time steps
                rates[-1]["held_ms"] = delay_steps(level, float(robot.model.opt.timestep)) \
                    * float(robot.model.opt.timestep) * 1e3
        summary["factors"][factor] = {"label": fspec["label"], "levels": rates}
    return summary
