"""One closed-loop rollout in MuJoCo, recorded: the engine of :mod:`paa_mj.sim.compiled.engine` with one state.

The controller reads the state every physics step and its torque is held over
the step (zero-order hold, also across the four stages of RK4). A compiled
controller runs entirely in compiled code; any other through its ``torque``.
The result is a :class:`~paa_mj.sim.trajectory.Trajectory`; the same inputs
through :func:`paa_mj.sim.batch.simulate_batch` give the same numbers, bit for bit.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ..control.base import balance_gain_of, controller_name
from ..errors import SimulationDiverged
from ..model.robot import Robot
from ..task import Task, as_task
from ..theory.linear import sampled_balance
from .compiled import engine
from .batch import NO_DISTURBANCES, Disturbances, _lyapunov, build_plan, controllers_for, outcome_arrays
from .inputs import check_initial_state, check_robot, sample_interval
from .integrators import integrator_name, mujoco_model_for
from .trajectory import Trajectory, seconds_or_none

__all__ = ["simulate_mujoco", "describe_controller", "trajectory_quantities", "divergence_reason"]


def describe_controller(controller) -> dict:
    describe = getattr(controller, "describe", None)
    return describe() if callable(describe) else {"controller": controller_name(controller)}


def trajectory_quantities(controller, robot: Robot, task: Task, q, qd):
    """E - E_r [J] (E_r the task's goal energy) and V of (34) (NaN without an energy controller) at the recorded
    states."""
    e_err = robot.analytic.energy(q, qd) - task.goal_energy(robot.analytic)
    return e_err, np.broadcast_to(_lyapunov(controller, robot.analytic, q, qd), e_err.shape).astype(float)


def simulate_mujoco(robot: Robot, controller="vcl", x0: ArrayLike | None = None, t_final: float | None = None, *,
                    task: Task | str | None = None, dt: float | None = None, integrator: str | None = None,
                    sample_dt: float = 0.01, torque_limit: ArrayLike | None = None,
                    disturbances: Disturbances | None = None, retire: bool = False, progress: bool = False,
                    stop_on_divergence: bool = True, partial: bool = False) -> Trajectory:
    """Run ``controller`` on the MuJoCo model for ``t_final`` seconds and record it.

    Parameters
    ----------
    robot : Robot
    controller : controller, name or ControllerSpec
        Reset before the run. Default: ``"vcl"`` with the robot's stored gains.
    x0 : array_like (2n,)
        Initial [q, qd] [rad, rad/s]; default the task's start (hanging at rest, (65) for the gymnast).
    t_final : float, optional
        Duration [s]; default the task's horizon.
    task : Task or str, optional
        What the run aims at and is judged by (:mod:`paa_mj.task`); default the paper's folded task.
    dt, integrator : float, str, optional
        Physics time step [s] and integrator (RK4, Euler, implicitfast, implicit);
        default: the model's own (RK4 at 1 ms for the named robots).
    sample_dt : float
        Recording interval [s] (a whole number of steps, at most ``t_final``).
    torque_limit : float or (n - 1,), optional
        Saturation [N m], capped by the model's actuator ranges.
    disturbances : Disturbances, optional
        Noise, delay, pushes and their seed (:class:`~paa_mj.sim.batch.Disturbances`, for one rollout).
    retire : bool
        Stop once the balance can no longer fail (as the batch engine does).
    partial : bool
        After Ctrl-C or SIGTERM, return the run recorded so far, ``meta["interrupted"]`` set (``paa-mj simulate``
        keeps it); by default the interruption is raised again, so that no caller takes a part for the run.

    Raises
    ------
    SimulationDiverged
        Non-finite state or torque, runaway speeds or a MuJoCo warning; the
        exception carries the trajectory recorded up to the last good state.
    KeyboardInterrupt
        Ctrl-C or SIGTERM, without ``partial``.
    """
    check_robot(robot)
    task = as_task(task, robot)
    links = robot.params.n_links
    x0 = check_initial_state(task.start if x0 is None else x0, links)
    t_final = task.horizon if t_final is None else t_final
    controllers = controllers_for(robot, controller, 1, task)
    model = mujoco_model_for(robot, dt, integrator)
    dt = float(model.opt.timestep)
    every = sample_interval(sample_dt, dt, t_final)
    plan = build_plan(robot, task, x0, t_final, controllers, dt=dt, integrator=integrator, torque_limit=torque_limit,
                      disturbances=_one_rollout(disturbances or NO_DISTURBANCES), every=every, retire=retire)
    outcome = engine.run(plan, controllers, nthread=1, progress=progress, desc=f"{robot.name} mujoco")
    traj, status, when = _trajectory(robot, task, model, plan, outcome, controllers, x0[0], t_final, every)
    if status in engine.DIVERGED:
        traj.meta["status"] = f"diverged at t = {when:.4f} s: {engine.STATUS_TEXT[status]}"
        if stop_on_divergence:
            raise SimulationDiverged(f"simulation {traj.outcome()}", traj)
    elif status == engine.RETIRED:
        traj.meta["status"] = f"balanced for good at t = {when:.4f} s (stopped early)"
    elif status == engine.STOPPED:
        traj.meta["status"] = f"interrupted at t = {when:.4f} s"
        traj.meta["interrupted"] = True
        if not partial:
            raise KeyboardInterrupt
    else:
        traj.meta["status"] = "ok"
    return traj


def _trajectory(robot, task, model, plan, outcome, controllers, x0, t_final, every):
    """The one rollout's :class:`Trajectory` from the engine's outcome (its samples, quantities and what the engine
    judged of it), with the engine's status code and the time the run ended [s]."""
    dt = float(model.opt.timestep)
    out = outcome_arrays(plan, outcome, controllers, [robot.analytic])
    count = int(outcome.samples["count"][0])
    s = {k: v[0, :count] for k, v in outcome.samples.items() if k != "count"}
    e_err, V = trajectory_quantities(controllers[0], robot, task, s["q"], s["qd"])
    switch = out["switch_time"][0]
    status = int(out["status"][0])
    traj = Trajectory(s["t"].copy(), s["q"].copy(), s["qd"].copy(), s["tau"].copy(), e_err, V, s["mode"].copy(),
                      None if np.isnan(switch) else float(switch), task=task,
                      meta={"robot": robot.name, "engine": "mujoco", "integrator": integrator_name(model), "dt": dt,
                            "sample_dt": every * dt, "x0": x0.tolist(), "t_final": float(t_final),
                            **describe_controller(controllers[0]), "torque_limit": _limit_meta(plan),
                            **robot.params.actuation_meta()},
                      robot_xml=robot.xml)
    traj.meta["success"] = bool(out["success"][0])
    traj.meta["t_region"] = seconds_or_none(out["t_region"][0])
    gain = balance_gain_of(controllers[0])
    if gain is not None:
        traj.meta["balance_sampling"] = sampled_balance(robot.analytic, gain, dt, task)
    # the engine's peak over every step, not only over the recorded samples
    traj.meta["max_abs_tau"] = out["max_abs_tau"][0].tolist()
    return traj, status, float(out["t_end"][0])


def _one_rollout(disturbances: Disturbances) -> Disturbances:
    """The disturbances of one rollout as the batch engine takes them: each per-rollout value as one row."""
    row = lambda v: None if v is None else np.asarray(v)[None]  # noqa: E731
    return Disturbances(row(disturbances.noise_std), row(disturbances.torque_noise), row(disturbances.delay_steps),
                        row(disturbances.pushes), disturbances.seed, disturbances.rollout_ids)


def _limit_meta(plan):
    limits = plan.settings.limits[0]
    return None if np.all(np.isinf(limits)) else limits.tolist()


def divergence_reason(data):
    """Why ``data`` has left the finite world (None if it has not): non-finite state, runaway speeds, MuJoCo warnings."""
    status = engine.check_state(data.qpos, data.qvel, data.warning.number)
    return None if status == engine.RUNNING else engine.STATUS_TEXT[status]
