"""Many closed-loop MuJoCo rollouts at once.

The physics of all rollouts advances one step per call of
``mujoco.rollout.Rollout`` (nstep = 1, its thread pool over all cores), and the
hybrid controller (40) + (67) + (68) is evaluated for the whole batch between
steps by the compiled kernel of :mod:`paa_mj.fast` (parallel over cores). Each
rollout may have its own initial state, gains, plant parameters (the model
MuJoCo simulates) and controller parameters (the model the controller
believes). Memory stays bounded: per-rollout summaries, and full trajectories
only when ``record=True``.

Results equal :func:`paa_mj.rollout.simulate_mujoco` for the same inputs (the tests check it).
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field

import mujoco
import numpy as np
from mujoco import rollout as mj_rollout
from tqdm.auto import tqdm

from .controllers import SwitchingController, check_gains, in_switch_region, udd_error
from .dynamics import AnalyticModel
from .errors import PaaError
from .fast import control_batch, kernel_constants
from .model import Robot, model_from_params
from .rollout import MAX_SPEED, mujoco_model_for, validate_run
from .trajectory import BALANCE_TOL

STATE_SPEC = mujoco.mjtState.mjSTATE_FULLPHYSICS


@dataclass
class BatchResult:
    """Per-rollout outcome of :func:`simulate_batch` (arrays over the batch, length N).

    switch_time is NaN where the state never entered region (68); ``diverged``
    marks rollouts stopped for a non-finite or runaway state (their other
    entries describe the last good state). ``held`` marks rollouts under LQR whose
    final state is still inside region (68), the success criterion when noise keeps
    the state from settling within 1e-3 of UDD. ``t_reached`` is the simulated time
    (less than t_final if the run was interrupted).
    """

    x0: np.ndarray
    switch_time: np.ndarray
    balanced: np.ndarray
    final_state: np.ndarray
    E_minus_Er_final: np.ndarray
    V_final: np.ndarray
    max_abs_tau: np.ndarray
    diverged: np.ndarray
    held: np.ndarray
    t_reached: float
    interrupted: bool = False
    trajectories: dict | None = None
    meta: dict = field(default_factory=dict)

    def __len__(self):
        return len(self.x0)

    def success(self):
        """Balanced at UDD at the end, without divergence."""
        return self.balanced & ~self.diverged

    def arrays(self):
        names = ("x0", "switch_time", "balanced", "final_state", "E_minus_Er_final", "V_final", "max_abs_tau",
                 "diverged", "held")
        return {n: getattr(self, n) for n in names}


def _as_rows(value, n, width, name):
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 1:
        arr = np.broadcast_to(arr, (n, arr.size))
    if arr.shape != (n, width):
        raise PaaError(f"{name} must have {width} values per rollout, got shape {arr.shape} for {n} rollouts")
    return np.ascontiguousarray(arr)


def simulate_batch(robot: Robot, x0, t_final=30.0, gains=None, plant_params=None, controller_params=None,
                   dt=None, integrator=None, torque_limit=None, enabled=True, nthread=None, record=False,
                   sample_dt=0.01, progress=False, stop_when_settled=True, noise_std=None, delay_steps=None,
                   seed=0) -> BatchResult:
    """Closed-loop rollouts of N initial states at once.

    Parameters
    ----------
    robot : Robot
        The nominal robot (default plant, controller model and gains).
    x0 : array_like (N, 6)
        Initial states [q1, q2, q3, d1, d2, d3] [rad, rad/s].
    gains : array_like (3,) or (N, 3), optional
        kD, kP, kV per rollout (default: the robot's). Each distinct set is checked
        against the nominal robot's kD_min.
    plant_params, controller_params : list of RobotParams, optional
        Per rollout: what MuJoCo simulates, and what controller (40) and the LQR
        believe (model error when they differ). Default: the nominal robot.
    torque_limit : float or array_like (N,), optional
        Saturation of each torque [N m], per rollout if an array (inf: none).
    noise_std : array_like (N, 2), optional
        Standard deviation of Gaussian measurement noise the controller sees on
        q [rad] and on qd [rad/s], per rollout (drawn from ``seed``).
    delay_steps : array_like (N,) of int, optional
        Control delay in physics steps: the torque computed now is applied this
        many steps later (zero torque before the first one arrives).
    enabled : bool
        The switch (68) to LQR.
    nthread : int, optional
        Physics threads (default: all cores).
    record : bool
        Keep full trajectories (q, qd, tau, mode every ``sample_dt``), else summaries only.
    stop_when_settled : bool
        End early once every rollout has balanced or diverged (the outcome can no longer change).
    """
    x0 = np.atleast_2d(np.asarray(x0, dtype=float))
    n = len(x0)
    if n == 0 or x0.shape[1] != 6:
        raise PaaError(f"initial states must be an (N, 6) array, got shape {x0.shape}")
    for row in x0:
        validate_run(row, t_final, dt, sample_dt)
    if gains is None:
        nominal = robot.resolve_gains()
        gains = [nominal["kD"], nominal["kP"], nominal["kV"]]
    gains = _as_rows(gains, n, 3, "gains")
    for kD, kP, kV in np.unique(gains, axis=0):
        check_gains(robot.analytic, kD, kP, kV)
    base_model = mujoco_model_for(robot, dt, integrator)
    dt = base_model.opt.timestep
    models = _plant_models(base_model, plant_params, n)
    consts, K = _controller_arrays(robot, controller_params, gains, enabled, n)
    if torque_limit is not None:
        from .fast import LIMIT

        consts[:, LIMIT] = np.broadcast_to(np.asarray(torque_limit, dtype=float), (n,))
        if np.any(~(consts[:, LIMIT] > 0)):
            raise PaaError("torque limits must be > 0")
    noise = None if noise_std is None else _as_rows(noise_std, n, 2, "noise_std")
    delays = np.zeros(n, np.int64) if delay_steps is None else np.broadcast_to(np.asarray(delay_steps), (n,)).astype(np.int64)
    if np.any(delays < 0):
        raise PaaError("control delays must be >= 0 steps")
    rng = np.random.default_rng(seed)
    delay_buffer = np.zeros((delays.max() + 1, n, 2)) if delays.any() else None
    measured = np.empty((n, 6))

    nthread = nthread or os.cpu_count() or 1
    datas = [mujoco.MjData(base_model) for _ in range(nthread)]
    nstate = mujoco.mj_stateSize(base_model, STATE_SPEC)
    state = np.zeros((n, nstate))
    state[:, 1:4], state[:, 4:7] = x0[:, :3], x0[:, 3:]
    out = np.empty((n, 1, nstate))
    ctrl = np.zeros((n, 1, 2))
    modes = np.zeros(n, np.int64)
    switch_time = np.full(n, np.nan)
    diverged = np.zeros(n, bool)
    max_tau = np.zeros((n, 2))
    last_good = state.copy()
    n_steps = int(round(t_final / dt))
    every = max(1, int(round(sample_dt / dt)))
    rec = _recorder(n, n_steps // every + 1) if record else None
    chunk = max(1, n // (4 * nthread))  # measured: smaller chunks than the default balance the threads better
    step, interrupted, k = 0, False, 0
    bar = tqdm(total=n_steps, unit="step", unit_scale=True, disable=None if progress else True, leave=False,
               desc=f"batch of {n}")
    try:
        with mj_rollout.Rollout(nthread=nthread) as pool:
            for step in range(n_steps + 1):
                if noise is None:
                    control_batch(state[:, 1:4], state[:, 4:7], ctrl[:, 0, :], consts, K, modes)
                else:
                    measured[:] = state[:, 1:7]
                    measured[:, :3] += rng.standard_normal((n, 3)) * noise[:, :1]
                    measured[:, 3:] += rng.standard_normal((n, 3)) * noise[:, 1:]
                    control_batch(measured[:, :3], measured[:, 3:], ctrl[:, 0, :], consts, K, modes)
                if delay_buffer is not None:
                    # computed now, applied `delay` steps later: a ring buffer indexed by step
                    slot = step % len(delay_buffer)
                    delay_buffer[slot] = ctrl[:, 0, :]
                    ctrl[:, 0, :] = delay_buffer[(step - delays) % len(delay_buffer), np.arange(n)]
                    ctrl[step < delays, 0, :] = 0.0
                bad = modes < 0
                if bad.any():
                    _freeze(bad & ~diverged, diverged, state, last_good, modes, ctrl)
                newly = (modes == 1) & np.isnan(switch_time)
                switch_time[newly] = step * dt
                np.maximum(max_tau, np.abs(ctrl[:, 0, :]), out=max_tau)
                if rec is not None and step % every == 0:
                    rec["t"][k] = step * dt
                    rec["q"][:, k], rec["qd"][:, k] = state[:, 1:4], state[:, 4:7]
                    rec["tau"][:, k], rec["mode"][:, k] = ctrl[:, 0, :], np.maximum(modes, 0)
                    k += 1
                if step % 100 == 0:
                    bar.update(min(100, n_steps - bar.n))
                    if stop_when_settled and not record and _settled(state, modes, diverged):
                        break
                if step == n_steps:
                    break
                pool.rollout(models, datas, state, ctrl, nstep=1, state=out, skip_checks=True, chunk_size=chunk)
                state[:] = out[:, 0]
                # MuJoCo resets a data whose acceleration blows up (time back to 0): catch that too.
                blown = ~np.all(np.isfinite(state), axis=1) | (np.max(np.abs(state[:, 4:7]), axis=1) > MAX_SPEED) \
                    | (np.abs(state[:, 0] - (step + 1) * dt) > 0.5 * dt)
                blown &= ~diverged
                if blown.any():
                    _freeze(blown, diverged, state, last_good, modes, ctrl)
                last_good[~diverged] = state[~diverged]
    except KeyboardInterrupt:
        interrupted = True
    bar.close()
    final = np.concatenate([last_good[:, 1:4], last_good[:, 4:7]], axis=1)
    err = np.max(np.abs(udd_error(final[:, :3], final[:, 3:])), axis=1)
    e_err, V = _energy_and_V(robot, plant_params, gains, final)
    trajectories = None
    if rec is not None:
        trajectories = {key: value[:, :k] if value.ndim > 1 else value[:k] for key, value in rec.items()}
    return BatchResult(x0=x0, switch_time=switch_time, balanced=(err < BALANCE_TOL) & ~diverged, final_state=final,
                       E_minus_Er_final=e_err, V_final=V, max_abs_tau=max_tau, diverged=diverged,
                       held=(modes == 1) & in_switch_region(final[:, :3], final[:, 3:]) & ~diverged,
                       t_reached=step * dt, interrupted=interrupted, trajectories=trajectories,
                       meta={"robot": robot.name, "dt": dt, "t_final": t_final, "nthread": nthread,
                             "integrator": int(base_model.opt.integrator)})


def _plant_models(base_model, plant_params, n):
    if plant_params is None:
        return [base_model] * n
    if len(plant_params) != n:
        raise PaaError(f"plant_params needs one entry per rollout ({n}), got {len(plant_params)}")
    cache, models = {}, []
    for p in plant_params:
        key = AnalyticModel.from_params(p).key()
        if key not in cache:
            m = model_from_params(p)
            m.opt.timestep, m.opt.integrator = base_model.opt.timestep, base_model.opt.integrator
            cache[key] = m
        models.append(cache[key])
    return models


def _controller_arrays(robot, controller_params, gains, enabled, n):
    consts, K = np.empty((n, 15)), np.empty((n, 2, 6))
    cache = {}
    for i in range(n):
        params = robot.params if controller_params is None else controller_params[i]
        key = (AnalyticModel.from_params(params).key(), tuple(gains[i]))
        if key not in cache:
            am = robot.analytic if controller_params is None else AnalyticModel.from_params(params)
            ctrl = SwitchingController.for_model(am, *gains[i], enabled=enabled, check=False)
            cache[key] = kernel_constants(ctrl)
        consts[i], K[i] = cache[key]
    if controller_params is not None and len(controller_params) != n:
        raise PaaError(f"controller_params needs one entry per rollout ({n}), got {len(controller_params)}")
    return consts, K


def _freeze(rows, diverged, state, last_good, modes, ctrl):
    """Stop rollouts that blew up: back to their last good state, no torque, marked diverged."""
    diverged |= rows
    state[rows] = last_good[rows]
    modes[rows] = np.maximum(modes[rows], 0)
    ctrl[rows] = 0.0


def _settled(state, modes, diverged):
    """True when every rollout is balanced under LQR (within 1e-6 of UDD) or diverged."""
    err = np.max(np.abs(udd_error(state[:, 1:4], state[:, 4:7])), axis=1)
    return bool(np.all(diverged | ((modes == 1) & (err < 1e-6 * BALANCE_TOL))))


def _energy_and_V(robot, plant_params, gains, final):
    from .controllers import EnergyVCLController

    q, qd = final[:, :3], final[:, 3:]
    if plant_params is None:
        ams = [robot.analytic] * len(final)
    else:
        ams = [AnalyticModel.from_params(p) for p in plant_params]
    e_err = np.array([am.energy(q[i], qd[i]) - am.E_r for i, am in enumerate(ams)])
    V = np.array([EnergyVCLController(am, *gains[i], check=False).lyapunov(q[i], qd[i]) for i, am in enumerate(ams)])
    return e_err, V


def _recorder(n, n_samples):
    return {"t": np.zeros(n_samples), "q": np.zeros((n, n_samples, 3)), "qd": np.zeros((n, n_samples, 3)),
            "tau": np.zeros((n, n_samples, 2)), "mode": np.zeros((n, n_samples), np.int8)}
