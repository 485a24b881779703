"""One step of a rollout, compiled: what the engine (:mod:`paa_mj.sim.compiled.engine`) runs between two ``mj_step``.

Each step of a rollout:

1. the controller sees the state, with optional Gaussian measurement noise (:func:`measure`);
2. its torque enters a delay line (optional), gets optional Gaussian torque noise, and is saturated at the
   rollout's torque limits: that is ``ctrl``, held over the step (zero-order hold, also across the stages
   of RK4) (:func:`actuate`);
3. outcomes are updated (switch, peak torques, integrals of effort, the task's book of success), a sample
   is recorded every ``every`` steps, and a rollout whose balance can no longer fail is retired
   (:mod:`paa_mj.sim.compiled.retirement`);
4. optional pushes (generalized forces on the joints) are applied and ``mj_step`` advances the physics; a
   non-finite state, speeds above :data:`MAX_SPEED` or a MuJoCo warning stop the rollout as *diverged*,
   keeping the last good state (:func:`finish_step`: :func:`before_physics`, ``mj_step``, :func:`after_physics`;
   :mod:`paa_mj.sim.compiled.mujoco_batch` calls the two around ``mujoco.batch``'s step instead).

Each equation of a step is written once, in a function of plain arrays and numbers: :func:`measure_into`,
:func:`command_into`, :func:`account`, :func:`verdict`, :func:`add_effort_work` and :func:`state_status`. The
engine's functions (:func:`measure`, :func:`actuate`, :func:`finish_step`, :func:`check_state`) unpack the
records of :mod:`paa_mj.sim.compiled.records` (``run``, ``settings``, ``state``, ``samples`` and one thread's
``physics``) and call them; the engine on MuJoCo Warp (:mod:`paa_mj.sim.warp.engine`) calls their translations
to Warp (:mod:`paa_mj.sim.warp.translate`), so that the two engines cannot keep different books.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, types

from ...control.base import KERNEL_TYPE
from ...jit import lazy_njit
from ...task import P_GOAL, book_start, book_update
from .mujoco_lib import WARNINGS, mj_reset as _mj_reset, mj_step as _mj_step
from ..noise import gaussian
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
def measure_into(qpos, qvel, noise_q, noise_qd, seed, rollout, step, out):
    """The state the controller sees at ``step``: [qpos, qvel] (n each) plus Gaussian measurement noise of standard
    deviations ``noise_q`` [rad] and ``noise_qd`` [rad/s], the draws of (``seed``, ``rollout``, ``step``), into
    ``out`` (2n)."""
    n = qpos.size
    for i in range(n):
        out[i] = qpos[i]
        out[n + i] = qvel[i]
    if noise_q > 0.0 or noise_qd > 0.0:
        for i in range(n):
            out[i] += noise_q * gaussian(seed, rollout, step, i)
            out[n + i] += noise_qd * gaussian(seed, rollout, step, n + i)


@njit(cache=True)
def measure(r, step, physics, run, settings, out):
    """:func:`measure_into` of rollout ``r``'s state, with its measurement noise."""
    setting = settings.rollouts[r]
    measure_into(physics.qpos, physics.qvel, setting.noise_q, setting.noise_qd, run.seed, setting.id, step, out)


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
def command_into(step, tau_cmd, ctrl, delay, delay_line, torque_noise, seed, rollout, n, limits):
    """``ctrl`` (n - 1) [N m] of ``step`` from the controller's torque ``tau_cmd``; returns whether that was finite.

    A non-finite torque becomes zero (the rollout then stops, after its records); a ``delay`` > 0 [steps] passes
    the torque through ``delay_line`` (delay + 1, n - 1), zero until the first one arrives; then Gaussian noise of
    standard deviation ``torque_noise`` [N m] (draws 2n + j of (``seed``, ``rollout``, ``step``), n links) and
    saturation at +-``limits``.
    """
    nu = ctrl.size
    finite = True
    for j in range(nu):
        ctrl[j] = tau_cmd[j]
        if not math.isfinite(ctrl[j]):
            finite = False
    if not finite:
        ctrl[:] = 0.0
    if delay > 0:
        slot = step % (delay + 1)
        back = (step - delay) % (delay + 1)
        for j in range(nu):
            delay_line[slot, j] = ctrl[j]
            ctrl[j] = 0.0 if step < delay else delay_line[back, j]
    if torque_noise > 0.0:
        for j in range(nu):
            ctrl[j] += torque_noise * gaussian(seed, rollout, step, 2 * n + j)
    for j in range(nu):
        ctrl[j] = min(max(ctrl[j], -limits[j]), limits[j])
    return finite


@njit(cache=True)
def account(step, mode, dt, task, qpos, qvel, ctrl, book, peak, last_tau, last_state, switch, smooth, speed):
    """The records of ``step`` with torques ``ctrl`` held over it; returns the new (switch, smooth, speed).

    ``switch``: the step of the first switch to mode 1 (-1: none yet); the task's ``book`` of success
    (:func:`~paa_mj.task.book_update`); ``peak``: the peak :math:`|\\tau_j|` [N m]; ``smooth``: the sum of squared
    torque changes per second [N^2 m^2 / s^2] (from step 1); ``speed``: the peak :math:`|\\dot q_i|` [rad/s];
    ``last_state`` [q, qd] and ``last_tau``, the last good ones.
    """
    n, nu = qpos.size, ctrl.size
    if mode == 1 and switch < 0:
        switch = step
    book_update(task, qpos, qvel, step, book)
    change = 0.0
    for j in range(nu):
        peak[j] = max(peak[j], abs(ctrl[j]))
        d = ctrl[j] - last_tau[j]
        change += d * d
    for i in range(n):
        speed = max(speed, abs(qvel[i]))
        last_state[i] = qpos[i]
        last_state[n + i] = qvel[i]
    if step > 0:
        smooth += change / (dt * dt)
    for j in range(nu):
        last_tau[j] = ctrl[j]
    return switch, smooth, speed


@njit(cache=True)
def verdict(step, n_steps, finite, retire, mode, level, t, push_end, cert, qpos, qvel, task):
    """The rollout's status after the records of ``step`` (time ``t`` [s]): NONFINITE_TORQUE (``finite`` False),
    RETIRED (``retire``, in mode 1 past its pushes, its :func:`~paa_mj.sim.compiled.retirement.modal_bound` at or below
    ``level`` > 0), FINISHED (the last step) or RUNNING."""
    if not finite:
        return NONFINITE_TORQUE
    if retire and mode == 1 and level > 0.0 and t > push_end:
        # nested: the bound is the one costly term, computed only when the others allow retirement
        if modal_bound(cert, qpos, qvel, task[P_GOAL:P_GOAL + qpos.size]) <= level:
            return RETIRED
    if step == n_steps:
        return FINISHED
    return RUNNING


@njit(cache=True)
def actuate(r, step, mode, tau_cmd, physics, run, settings, state, samples):
    """Turn the controller's torque into ``ctrl``, account for it, record; the rollout's status after the step's
    records (:func:`verdict`)."""
    setting = settings.rollouts[r]
    qpos, qvel, ctrl = physics.qpos, physics.qvel, physics.ctrl
    finite = command_into(step, tau_cmd, ctrl, setting.delay, state.delay_line[r], setting.torque_noise, run.seed,
                          setting.id, qpos.size, settings.limits[r])
    st = state.rollouts[r]
    st.mode = mode
    st.switch, st.smooth, st.speed = account(step, mode, run.dt, run.task, qpos, qvel, ctrl, state.book[r],
                                             state.peak[r], state.last_tau[r], state.last_state[r], st.switch,
                                             st.smooth, st.speed)
    if run.every > 0 and step % run.every == 0:
        _record(r, st.samples, step * run.dt, qpos, qvel, ctrl, mode, samples)
        st.samples += 1
    return verdict(step, run.n_steps, finite, run.retire, mode, setting.retire_level, step * run.dt,
                   setting.push_end, settings.cert[r], qpos, qvel, run.task)


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
def state_status(qpos, qvel):
    """RUNNING, or why the state (n angles, n speeds) left the finite world: NONFINITE_STATE or RUNAWAY (a speed
    above :data:`MAX_SPEED`)."""
    status = RUNNING
    for i in range(qpos.size):
        if not (math.isfinite(qpos[i]) and math.isfinite(qvel[i])):
            status = NONFINITE_STATE
    if status == RUNNING:
        for i in range(qvel.size):
            if abs(qvel[i]) > MAX_SPEED:
                status = RUNAWAY
    return status


@njit(cache=True)
def check_state(qpos, qvel, warnings):
    """:func:`state_status`, else MUJOCO_WARNING when one of MuJoCo's instability warnings was counted."""
    status = state_status(qpos, qvel)
    if status != RUNNING:
        return status
    for w in _WARNINGS:
        if warnings[w] > 0:
            return MUJOCO_WARNING
    return RUNNING


@njit(cache=True)
def add_effort_work(ctrl, qvel, joints, dt, effort, work):
    """The integrals after a step of ``dt`` [s] with ``ctrl`` (:math:`\\tau`) held: (``effort`` +
    :math:`|\\tau|^2 dt` [N^2 m^2 s], ``work`` + :math:`|\\tau \\cdot \\dot q_a| dt` [J]), :math:`\\dot q_a` the
    speeds after the step of the driven ``joints`` (m, 0-based, as floats: motor j drives joint ``joints[j]``)."""
    e, p = 0.0, 0.0
    for j in range(ctrl.size):
        e += ctrl[j] * ctrl[j]
        p += ctrl[j] * qvel[int(joints[j])]
    return effort + e * dt, work + abs(p) * dt


@njit(nogil=True, cache=True)
def before_physics(r, step, mode, tau_cmd, physics, run, settings, state, samples):
    """A step's work before the physics: actuate, record, the pushes into ``qfrc``; True when the rollout ends here."""
    st = state.rollouts[r]
    status = actuate(r, step, mode, tau_cmd, physics, run, settings, state, samples)
    if status != RUNNING:
        st.status = status
        _record_last(r, step, run, state, samples)  # the end, where the sampling grid does not reach it
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
    st.effort, st.work = add_effort_work(ctrl, qvel, run.joints, run.dt, st.effort, st.work)
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
    """One evaluation of a packed controller (:func:`paa_mj.sim.compiled.engine.pack`): ``first`` until ``condition`` first
    holds, then ``second`` for good; returns the mode of the controller that acted."""
    n1, n2, s1, s2 = int(params[0]), int(params[1]), int(params[2]), int(params[3])
    if memory[0] == 0.0 and condition(x, t, params[4 + n1 + n2:], memory[:1], tau) != 0:
        memory[0] = 1.0
    if memory[0] != 0.0:
        return second(x, t, params[4 + n1:4 + n1 + n2], memory[1 + s1:1 + s1 + s2], tau)
    return first(x, t, params[4:4 + n1], memory[1:1 + s1], tau)


_C1 = types.float64[::1]
#: The records' layouts (:mod:`paa_mj.sim.compiled.records`), as :func:`python_step` is compiled for them too: the helpers
#: both call are then compiled once, not once per layout.
_ADVANCE_SIG = types.int64(KERNEL_TYPE, KERNEL_TYPE, KERNEL_TYPE, types.int64, types.int64, _C1, PHYSICS_T, RUN_T,
                           SETTINGS_T, STATE_T, SAMPLES_T)


@lazy_njit(_ADVANCE_SIG, nogil=True, cache=True)
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


@lazy_njit(types.int64(KERNEL_TYPE, KERNEL_TYPE, KERNEL_TYPE, _C1, types.float64, _C1, _C1, _C1), cache=True)
def evaluate_once(first, second, condition, x, t, params, memory, tau):
    """:func:`call_controller` with a fixed signature (the layouts :func:`advance_compiled` passes), so that calls
    from Python compile once and share its compiled :func:`call_controller`."""
    return call_controller(first, second, condition, x, t, params, memory, tau)
