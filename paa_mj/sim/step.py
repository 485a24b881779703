"""One step of a rollout, compiled: what the engine (:mod:`paa_mj.sim.engine`) runs between two ``mj_step``.

Each step of a rollout:

1. the controller sees the state, with optional Gaussian measurement noise (:func:`measure`);
2. its torque enters a delay line (optional), gets optional Gaussian torque noise, and is saturated at the
   rollout's torque limits: that is ``ctrl``, held over the step (zero-order hold, also across the stages
   of RK4) (:func:`actuate`);
3. outcomes are updated (switch, peak torques, integrals of effort, the task's book of success), a sample
   is recorded every ``every`` steps, and a rollout whose balance can no longer fail is retired
   (:mod:`paa_mj.sim.retirement`);
4. optional pushes (generalized forces on the joints) are applied and ``mj_step`` advances the physics; a
   non-finite state, speeds above :data:`MAX_SPEED` or a MuJoCo warning stop the rollout as *diverged*,
   keeping the last good state (:func:`finish_step`: :func:`before_physics`, ``mj_step``, :func:`after_physics`;
   :mod:`paa_mj.sim.mujoco_batch` calls the two around ``mujoco.batch``'s step instead).

Every function reads the records of :mod:`paa_mj.sim.records`: ``run``, ``settings``, ``state``,
``samples`` and one thread's ``physics``.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, types

from ..control.base import KERNEL_TYPE
from ..task import P_GOAL, book_start, book_update
from .mujoco_lib import WARNINGS, mj_reset as _mj_reset, mj_step as _mj_step
from .noise import gaussian
from .records import PHYSICS_T, RUN_T, SAMPLES_T, SETTINGS_T, STATE_T
from .retirement import modal_bound

#: Speeds beyond this [rad/s] mean the simulation has blown up.
MAX_SPEED = 1e4

# Rollout status codes.
RUNNING, FINISHED, RETIRED, NONFINITE_TORQUE, NONFINITE_STATE, RUNAWAY, MUJOCO_WARNING, STOPPED = range(8)
STATUS_TEXT = {
    RUNNING: "running", FINISHED: "ran to the final time", RETIRED: "balanced for good (retired early)",
    NONFINITE_TORQUE: "the controller returned a non-finite torque",
    NONFINITE_STATE: "the state is not finite", RUNAWAY: f"joint speeds above {MAX_SPEED:g} rad/s",
    MUJOCO_WARNING: "MuJoCo warned of an unstable simulation (bad qacc, qpos or qvel)", STOPPED: "interrupted",
}
DIVERGED = (NONFINITE_TORQUE, NONFINITE_STATE, RUNAWAY, MUJOCO_WARNING)
_WARNINGS = np.array(WARNINGS)


@njit(cache=True)
def measure(r, step, physics, run, settings, out):
    """The state the controller sees, with the rollout's measurement noise, into ``out`` (2n)."""
    qpos, qvel = physics.qpos, physics.qvel
    n = qpos.size
    setting = settings.rollouts[r]
    nq, nqd = setting.noise_q, setting.noise_qd
    for i in range(n):
        out[i] = qpos[i]
        out[n + i] = qvel[i]
    if nq > 0.0 or nqd > 0.0:
        for i in range(n):
            out[i] += nq * gaussian(run.seed, setting.id, step, i)
            out[n + i] += nqd * gaussian(run.seed, setting.id, step, n + i)


@njit(cache=True)
def _record(r, k, t, q, qd, tau, mode, samples):
    samples.t[r, k] = t
    for i in range(q.size):
        samples.q[r, k, i] = q[i]
        samples.qd[r, k, i] = qd[i]
    for j in range(tau.size):
        samples.tau[r, k, j] = tau[j]
    samples.mode[r, k] = mode


@njit(cache=True)
def _command(r, step, tau_cmd, physics, run, settings, state):
    """``ctrl`` from the controller's torque: delayed, noisy, saturated; returns whether the torque was finite."""
    ctrl = physics.ctrl
    nu = ctrl.size
    n = physics.qpos.size
    setting = settings.rollouts[r]
    bad_torque = False
    for j in range(nu):
        ctrl[j] = tau_cmd[j]
        if not math.isfinite(ctrl[j]):
            bad_torque = True
    if bad_torque:
        ctrl[:] = 0.0
    delay = setting.delay
    if delay > 0:
        slot = step % (delay + 1)
        back = (step - delay) % (delay + 1)
        for j in range(nu):
            state.delay_line[r, slot, j] = ctrl[j]
            ctrl[j] = 0.0 if step < delay else state.delay_line[r, back, j]
    noise = setting.torque_noise
    if noise > 0.0:
        for j in range(nu):
            ctrl[j] += noise * gaussian(run.seed, setting.id, step, 2 * n + j)
    for j in range(nu):
        limit = settings.limits[r, j]
        ctrl[j] = min(max(ctrl[j], -limit), limit)
    return not bad_torque


@njit(cache=True)
def actuate(r, step, mode, tau_cmd, physics, run, settings, state, samples):
    """Turn the controller's torque into ``ctrl``, account for it, record; returns True to stop here."""
    finite = _command(r, step, tau_cmd, physics, run, settings, state)
    qpos, qvel, ctrl = physics.qpos, physics.qvel, physics.ctrl
    n, nu = qpos.size, ctrl.size
    st = state.rollouts[r]
    st.mode = mode
    if mode == 1 and st.switch < 0:
        st.switch = step
    book_update(run.task, qpos, qvel, step, state.book[r])
    smooth = 0.0
    for j in range(nu):
        state.peak[r, j] = max(state.peak[r, j], abs(ctrl[j]))
        smooth += (ctrl[j] - state.last_tau[r, j]) ** 2
    for i in range(n):
        st.speed = max(st.speed, abs(qvel[i]))
        state.last_state[r, i] = qpos[i]
        state.last_state[r, n + i] = qvel[i]
    if step > 0:
        st.smooth += smooth / (run.dt * run.dt)
    for j in range(nu):
        state.last_tau[r, j] = ctrl[j]
    if run.every > 0 and step % run.every == 0:
        _record(r, st.samples, step * run.dt, qpos, qvel, ctrl, mode, samples)
        st.samples += 1
    if not finite:
        st.status = NONFINITE_TORQUE
        return True
    level = settings.rollouts[r].retire_level
    if run.retire and mode == 1 and level > 0.0 and step * run.dt > settings.rollouts[r].push_end and \
            modal_bound(settings.cert[r], qpos, qvel, run.task[P_GOAL:P_GOAL + n]) <= level:
        st.status = RETIRED
        return True
    return False


@njit(cache=True)
def _record_last(r, step, run, state, samples):
    """A stopped rollout's last good state as its last sample, unless the grid already holds it."""
    st = state.rollouts[r]
    n = state.last_state.shape[1] // 2
    if run.every > 0 and step % run.every != 0:
        _record(r, st.samples, step * run.dt, state.last_state[r, :n], state.last_state[r, n:], state.last_tau[r],
                st.mode, samples)
        st.samples += 1


@njit(cache=True)
def apply_pushes(r, t, pushes, qfrc):
    """Generalized forces of the rollout's pushes at time t into ``qfrc`` [N m]."""
    qfrc[:] = 0.0
    for k in range(pushes.shape[1]):
        sigma = pushes[r, k, 1]
        if sigma <= 0.0:
            continue
        u = (t - pushes[r, k, 0]) / sigma
        if abs(u) < 4.0:
            w = math.exp(-0.5 * u * u)
            for j in range(qfrc.size):
                qfrc[j] += w * pushes[r, k, 2 + j]


@njit(cache=True)
def check_state(qpos, qvel, warnings):
    """RUNNING, or why the state left the finite world."""
    for i in range(qpos.size):
        if not (math.isfinite(qpos[i]) and math.isfinite(qvel[i])):
            return NONFINITE_STATE
    for i in range(qvel.size):
        if abs(qvel[i]) > MAX_SPEED:
            return RUNAWAY
    for w in _WARNINGS:
        if warnings[w] > 0:
            return MUJOCO_WARNING
    return RUNNING


@njit(nogil=True, cache=True)
def before_physics(r, step, mode, tau_cmd, physics, run, settings, state, samples):
    """A step's work before the physics: actuate, record, the pushes into ``qfrc``; True when the rollout ends here."""
    st = state.rollouts[r]
    if actuate(r, step, mode, tau_cmd, physics, run, settings, state, samples):
        _record_last(r, step, run, state, samples)
        return True
    if step == run.n_steps:
        st.status = FINISHED
        return True
    if settings.pushes.shape[1] > 0:
        apply_pushes(r, step * run.dt, settings.pushes, physics.qfrc)
    return False


@njit(nogil=True, cache=True)
def after_physics(r, step, physics, run, state, samples):
    """A step's work after ``mj_step``: the integrals of effort and work, the state's checks (a diverged rollout
    keeps its last good state); True when the rollout ends."""
    st = state.rollouts[r]
    ctrl, qpos, qvel = physics.ctrl, physics.qpos, physics.qvel
    effort, power = 0.0, 0.0
    for j in range(ctrl.size):
        effort += ctrl[j] * ctrl[j]
        power += ctrl[j] * qvel[j + 1]
    st.effort += effort * run.dt
    st.work += abs(power) * run.dt
    status = check_state(qpos, qvel, physics.warnings)
    if status != RUNNING:
        st.status = status
        n = qpos.size
        for i in range(n):
            qpos[i] = state.last_state[r, i]
            qvel[i] = state.last_state[r, n + i]
        _record_last(r, step, run, state, samples)
        return True
    st.step = step + 1
    return False


@njit(nogil=True, cache=True)
def finish_step(r, step, mode, tau_cmd, physics, run, settings, state, samples):
    """Everything of one step after the controller: :func:`before_physics`, ``mj_step``, :func:`after_physics`;
    True when the rollout ends."""
    if before_physics(r, step, mode, tau_cmd, physics, run, settings, state, samples):
        return True
    _mj_step(physics.model, physics.data)
    return after_physics(r, step, physics, run, state, samples)


@njit(nogil=True, cache=True)
def python_step(step, mode, tau_cmd, r, physics, run, settings, state, samples, seen):
    """A step under a Python controller, after its ``torque`` (``tau_cmd`` [N m]): :func:`finish_step`, then
    :func:`measure` of the next step into ``seen``; True when the rollout ends.

    One call from Python a step instead of two: numba checks the type of every argument of a call, which
    costs about a microsecond here, and a small ``mj_step`` a few.
    """
    if finish_step(r, step, mode, tau_cmd, physics, run, settings, state, samples):
        return True
    measure(r, step + 1, physics, run, settings, seen)
    return False


@njit(nogil=True, cache=True)
def start_rollout(r, physics, x0, state, memory0):
    """Reset the data to x0 and the rollout's state to its start."""
    _mj_reset(physics.model, physics.data)
    begin_rollout(r, physics, x0, state, memory0)


@njit(nogil=True, cache=True)
def begin_rollout(r, physics, x0, state, memory0):
    """The rollout's state at its start, and x0 into the (reset) data."""
    qpos, qvel = physics.qpos, physics.qvel
    n = qpos.size
    for i in range(n):
        qpos[i] = x0[r, i]
        qvel[i] = x0[r, n + i]
    st = state.rollouts[r]
    st.step, st.status, st.samples, st.mode = 0, RUNNING, 0, 0
    st.switch = -1
    st.effort, st.work, st.smooth, st.speed = 0.0, 0.0, 0.0, 0.0
    book_start(state.book[r])
    for j in range(state.peak.shape[1]):
        state.peak[r, j] = 0.0
        state.last_tau[r, j] = 0.0
    for i in range(2 * n):
        state.last_state[r, i] = x0[r, i]
    for i in range(state.memory.shape[1]):  # element by element: an array assignment compiles numba's shape checks
        state.memory[r, i] = memory0[i] if i < memory0.size else 0.0
    state.delay_line[r, :, :] = 0.0


@njit(cache=True)
def call_controller(first, second, condition, x, t, params, memory, tau):
    """One evaluation of a packed controller (:func:`paa_mj.sim.engine.pack`): ``first`` until ``condition`` first
    holds, then ``second`` for good; returns the mode of the controller that acted."""
    n1, n2, s1, s2 = int(params[0]), int(params[1]), int(params[2]), int(params[3])
    if memory[0] == 0.0 and condition(x, t, params[4 + n1 + n2:], memory[:1], tau) != 0:
        memory[0] = 1.0
    if memory[0] != 0.0:
        return second(x, t, params[4 + n1:4 + n1 + n2], memory[1 + s1:1 + s1 + s2], tau)
    return first(x, t, params[4:4 + n1], memory[1:1 + s1], tau)


_C1 = types.float64[::1]
#: The records' layouts (:mod:`paa_mj.sim.records`), as :func:`python_step` is compiled for them too: the helpers
#: both call are then compiled once, not once per layout.
_ADVANCE_SIG = types.int64(KERNEL_TYPE, KERNEL_TYPE, KERNEL_TYPE, types.int64, types.int64, _C1, PHYSICS_T, RUN_T,
                           SETTINGS_T, STATE_T, SAMPLES_T)


@njit(_ADVANCE_SIG, nogil=True, cache=True)
def advance_compiled(first, second, condition, r, step_to, params, physics, run, settings, state, samples):
    """Run rollout ``r`` with a compiled controller from its current step through ``step_to``."""
    seen = np.empty(2 * physics.qpos.size)
    tau = np.empty(physics.ctrl.size)
    st = state.rollouts[r]
    memory = state.memory[r]
    while st.status == RUNNING and st.step <= step_to:
        step = st.step
        measure(r, step, physics, run, settings, seen)
        mode = call_controller(first, second, condition, seen, step * run.dt, params, memory, tau)
        if finish_step(r, step, mode, tau, physics, run, settings, state, samples):
            break
    return st.status


@njit(types.int64(KERNEL_TYPE, KERNEL_TYPE, KERNEL_TYPE, _C1, types.float64, _C1, _C1, _C1), cache=True)
def evaluate_once(first, second, condition, x, t, params, memory, tau):
    """:func:`call_controller` with a fixed signature (the layouts :func:`advance_compiled` passes), so that calls
    from Python compile once and share its compiled :func:`call_controller`."""
    return call_controller(first, second, condition, x, t, params, memory, tau)
