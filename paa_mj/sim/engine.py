"""The rollout engine: MuJoCo stepped from compiled code, with the controller in the same loop.

Every rollout of the package, single or batched, runs through :func:`run`, for any chain of the
family: its arrays are sized from the model (n joints, n - 1 motors) and its task (the goal
q*, region (68) around it, the balance tolerance) is data of the plan, not constants of the step.
Each step of a rollout:

1. the controller sees the state, with optional Gaussian measurement noise;
2. its torque enters a delay line (optional), gets optional Gaussian torque
   noise, and is saturated at the rollout's torque limits: that is ``ctrl``,
   held over the step (zero-order hold, also across the stages of RK4);
3. outcomes are updated (switch time, peak torques, integrals of effort), a
   sample is recorded every ``every`` steps, and a rollout whose balance can
   no longer fail is retired (:mod:`paa_mj.sim.retirement`);
4. optional pushes (generalized forces on the joints) are applied and
   ``mj_step`` advances the physics; a non-finite state, speeds above
   :data:`MAX_SPEED` or a MuJoCo warning stop the rollout as *diverged*,
   keeping the last good state.

A controller with a compiled form (:class:`~paa_mj.control.base.CompiledForm`)
runs with ``mj_step`` called from numba (:mod:`paa_mj.sim.mujoco_lib`), so nothing
of Python happens between steps; rollouts are spread over threads that take one
rollout at a time. Any other controller runs with the same per-step code, its
``torque`` called on the whole batch between steps. Both give the same numbers
for the same torques. Noise comes from :mod:`paa_mj.sim.noise`.
"""
from __future__ import annotations

import math
import os
import threading
from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait
from dataclasses import dataclass, field

import mujoco
import numpy as np
from numba import njit, typeof, types
from numba.extending import register_jitable

from .mujoco_lib import COMPILED_PHYSICS, WARNINGS, mj_reset as _mj_reset, mj_step as _mj_step
from .mujoco_log import mujoco_log_off
from .noise import gaussian
from .retirement import RETIRE_FRACTION, certificate_size, modal_bound, retirement_certificate
from ..control.base import KERNEL_TYPE, CompiledForm, SwitchedForm, kernel, mode_of, reset_controller, torque_of
from ..control.region import BALANCE_TOL, goal_terms
from ..errors import PaaError
from ..progress import progress as progress_bar

__all__ = ["COMPILED_PHYSICS", "RETIRE_FRACTION", "certificate_size", "gaussian", "retirement_certificate", "run",
           "evaluate", "pack", "Plan", "Outcome"]

#: Speeds beyond this [rad/s] mean the simulation has blown up.
MAX_SPEED = 1e4
#: Steps a compiled rollout runs between two looks from Python (progress, Ctrl-C).
SEGMENT = 4096

# Rollout status codes.
RUNNING, FINISHED, RETIRED, NONFINITE_TORQUE, NONFINITE_STATE, RUNAWAY, MUJOCO_WARNING, STOPPED = range(8)
STATUS_TEXT = {
    RUNNING: "running", FINISHED: "ran to the final time", RETIRED: "balanced for good (retired early)",
    NONFINITE_TORQUE: "the controller returned a non-finite torque",
    NONFINITE_STATE: "the state is not finite", RUNAWAY: f"joint speeds above {MAX_SPEED:g} rad/s",
    MUJOCO_WARNING: "MuJoCo warned of an unstable simulation (bad qacc, qpos or qvel)", STOPPED: "interrupted",
}
DIVERGED = (NONFINITE_TORQUE, NONFINITE_STATE, RUNAWAY, MUJOCO_WARNING)

# Integer state of a rollout (one row of ``istate``).
I_STEP, I_STATUS, I_SWITCH, I_REGION, I_OUTSIDE, I_SAMPLES, I_MODE, I_LEFT_GOAL = range(8)
N_ISTATE = 8
# Float state and outcomes (one row of ``fstate``): four sums and peaks, then per motor the peak torque and the
# last torque, then the last good state [q, qd] (see :func:`fstate_layout`).
F_INT_TAU2, F_WORK, F_SMOOTH, F_SPEED = range(4)
F_PEAK = 4
# Per-rollout setup (one row of ``setup``): five scalars, then the torque limit of each motor, then the goal q*.
S_NOISE_Q, S_NOISE_QD, S_TAU_NOISE, S_DELAY, S_LEVEL, S_PUSH_END = range(6)
S_LIMITS = 6
_WARNINGS = np.array(WARNINGS)


@register_jitable
def fstate_layout(n_links):
    """(peak, previous, last, width): where a row of ``fstate`` keeps the peak torques (n - 1), the last
    torques (n - 1) and the last good state (2n), and its width."""
    nu = n_links - 1
    return F_PEAK, F_PEAK + nu, F_PEAK + 2 * nu, F_PEAK + 2 * nu + 2 * n_links


@register_jitable
def setup_layout(n_links):
    """(limits, goal, width): where a row of ``setup`` keeps the torque limits (n - 1) and the goal q* (n)."""
    return S_LIMITS, S_LIMITS + n_links - 1, S_LIMITS + 2 * n_links - 1


def push_width(n_links):
    """A push is (t_center [s], sigma [s], f_1..f_n [N m]): a Gaussian pulse of generalized force on the joints."""
    return 2 + n_links


# --- the per-step pieces, shared by the compiled loop and the Python-controller path --------------

@njit(cache=True)
def measure(r, step, qpos, qvel, setup, rollout_ids, seed, out):
    """The state the controller sees, with the rollout's measurement noise, into ``out`` (2n)."""
    n = qpos.size
    nq, nqd = setup[r, S_NOISE_Q], setup[r, S_NOISE_QD]
    for i in range(n):
        out[i] = qpos[i]
        out[n + i] = qvel[i]
    if nq > 0.0 or nqd > 0.0:
        for i in range(n):
            out[i] += nq * gaussian(seed, rollout_ids[r], step, i)
            out[n + i] += nqd * gaussian(seed, rollout_ids[r], step, n + i)


@njit(cache=True)
def _record(r, k, t, qpos, qvel, tau, mode, rec_t, rec_q, rec_qd, rec_tau, rec_mode):
    rec_t[r, k] = t
    for i in range(qpos.size):
        rec_q[r, k, i] = qpos[i]
        rec_qd[r, k, i] = qvel[i]
    for j in range(tau.size):
        rec_tau[r, k, j] = tau[j]
    rec_mode[r, k] = mode


@njit(cache=True)
def actuate(r, step, dt, mode, tau_cmd, ctrl, qpos, qvel, setup, cert, delay_line, istate, fstate, rollout_ids, seed,
            every, rec_t, rec_q, rec_qd, rec_tau, rec_mode, retire):
    """Turn the controller's torque into ``ctrl``, account for it, record; returns True to stop here."""
    st = istate[r]
    fs = fstate[r]
    n, nu = qpos.size, ctrl.size
    f_peak, f_prev, f_last, _ = fstate_layout(n)
    s_limits, s_goal, _ = setup_layout(n)
    bad_torque = False
    for j in range(nu):
        ctrl[j] = tau_cmd[j]
        if not math.isfinite(ctrl[j]):
            bad_torque = True
    if bad_torque:
        ctrl[:] = 0.0
    delay = int(setup[r, S_DELAY])
    if delay > 0:
        slot = step % (delay + 1)
        back = (step - delay) % (delay + 1)
        for j in range(nu):
            delay_line[r, slot, j] = ctrl[j]
            ctrl[j] = 0.0 if step < delay else delay_line[r, back, j]
    noise = setup[r, S_TAU_NOISE]
    if noise > 0.0:
        for j in range(nu):
            ctrl[j] += noise * gaussian(seed, rollout_ids[r], step, 2 * n + j)
    for j in range(nu):
        limit = setup[r, s_limits + j]
        ctrl[j] = min(max(ctrl[j], -limit), limit)
    st[I_MODE] = mode
    if mode == 1 and st[I_SWITCH] < 0:
        st[I_SWITCH] = step
    goal = setup[r, s_goal:s_goal + n]
    inside, angle_max, speed_max, _, _ = goal_terms(qpos, qvel, n, goal)
    distance = max(angle_max, speed_max)  # the largest error max(|wrap(q - q*)|, |qd|) [rad, rad/s]
    if st[I_REGION] < 0 and inside:
        st[I_REGION] = step
    if not inside:  # the success window (:func:`~paa_mj.control.region.succeeded`) starts after the last exit
        st[I_LEFT_GOAL] = step
    if distance >= BALANCE_TOL:
        st[I_OUTSIDE] = step
    smooth = 0.0
    for j in range(nu):
        fs[f_peak + j] = max(fs[f_peak + j], abs(ctrl[j]))
        smooth += (ctrl[j] - fs[f_prev + j]) ** 2
    for i in range(n):
        fs[F_SPEED] = max(fs[F_SPEED], abs(qvel[i]))
        fs[f_last + i] = qpos[i]
        fs[f_last + n + i] = qvel[i]
    if step > 0:
        fs[F_SMOOTH] += smooth / (dt * dt)
    for j in range(nu):
        fs[f_prev + j] = ctrl[j]
    if every > 0 and step % every == 0:
        _record(r, st[I_SAMPLES], step * dt, qpos, qvel, ctrl, mode, rec_t, rec_q, rec_qd, rec_tau, rec_mode)
        st[I_SAMPLES] += 1
    if bad_torque:
        st[I_STATUS] = NONFINITE_TORQUE
        return True
    level = setup[r, S_LEVEL]
    if retire and mode == 1 and level > 0.0 and step * dt > setup[r, S_PUSH_END] and \
            modal_bound(cert[r], qpos, qvel, goal) <= level:
        st[I_STATUS] = RETIRED
        return True
    return False


@njit(cache=True)
def _record_last(r, step, dt, every, istate, fstate, nu, rec_t, rec_q, rec_qd, rec_tau, rec_mode):
    """A stopped rollout's last good state as its last sample, unless the grid already holds it."""
    st = istate[r]
    fs = fstate[r]
    n = (fs.size - F_PEAK - 2 * nu) // 2
    _, f_prev, f_last, _ = fstate_layout(n)
    if every > 0 and step % every != 0:
        _record(r, st[I_SAMPLES], step * dt, fs[f_last:f_last + n], fs[f_last + n:f_last + 2 * n],
                fs[f_prev:f_prev + nu], st[I_MODE], rec_t, rec_q, rec_qd, rec_tau, rec_mode)
        st[I_SAMPLES] += 1


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
def finish_step(r, step, mode, tau_cmd, model_ptr, data_ptr, qpos, qvel, ctrl, qfrc, warnings, dt, n_steps, every,
                retire, setup, cert, pushes, delay_line, istate, fstate, rollout_ids, seed,
                rec_t, rec_q, rec_qd, rec_tau, rec_mode):
    """Everything of one step after the controller: actuate, record, step the physics; True when the rollout ends."""
    st = istate[r]
    nu = ctrl.size
    if actuate(r, step, dt, mode, tau_cmd, ctrl, qpos, qvel, setup, cert, delay_line, istate, fstate, rollout_ids,
               seed, every, rec_t, rec_q, rec_qd, rec_tau, rec_mode, retire):
        _record_last(r, step, dt, every, istate, fstate, nu, rec_t, rec_q, rec_qd, rec_tau, rec_mode)
        return True
    if step == n_steps:
        st[I_STATUS] = FINISHED
        return True
    if pushes.shape[1] > 0:
        apply_pushes(r, step * dt, pushes, qfrc)
    _mj_step(model_ptr, data_ptr)
    fs = fstate[r]
    effort, power = 0.0, 0.0
    for j in range(nu):
        effort += ctrl[j] * ctrl[j]
        power += ctrl[j] * qvel[j + 1]
    fs[F_INT_TAU2] += effort * dt
    fs[F_WORK] += abs(power) * dt
    status = check_state(qpos, qvel, warnings)
    if status != RUNNING:
        st[I_STATUS] = status
        n = qpos.size
        _, _, f_last, _ = fstate_layout(n)
        for i in range(n):
            qpos[i] = fs[f_last + i]
            qvel[i] = fs[f_last + n + i]
        _record_last(r, step, dt, every, istate, fstate, nu, rec_t, rec_q, rec_qd, rec_tau, rec_mode)
        return True
    st[I_STEP] = step + 1
    return False


@njit(nogil=True, cache=True)
def python_step(step, mode, tau_cmd, r, model_ptr, data_ptr, qpos, qvel, ctrl, qfrc, warnings, dt, n_steps, every,
                retire, setup, cert, pushes, delay_line, istate, fstate, rollout_ids, seed,
                rec_t, rec_q, rec_qd, rec_tau, rec_mode, seen):
    """A step under a Python controller, after its ``torque`` (``tau_cmd`` [N m]): :func:`finish_step`, then
    :func:`measure` of the next step into ``seen``; True when the rollout ends.

    One call from Python a step instead of two: numba checks the type of every argument of a call, which
    costs about a microsecond here, and a small ``mj_step`` a few.
    """
    if finish_step(r, step, mode, tau_cmd, model_ptr, data_ptr, qpos, qvel, ctrl, qfrc, warnings, dt, n_steps, every,
                   retire, setup, cert, pushes, delay_line, istate, fstate, rollout_ids, seed,
                   rec_t, rec_q, rec_qd, rec_tau, rec_mode):
        return True
    measure(r, step + 1, qpos, qvel, setup, rollout_ids, seed, seen)
    return False


@njit(nogil=True, cache=True)
def start_rollout(r, model_ptr, data_ptr, qpos, qvel, x0, istate, fstate, memory, memory0, delay_line):
    """Reset the data to x0 and the rollout's state to its start."""
    _mj_reset(model_ptr, data_ptr)
    n = qpos.size
    for i in range(n):
        qpos[i] = x0[r, i]
        qvel[i] = x0[r, n + i]
    istate[r, :] = 0
    istate[r, I_SWITCH] = -1
    istate[r, I_REGION] = -1
    istate[r, I_OUTSIDE] = -1
    istate[r, I_LEFT_GOAL] = -1
    fstate[r, :] = 0.0
    _, _, f_last, _ = fstate_layout(n)
    for i in range(2 * n):
        fstate[r, f_last + i] = x0[r, i]
    for i in range(memory0.size):  # element by element: an array assignment compiles numba's shape checks, seconds
        memory[r, i] = memory0[i]
    delay_line[r, :, :] = 0.0


@kernel
def _never(x, t, params, memory, tau):
    return 0


@njit(cache=True)
def call_controller(first, second, condition, x, t, params, memory, tau):
    """One evaluation of a packed controller (see :func:`pack`): ``first`` until ``condition`` first holds,
    then ``second`` for good; returns the mode of the controller that acted."""
    n1, n2, s1, s2 = int(params[0]), int(params[1]), int(params[2]), int(params[3])
    if memory[0] == 0.0 and condition(x, t, params[4 + n1 + n2:], memory[:1], tau) != 0:
        memory[0] = 1.0
    if memory[0] != 0.0:
        return second(x, t, params[4 + n1:4 + n1 + n2], memory[1 + s1:1 + s1 + s2], tau)
    return first(x, t, params[4:4 + n1], memory[1:1 + s1], tau)


_C1, _C2, _C3 = types.float64[::1], types.float64[:, ::1], types.float64[:, :, ::1]
#: C-contiguous arrays, as :func:`python_step` is compiled for (``typeof`` of the same arrays): the helpers both call
#: are then compiled once, not once per layout. ``warnings`` is MuJoCo's strided view of its warning counters.
_ADVANCE_SIG = types.int64(
    KERNEL_TYPE, KERNEL_TYPE, KERNEL_TYPE, types.int64, types.int64, _C1, types.intp, types.intp,
    _C1, _C1, _C1, _C1, types.int32[:], types.float64,
    types.int64, types.int64, types.boolean, _C2, _C2, _C3,
    _C2, _C3, types.int64[:, ::1], _C2, types.int64[::1], types.int64,
    _C2, _C3, _C3, _C3, types.int8[:, ::1])


@njit(_ADVANCE_SIG, nogil=True, cache=True)
def advance_compiled(first, second, condition, r, step_to, params, model_ptr, data_ptr, qpos, qvel, ctrl, qfrc,
                     warnings, dt, n_steps, every, retire, setup, cert, pushes, memory, delay_line, istate, fstate,
                     rollout_ids, seed, rec_t, rec_q, rec_qd, rec_tau, rec_mode):
    """Run rollout ``r`` with a compiled controller from its current step through ``step_to``."""
    seen = np.empty(2 * qpos.size)
    tau = np.empty(ctrl.size)
    st = istate[r]
    mem = memory[r]
    while st[I_STATUS] == RUNNING and st[I_STEP] <= step_to:
        step = st[I_STEP]
        measure(r, step, qpos, qvel, setup, rollout_ids, seed, seen)
        mode = call_controller(first, second, condition, seen, step * dt, params, mem, tau)
        if finish_step(r, step, mode, tau, model_ptr, data_ptr, qpos, qvel, ctrl, qfrc, warnings, dt, n_steps, every,
                       retire, setup, cert, pushes, delay_line, istate, fstate, rollout_ids, seed,
                       rec_t, rec_q, rec_qd, rec_tau, rec_mode):
            break
    return st[I_STATUS]


@njit(types.int64(KERNEL_TYPE, KERNEL_TYPE, KERNEL_TYPE, _C1, types.float64, _C1, _C1, _C1), cache=True)
def evaluate_once(first, second, condition, x, t, params, memory, tau):
    """:func:`call_controller` with a fixed signature (the layouts :func:`advance_compiled` passes), so that calls
    from Python compile once and share its compiled :func:`call_controller`."""
    return call_controller(first, second, condition, x, t, params, memory, tau)


@dataclass(frozen=True, eq=False)
class Packed:
    """A compiled controller as the engine calls it: three kernels, one parameter vector, one initial memory."""

    first: object
    second: object
    condition: object
    params: np.ndarray
    memory: np.ndarray


def pack(form) -> Packed:
    """The engine's layout of a :class:`CompiledForm` or :class:`SwitchedForm`.

    ``params`` = [n1, n2, s1, s2, first's params (n1), second's (n2), the condition's]
    and ``memory`` = [switched?, first's memory (s1), second's memory (s2)].
    """
    if isinstance(form, SwitchedForm):
        first, second, condition, cond_params = form.first, form.second, form.condition, form.condition_params
    else:
        first, second, condition, cond_params = form, CompiledForm(_never, np.zeros(1)), _never, np.zeros(0)
    params = np.concatenate([[first.params.size, second.params.size, first.memory.size, second.memory.size],
                             first.params, second.params, np.asarray(cond_params, float)])
    memory = np.concatenate([[0.0], first.memory, second.memory])
    return Packed(first.kernel, second.kernel, condition, np.ascontiguousarray(params), memory)


def evaluate(form, q, qd, t=0.0, memory=None):
    """Torques (N, n - 1) and modes of a compiled form at states (N, n), (N, n), from ``memory`` (default: initial)."""
    packed = pack(form)
    q, qd = np.atleast_2d(np.asarray(q, float)), np.atleast_2d(np.asarray(qd, float))
    tau, modes = np.empty((len(q), q.shape[1] - 1)), np.empty(len(q), np.int64)
    out = np.empty(q.shape[1] - 1)
    for i in range(len(q)):
        mem = (packed.memory if memory is None else np.asarray(memory, float)).copy()
        modes[i] = evaluate_once(packed.first, packed.second, packed.condition, np.concatenate([q[i], qd[i]]),
                                 float(t), packed.params, mem, out)
        tau[i] = out
    return tau, modes


# --- the Python side: plans, threads -----------------------------------------------------------------

@dataclass
class Plan:
    """What to run: N rollouts of one time step and length on one or more plant models.

    Attributes
    ----------
    models : list of mujoco.MjModel
        The distinct plants (same sizes, time step and integrator).
    model_index : ndarray (N,) of int
        Which plant each rollout runs on.
    x0 : ndarray (N, 2n)
        Initial states [q, qd] (n joints of the models).
    setup : ndarray (N, width)
        Noise levels, delay, retirement level, end of the pushes, torque limits and goal (:func:`setup_layout`).
    cert : ndarray (N, 3 (2n)^2)
        The retirement certificate of each rollout (:func:`~paa_mj.sim.retirement.retirement_certificate`).
    pushes : ndarray (N, K, 2 + n)
        Pushes (t_center [s], sigma [s], f_1..f_n [N m]); K may be 0.
    rollout_ids : ndarray (N,) of int
        Global rollout numbers: the noise of a rollout depends on (seed, id, step) only.
    seed : int
    dt : float
    n_steps : int
    every : int
        Record a sample every ``every`` steps (0: record nothing).
    retire : bool
        Stop rollouts early by the retirement rule (:mod:`paa_mj.sim.retirement`).
    goal : str
        The goal the rollouts are judged against (its angles are in ``setup``).
    """

    models: list
    model_index: np.ndarray
    x0: np.ndarray
    setup: np.ndarray
    cert: np.ndarray
    pushes: np.ndarray
    rollout_ids: np.ndarray
    seed: int
    dt: float
    n_steps: int
    every: int = 0
    retire: bool = False
    goal: str = "folded"

    def __post_init__(self):
        # contiguous, as advance_compiled's signature takes them (no copy where they are already)
        self.setup, self.cert, self.pushes = (np.ascontiguousarray(a, dtype=float)
                                              for a in (self.setup, self.cert, self.pushes))
        self.rollout_ids = np.ascontiguousarray(self.rollout_ids, dtype=np.int64)

    def __len__(self):
        return len(self.x0)

    @property
    def n_links(self) -> int:
        return int(self.models[0].nq)


@dataclass
class Outcome:
    """The engine's raw result: per-rollout integer and float state, and the samples if recorded."""

    istate: np.ndarray
    fstate: np.ndarray
    samples: dict | None
    interrupted: bool = False
    meta: dict = field(default_factory=dict)


def _data_views(data):
    return data.qpos, data.qvel, data.ctrl, data.qfrc_applied, data.warning.number


class _Arrays:
    """The mutable per-rollout arrays of one run."""

    def __init__(self, plan: Plan, memory_size: int):
        n = len(plan)
        links = plan.n_links
        self.istate = np.zeros((n, N_ISTATE), np.int64)
        self.fstate = np.zeros((n, fstate_layout(links)[-1]))
        self.memory = np.zeros((n, max(1, memory_size)))
        self.delay_line = np.zeros((n, int(np.max(plan.setup[:, S_DELAY], initial=0)) + 1, links - 1))
        capacity = plan.n_steps // plan.every + 2 if plan.every else 0
        self.rec_t = np.zeros((n, capacity))
        self.rec_q = np.zeros((n, capacity, links))
        self.rec_qd = np.zeros((n, capacity, links))
        self.rec_tau = np.zeros((n, capacity, links - 1))
        self.rec_mode = np.zeros((n, capacity), np.int8)

    def start(self, plan, r, model, data, memory0):
        qpos, qvel, _, _, _ = _data_views(data)
        initial = np.zeros(self.memory.shape[1])
        initial[:memory0.size] = memory0
        start_rollout(r, model._address, data._address, qpos, qvel, plan.x0, self.istate, self.fstate, self.memory,
                      initial, self.delay_line)

    def step_args(self, plan):
        return (plan.dt, plan.n_steps, plan.every, plan.retire, plan.setup, plan.cert, plan.pushes)

    def state_args(self, plan):
        return (self.istate, self.fstate, plan.rollout_ids, int(plan.seed), self.rec_t, self.rec_q, self.rec_qd,
                self.rec_tau, self.rec_mode)


def _form_of(controller):
    compiled = getattr(controller, "compiled", None)
    return compiled() if callable(compiled) else None


def run(plan: Plan, controllers, nthread=None, progress=False, desc="rollouts") -> Outcome:
    """Run every rollout of ``plan``; ``controllers`` holds one controller per rollout (repeats allowed).

    Compiled controllers run on ``nthread`` threads (default: all cores), one
    rollout at a time each; the others run together, ``torque`` on the batch
    between steps. Ctrl-C (or SIGTERM through :mod:`paa_mj.cli`) stops at the next
    segment and returns what finished, with ``interrupted`` set.
    """
    n = len(plan)
    if len(controllers) != n:
        raise PaaError(f"need one controller per rollout ({n}), got {len(controllers)}")
    forms, compiled_rows, python_groups = {}, [], {}
    for r, controller in enumerate(controllers):
        key = id(controller)
        if key not in forms:
            form = _form_of(controller)
            forms[key] = None if form is None else pack(form)
        if forms[key] is not None:
            compiled_rows.append(r)
        else:
            python_groups.setdefault(key, []).append(r)
    memory_size = max([f.memory.size for f in forms.values() if f is not None] + [1])
    arrays = _Arrays(plan, memory_size)
    interrupted = False
    # Counted in simulated seconds, so that one long rollout shows its progress too.
    bar = _SimulatedTime(progress_bar(total=round(n * plan.n_steps * plan.dt, 6), unit="s simulated", desc=desc,
                                      enabled=progress), arrays, plan)
    try:
        with mujoco_log_off():
            if compiled_rows:
                interrupted = _run_compiled(plan, controllers, forms, compiled_rows, arrays, nthread, bar)
            for rows in python_groups.values():
                if interrupted:
                    break
                interrupted = _run_python(plan, controllers[rows[0]], rows, arrays, bar)
    finally:
        bar.close()
    running = arrays.istate[:, I_STATUS] == RUNNING
    arrays.istate[running, I_STATUS] = STOPPED
    samples = None
    if plan.every:
        samples = {"t": arrays.rec_t, "q": arrays.rec_q, "qd": arrays.rec_qd, "tau": arrays.rec_tau,
                   "mode": arrays.rec_mode, "count": arrays.istate[:, I_SAMPLES].copy()}
    return Outcome(arrays.istate, arrays.fstate, samples, interrupted=interrupted or bool(running.any()))


class _SimulatedTime:
    """A progress bar fed with the simulated time of every rollout (finished ones count in full)."""

    def __init__(self, bar, arrays, plan):
        self.bar, self.arrays, self.plan, self.reported = bar, arrays, plan, 0.0

    def refresh(self):
        st = self.arrays.istate
        steps = np.where(st[:, I_STATUS] == RUNNING, st[:, I_STEP], self.plan.n_steps)
        done = round(float(np.sum(steps)) * self.plan.dt, 6)
        if done > self.reported:
            self.bar.update(done - self.reported)
            self.reported = done

    def close(self):
        self.refresh()
        self.bar.close()


def _run_compiled(plan, controllers, forms, rows, arrays, nthread, bar):
    """Compiled rollouts, one at a time per thread; returns True if interrupted."""
    nthread = max(1, min(nthread or os.cpu_count() or 1, len(rows)))
    queue = iter(rows)
    lock, stop = threading.Lock(), threading.Event()
    step_args, state_args = arrays.step_args(plan), arrays.state_args(plan)

    def run_one(r, datas):
        model = plan.models[plan.model_index[r]]
        data = datas.get(id(model))
        if data is None:
            data = datas[id(model)] = mujoco.MjData(model)
        form = forms[id(controllers[r])]
        arrays.start(plan, r, model, data, form.memory)
        views = _data_views(data)
        while not stop.is_set():
            step_to = min(arrays.istate[r, I_STEP] + SEGMENT, plan.n_steps)
            status = advance_compiled(form.first, form.second, form.condition, r, step_to, form.params,
                                      model._address, data._address, *views,
                                      *step_args, arrays.memory, arrays.delay_line, *state_args)
            if nthread == 1:
                bar.refresh()
            if status != RUNNING:
                return

    def work():
        datas = {}
        while not stop.is_set():
            with lock:
                r = next(queue, None)
            if r is None:
                return
            run_one(r, datas)

    if nthread == 1:  # in this thread, so Ctrl-C lands between two segments
        try:
            work()
        except KeyboardInterrupt:
            return True
        return False
    with ThreadPoolExecutor(nthread) as pool:
        futures = {pool.submit(work) for _ in range(nthread)}
        try:
            while futures:
                finished, futures = wait(futures, timeout=0.2, return_when=FIRST_COMPLETED)
                for future in finished:
                    future.result()
                bar.refresh()
        except KeyboardInterrupt:
            stop.set()
            wait(futures)
            return True
    return False


def _run_python(plan, controller, rows, arrays, bar):
    """Rollouts of a controller without a compiled form, stepped together; returns True if interrupted.

    The controller's ``torque`` is called once per step on the batch of measured states. Everything
    else of a step runs in one call of :func:`python_step` per rollout, its arguments bound once: the
    Python between two physics steps is what a hand-written ``mj_step`` loop would have, and little more.
    """
    rows = [int(r) for r in rows]
    datas = [mujoco.MjData(plan.models[plan.model_index[r]]) for r in rows]
    views = [_data_views(d) for d in datas]
    for r, data in zip(rows, datas):
        arrays.start(plan, r, plan.models[plan.model_index[r]], data, np.zeros(1))
    reset_controller(controller)
    links = plan.n_links
    seen = np.zeros((len(rows), 2 * links))
    seen_q, seen_qd = seen[:, :links], seen[:, links:]
    step_args, state_args = arrays.step_args(plan), arrays.state_args(plan)
    dt, status = plan.dt, arrays.istate[:, I_STATUS]
    bound = [(r, plan.models[plan.model_index[r]]._address, datas[k]._address, *views[k], *step_args,
              arrays.delay_line, *state_args, seen[k]) for k, r in enumerate(rows)]
    # python_step as compiled for exactly these arguments (step, mode, torques, the bound ones): called
    # without numba's look at the type of every argument, which would cost as much as the rest of the call
    torques = np.zeros((len(rows), links - 1))
    steppers = [python_step.compile(tuple(typeof(a) for a in (0, 0, torques[0], *args))) for args in bound]
    active = list(range(len(rows)))
    batch = (len(rows),)
    try:
        for k, r in enumerate(rows):
            measure(r, 0, views[k][0], views[k][1], plan.setup, plan.rollout_ids, int(plan.seed), seen[k])
        for step in range(plan.n_steps + 1):
            # copied into the engine's own array: the controller may reuse or change its output later
            torques[:] = torque_of(controller, seen_q.copy(), seen_qd.copy(), step * dt, copy=False)
            modes = mode_of(controller, batch, plain=True)  # one int for every rollout, or one per rollout
            ended = False
            for k in active:
                if steppers[k](step, modes if type(modes) is int else int(modes[k]), torques[k], *bound[k]):
                    ended = True
            if step % SEGMENT == 0:
                bar.refresh()
            if ended:
                active = [k for k in active if status[rows[k]] == RUNNING]
                if not active:
                    break
    except KeyboardInterrupt:
        return True
    return False
