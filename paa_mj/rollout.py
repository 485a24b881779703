"""Closed-loop rollouts: in MuJoCo, and of the analytic model (1) with ``solve_ivp``.

MuJoCo rollout: every physics step the controller reads ``qpos``/``qvel`` and
writes ``ctrl``, which is held over the step (zero-order hold, also across the
four stages of RK4). The analytic reference integrates (1) with the torque
evaluated continuously inside the vector field (rtol 1e-10), and finds the
switch (68) as an event.
"""
from __future__ import annotations

import math

import mujoco
import numpy as np
from scipy.integrate import solve_ivp
from tqdm.auto import tqdm

from .controllers import EnergyVCLController, LQRController, SwitchingController, switch_margin
from .errors import PaaError, SimulationDiverged
from .model import Robot
from .trajectory import Trajectory

#: Initial condition (65): hanging straight down, at rest.
X0_HANGING = np.array([-np.pi, 0.0, 0.0, 0.0, 0.0, 0.0])
INTEGRATORS = {"RK4": mujoco.mjtIntegrator.mjINT_RK4, "Euler": mujoco.mjtIntegrator.mjINT_EULER,
               "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
               "implicit": mujoco.mjtIntegrator.mjINT_IMPLICIT}
#: Speeds beyond this [rad/s] mean the simulation has blown up.
MAX_SPEED = 1e4


def validate_run(x0, t_final, dt=None, sample_dt=None):
    """Check the common inputs of a rollout; return x0 as an array."""
    x0 = np.asarray(x0, dtype=float).reshape(-1)
    if x0.shape != (6,):
        raise PaaError(f"initial state needs 6 numbers (q1 q2 q3 d1 d2 d3), got {x0.size}")
    if not np.all(np.isfinite(x0)):
        raise PaaError(f"initial state must be finite, got {x0.tolist()}")
    for name, value in (("final time", t_final), ("time step", dt), ("sample interval", sample_dt)):
        if value is not None and not (np.isfinite(value) and value > 0):
            raise PaaError(f"{name} must be a positive number, got {value}")
    return x0


def record_quantities(controller, robot: Robot, q, qd):
    """E - E_r and V (34) of the swing-up controller at the recorded states."""
    swing = controller.swing_up if isinstance(controller, SwitchingController) else controller
    e_err = robot.analytic.energy(q, qd) - robot.analytic.E_r
    V = swing.lyapunov(q, qd) if isinstance(swing, EnergyVCLController) else np.full(len(q), np.nan)
    return e_err, V


def _mode_of(controller):
    return int(np.asarray(getattr(controller, "mode", 0)))


def mujoco_model_for(robot: Robot, dt=None, integrator=None) -> mujoco.MjModel:
    """A copy of the robot's MjModel with the time step and integrator set."""
    model = robot.model.__copy__()
    if dt is not None:
        model.opt.timestep = dt
    if integrator is not None:
        if integrator not in INTEGRATORS:
            raise PaaError(f"unknown integrator {integrator!r}: use one of {', '.join(INTEGRATORS)}")
        model.opt.integrator = INTEGRATORS[integrator]
    return model


def simulate_mujoco(robot: Robot, controller, x0=X0_HANGING, t_final=30.0, dt=None, integrator=None,
                    sample_dt=0.01, progress=False, stop_on_divergence=True,
                    stop_after_switch=None, compiled=True) -> Trajectory:
    """Run ``controller`` on the MuJoCo model for ``t_final`` seconds.

    Parameters
    ----------
    robot : Robot
    controller : Controller
        Maps (q, qd) to tau; reset before the run.
    x0 : array_like (6,)
        Initial [q1, q2, q3, d1, d2, d3] [rad, rad/s]; default (65).
    t_final : float
        Duration [s].
    dt, integrator : float, str, optional
        Physics time step [s] and integrator (RK4, Euler, implicitfast, implicit);
        default: the model's own (RK4 at 1 ms for the named robots).
    sample_dt : float
        Recording interval [s] (rounded to a whole number of steps).
    stop_after_switch : float, optional
        End the run this long [s] after the switch to LQR (studies that only
        need the switch time and whether the balance holds).
    compiled : bool
        Evaluate a :class:`SwitchingController` with the compiled kernel of
        :mod:`paa_mj.fast` (same results to rounding, several times faster).
        Other controllers always run through their ``torque`` method.

    Raises
    ------
    SimulationDiverged
        Non-finite state or torque, runaway speeds or a MuJoCo warning; the
        exception carries the trajectory recorded up to then.
    """
    x0 = validate_run(x0, t_final, dt, sample_dt)
    model = mujoco_model_for(robot, dt, integrator)
    dt = model.opt.timestep
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:] = x0[:3], x0[3:]
    mujoco.mj_forward(model, data)
    controller.reset()
    control = _control_function(controller, data, compiled)
    n_steps = int(round(t_final / dt))
    every = max(1, int(round(sample_dt / dt)))
    n_samples = n_steps // every + 1
    t = np.empty(n_samples)
    q, qd = np.empty((n_samples, 3)), np.empty((n_samples, 3))
    tau_rec, mode_rec = np.empty((n_samples, 2)), np.empty(n_samples, np.int8)
    qpos, qvel, ctrl = data.qpos, data.qvel, data.ctrl
    step_fn, switch_time, k, failure, mode = mujoco.mj_step, None, 0, None, 0
    bar = tqdm(total=n_steps, unit="step", unit_scale=True, disable=None if progress else True, leave=False,
               desc=f"{robot.name} mujoco")
    for step in range(n_steps + 1):
        mode = control()
        if mode == -1:
            failure = "the controller returned a non-finite torque (singular Lambda of (38)?)"
        elif mode == 1 and switch_time is None:
            switch_time = step * dt
        if step % every == 0 or failure:
            t[k], q[k], qd[k], tau_rec[k], mode_rec[k] = step * dt, qpos, qvel, ctrl, max(mode, 0)
            k += 1
            failure = failure or divergence_reason(data)
            if failure:
                break
            if progress and step:
                bar.update(every)
            if stop_after_switch is not None and switch_time is not None and step * dt >= switch_time + stop_after_switch:
                break
        if step == n_steps:
            break
        step_fn(model, data)
    bar.close()
    e_err, V = record_quantities(controller, robot, q[:k], qd[:k])
    integ = next(name for name, value in INTEGRATORS.items() if value == model.opt.integrator)
    traj = Trajectory(t[:k], q[:k], qd[:k], tau_rec[:k], e_err, V, mode_rec[:k], switch_time,
                      meta={"robot": robot.name, "engine": "mujoco", "integrator": integ, "dt": dt,
                            "x0": x0.tolist(), "t_final": t_final, **_controller_meta(controller)})
    if failure:
        when = float(t[k - 1])
        traj.meta["status"] = f"diverged at t = {when:.4f} s: {failure}"
        if stop_on_divergence:
            raise SimulationDiverged(f"simulation diverged at t = {when:.4f} s: {failure}", traj)
    else:
        traj.meta["status"] = "ok"
    return traj


def _control_function(controller, data, compiled):
    """A no-argument callable that writes ``data.ctrl`` and returns the mode (-1: non-finite torque)."""
    qpos, qvel, ctrl = data.qpos, data.qvel, data.ctrl
    standard = (type(controller) is SwitchingController and type(controller.swing_up) is EnergyVCLController
                and type(controller.balance) is LQRController)
    if compiled and standard:
        from .fast import control_step, kernel_constants

        consts, K = kernel_constants(controller)
        state = [0]

        def control():
            state[0] = mode = control_step(qpos, qvel, ctrl, consts, K, state[0])
            if mode >= 0:
                controller.mode = np.int8(mode)
            return mode

        return control

    def control():
        tau = controller.torque(qpos, qvel)
        ctrl[:] = tau
        if not (math.isfinite(tau[0]) and math.isfinite(tau[1])):
            return -1
        return _mode_of(controller)

    return control


def divergence_reason(data):
    """Why ``data`` has left the finite world (None if it has not): non-finite state, runaway speeds, MuJoCo warnings."""
    state_ok = np.all(np.isfinite(data.qpos)) and np.all(np.isfinite(data.qvel))
    if not state_ok:
        return "the state is not finite"
    if np.max(np.abs(data.qvel)) > MAX_SPEED:
        return f"joint speeds above {MAX_SPEED:g} rad/s"
    for w in (mujoco.mjtWarning.mjWARN_BADQACC, mujoco.mjtWarning.mjWARN_BADQPOS,
              mujoco.mjtWarning.mjWARN_BADQVEL, mujoco.mjtWarning.mjWARN_BADCTRL):
        if data.warning[w].number:
            return f"MuJoCo warning {mujoco.mjtWarning(w).name}"
    return None


def _controller_meta(controller):
    swing = controller.swing_up if isinstance(controller, SwitchingController) else controller
    meta = {"controller": type(controller).__name__}
    if isinstance(swing, EnergyVCLController):
        meta["gains"] = {"kD": swing.kD, "kP": swing.kP, "kV": swing.kV}
    if isinstance(controller, SwitchingController):
        meta["switch_enabled"] = controller.enabled
    limit = getattr(controller, "torque_limit", None)
    meta["torque_limit"] = limit
    return meta


def simulate_analytic(robot: Robot, controller: SwitchingController, x0=X0_HANGING, t_final=30.0,
                      sample_dt=0.01, rtol=1e-10, atol=1e-10, method="DOP853", progress=False) -> Trajectory:
    """Integrate (1) closed by ``controller`` with continuous-time control (no zero-order hold).

    The switch (68) is found as a terminal event of ``solve_ivp`` (to solver
    accuracy); integration then restarts under LQR (67).
    """
    x0 = validate_run(x0, t_final, None, sample_dt)
    if not isinstance(controller, SwitchingController):
        raise PaaError("the analytic rollout takes a SwitchingController")
    am = robot.analytic
    controller.reset()
    laws = [controller.swing_up, controller.balance]

    def field(law):
        def f(_t, x):
            q, qd = x[:3], x[3:]
            return np.concatenate([qd, am.acceleration(q, qd, law.torque(q, qd))])
        return f

    def entered(_t, x):
        return switch_margin(x[:3], x[3:])

    entered.terminal, entered.direction = True, -1
    t_eval = np.arange(0.0, t_final + 0.5 * sample_dt, sample_dt)
    t_eval = t_eval[t_eval <= t_final]
    ts, xs, modes = [], [], []
    t0, x, switch_time, phase = 0.0, x0, None, 0
    if controller.enabled and entered(0, x0) < 0:
        switch_time, phase = 0.0, 1
    bar = tqdm(total=t_final, unit="s", disable=None if progress else True, leave=False, desc=f"{robot.name} solve_ivp",
               bar_format="{l_bar}{bar}| {n:.1f}/{total:.1f} s")
    failure = None
    while True:
        grid = t_eval[(t_eval >= t0) & (t_eval <= t_final)]
        events = entered if (phase == 0 and controller.enabled) else None
        sol = solve_ivp(field(laws[phase]), (t0, t_final), x, method=method, rtol=rtol, atol=atol,
                        t_eval=grid, events=events)
        ts.append(sol.t)
        xs.append(sol.y.T)
        modes.append(np.full(len(sol.t), phase, np.int8))
        bar.update((sol.t[-1] if len(sol.t) else t0) - bar.n)
        if sol.status == -1:
            failure = sol.message
            break
        if sol.status == 1 and phase == 0:
            t0, x = float(sol.t_events[0][0]), sol.y_events[0][0]
            switch_time, phase = t0, 1
            continue
        break
    bar.close()
    t = np.concatenate(ts)
    X = np.concatenate(xs)
    mode = np.concatenate(modes)
    q, qd = X[:, :3], X[:, 3:]
    tau = np.where(mode[:, None] == 1, laws[1].torque(q, qd), laws[0].torque(q, qd))
    e_err, V = record_quantities(controller, robot, q, qd)
    traj = Trajectory(t, q, qd, tau, e_err, V, mode, switch_time,
                      meta={"robot": robot.name, "engine": "analytic", "integrator": f"solve_ivp {method}",
                            "dt": None, "rtol": rtol, "x0": x0.tolist(), "t_final": t_final,
                            **_controller_meta(controller)})
    if failure:
        when = float(t[-1]) if len(t) else 0.0
        traj.meta["status"] = f"diverged at t = {when:.4f} s: {failure}"
        raise SimulationDiverged(f"analytic integration failed at t = {when:.4f} s: {failure}", traj)
    traj.meta["status"] = "ok"
    return traj


def replay_torques_mujoco(robot: Robot, x0, torques, dt=None, integrator=None):
    """Feed a fixed torque sequence (one per step, zero-order hold) to MuJoCo; states after each step."""
    model = mujoco_model_for(robot, dt, integrator)
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:] = x0[:3], x0[3:]
    out = np.empty((len(torques), 6))
    for i, tau in enumerate(torques):
        data.ctrl[:] = tau
        mujoco.mj_step(model, data)
        out[i, :3], out[i, 3:] = data.qpos, data.qvel
    return out


def replay_torques_analytic(robot: Robot, x0, torques, dt, rtol=1e-12, atol=1e-12):
    """Integrate (1) exactly (to rtol) with the same zero-order-hold torque sequence."""
    am = robot.analytic
    x = np.asarray(x0, float)
    out = np.empty((len(torques), 6))
    for i, tau in enumerate(torques):
        sol = solve_ivp(lambda _t, s: np.concatenate([s[3:], am.acceleration(s[:3], s[3:], tau)]),
                        (0.0, dt), x, method="DOP853", rtol=rtol, atol=atol)
        x = sol.y[:, -1]
        out[i] = x
    return out
