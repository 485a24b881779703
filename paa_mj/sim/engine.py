"""The rollout engine: MuJoCo stepped from compiled code, with the controller in the same loop.

Every rollout of the package, single or batched, runs through :func:`run`.
Each step of a rollout:

1. the controller sees the state, with optional Gaussian measurement noise;
2. its torque enters a delay line (optional), gets optional Gaussian torque
   noise, and is saturated at the rollout's torque limits: that is ``ctrl``,
   held over the step (zero-order hold, also across the stages of RK4);
3. outcomes are updated (switch time, peak torques, integrals of effort), a
   sample is recorded every ``every`` steps, and a rollout whose balance can
   no longer fail is retired (below);
4. optional pushes (generalized forces on the joints) are applied and
   ``mj_step`` advances the physics; a non-finite state, speeds above
   :data:`MAX_SPEED` or a MuJoCo warning stop the rollout as *diverged*,
   keeping the last good state.

A controller with a compiled form (:class:`~paa_mj.control.base.CompiledForm`)
runs with ``mj_step`` called from numba (through MuJoCo's C library, the one the
Python bindings load), so nothing of Python happens between steps; rollouts are
spread over threads that take one rollout at a time. Any other controller runs
with the same per-step code, its ``torque`` called on the whole batch between
steps. Both give the same numbers for the same torques.

Retirement: a rollout under the balance controller (mode 1) stops early once
its balance can no longer fail. Linearised at UDD and sampled with zero-order
hold at the time step, the closed loop of the plant and the controller's
balance gain K is x_{k+1} = Phi x_k. Writing x = sum_m c_m v_m over the
eigenvectors of Phi (all eigenvalues inside the unit circle), every future :math:`|x_i|` is at most
:math:`\\sum_m |c_m| |v_{m,i}|` (the *modal bound*, tight when one mode dominates). A rollout
retires when that bound is below 0.9 :data:`~paa_mj.control.region.BALANCE_TOL`
in every coordinate: it would stay balanced to the end, and its peak torques
can no longer grow (:math:`|K x|` only shrinks there). It reports its state and time
at retirement. Retirement is off where the bound does not hold: with noise,
delay, pushes still to come, or an unstable sampled loop.
"""
from __future__ import annotations

import ctypes.util
import glob
import math
import os
import threading
from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait
from dataclasses import dataclass, field

import mujoco
import numpy as np
from numba import njit, types

from .mujoco_log import mujoco_log_off
from ..control.base import KERNEL_TYPE, CompiledForm, SwitchedForm, kernel, mode_of, reset_controller, torque_of
from ..control.region import BALANCE_TOL, inside_region
from ..errors import PaaError
from ..progress import progress as progress_bar
from ..model.states import udd_error_components

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
# Float state and outcomes (one row of ``fstate``).
(F_TAU2, F_TAU3, F_INT_TAU2, F_WORK, F_SMOOTH, F_SPEED, F_PREV2, F_PREV3,
 F_Q1, F_Q2, F_Q3, F_D1, F_D2, F_D3) = range(14)
N_FSTATE = 14
#: Width of a retirement certificate: Re and Im of V^-1 and the moduli of V (6 x 6 each), V the eigenvectors of Phi.
N_CERT = 108
#: A rollout retires when its modal bound is below this fraction of BALANCE_TOL.
RETIRE_FRACTION = 0.9
# Per-rollout setup (one row of ``setup``).
S_LIMIT2, S_LIMIT3, S_NOISE_Q, S_NOISE_QD, S_TAU_NOISE, S_DELAY, S_LEVEL, S_PUSH_END = range(8)
N_SETUP = 8
# A push: Gaussian pulse of generalized force on the joints, (t_center, sigma, f1, f2, f3).
N_PUSH = 5

_WARNINGS = np.array([int(mujoco.mjtWarning.mjWARN_BADQACC), int(mujoco.mjtWarning.mjWARN_BADQPOS),
                      int(mujoco.mjtWarning.mjWARN_BADQVEL), int(mujoco.mjtWarning.mjWARN_BADCTRL)])


def _mujoco_library():
    """Path of the MuJoCo C library that the Python bindings load."""
    folder = os.path.dirname(mujoco.__file__)
    found = sorted(glob.glob(os.path.join(folder, "libmujoco.so*")) + glob.glob(os.path.join(folder, "libmujoco*.dylib"))
                   + glob.glob(os.path.join(folder, "mujoco.dll")))
    return found[0] if found else ctypes.util.find_library("mujoco")


def _link_mujoco():
    import llvmlite.binding as llvm

    path = _mujoco_library()
    if path is None:
        return False
    llvm.load_library_permanently(path)
    return True


COMPILED_PHYSICS = _link_mujoco()
# MuJoCo's functions as numba sees them: pointers passed as integers (same ABI).
_mj_step = types.ExternalFunction("mj_step", types.void(types.intp, types.intp))
_mj_reset = types.ExternalFunction("mj_resetData", types.void(types.intp, types.intp))


# --- counter-based Gaussian noise: the same numbers whatever thread runs a rollout ---------------

@njit(cache=True)
def _mix(z):
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


@njit(cache=True)
def gaussian(seed, rollout, step, k):
    """A standard normal number determined by (seed, rollout, step, k) alone (SplitMix64 + Box-Muller)."""
    z = _mix(np.uint64(seed) * np.uint64(0x9E3779B97F4A7C15) + np.uint64(rollout))
    z = _mix(z ^ (np.uint64(step) * np.uint64(0xD1B54A32D192ED03) + np.uint64(k)))
    u1 = ((z >> np.uint64(11)) + np.uint64(1)) * (1.0 / 9007199254740993.0)
    u2 = (_mix(z) >> np.uint64(11)) * (1.0 / 9007199254740992.0)
    return math.sqrt(-2.0 * math.log(u1)) * math.cos(2.0 * math.pi * u2)


# --- the per-step pieces, shared by the compiled loop and the Python-controller path --------------

@njit(cache=True)
def measure(r, step, qpos, qvel, setup, rollout_ids, seed, out):
    """The state the controller sees, with the rollout's measurement noise, into ``out`` (6)."""
    nq, nqd = setup[r, S_NOISE_Q], setup[r, S_NOISE_QD]
    for i in range(3):
        out[i] = qpos[i]
        out[3 + i] = qvel[i]
    if nq > 0.0 or nqd > 0.0:
        for i in range(3):
            out[i] += nq * gaussian(seed, rollout_ids[r], step, i)
            out[3 + i] += nqd * gaussian(seed, rollout_ids[r], step, 3 + i)


@njit(cache=True)
def _record(r, k, t, q1, q2, q3, d1, d2, d3, t2, t3, mode, rec_t, rec_q, rec_qd, rec_tau, rec_mode):
    rec_t[r, k] = t
    rec_q[r, k, 0], rec_q[r, k, 1], rec_q[r, k, 2] = q1, q2, q3
    rec_qd[r, k, 0], rec_qd[r, k, 1], rec_qd[r, k, 2] = d1, d2, d3
    rec_tau[r, k, 0], rec_tau[r, k, 1] = t2, t3
    rec_mode[r, k] = mode


@njit(cache=True)
def actuate(r, step, dt, mode, tau_cmd, ctrl, qpos, qvel, setup, cert, delay_line, istate, fstate, rollout_ids, seed,
            every, rec_t, rec_q, rec_qd, rec_tau, rec_mode, retire):
    """Turn the controller's torque into ``ctrl``, account for it, record; returns True to stop here."""
    st = istate[r]
    fs = fstate[r]
    t2, t3 = tau_cmd[0], tau_cmd[1]
    bad_torque = not (math.isfinite(t2) and math.isfinite(t3))
    if bad_torque:
        t2, t3 = 0.0, 0.0
    delay = int(setup[r, S_DELAY])
    if delay > 0:
        slot = step % (delay + 1)
        delay_line[r, slot, 0], delay_line[r, slot, 1] = t2, t3
        if step < delay:
            t2, t3 = 0.0, 0.0
        else:
            back = (step - delay) % (delay + 1)
            t2, t3 = delay_line[r, back, 0], delay_line[r, back, 1]
    noise = setup[r, S_TAU_NOISE]
    if noise > 0.0:
        t2 += noise * gaussian(seed, rollout_ids[r], step, 6)
        t3 += noise * gaussian(seed, rollout_ids[r], step, 7)
    lim2, lim3 = setup[r, S_LIMIT2], setup[r, S_LIMIT3]
    t2 = min(max(t2, -lim2), lim2)
    t3 = min(max(t3, -lim3), lim3)
    ctrl[0], ctrl[1] = t2, t3
    st[I_MODE] = mode
    if mode == 1 and st[I_SWITCH] < 0:
        st[I_SWITCH] = step
    q1, q2, q3, d1, d2, d3 = qpos[0], qpos[1], qpos[2], qvel[0], qvel[1], qvel[2]
    inside = inside_region(q1, q2, q3, d1, d2, d3)
    if st[I_REGION] < 0 and inside:
        st[I_REGION] = step
    if not inside:  # the success window (:func:`~paa_mj.control.region.succeeded`) starts after the last exit
        st[I_LEFT_GOAL] = step
    x1, x2, x3 = udd_error_components(q1, q2, q3)
    if max(abs(x1), abs(x2), abs(x3), abs(d1), abs(d2), abs(d3)) >= BALANCE_TOL:
        st[I_OUTSIDE] = step
    fs[F_TAU2] = max(fs[F_TAU2], abs(t2))
    fs[F_TAU3] = max(fs[F_TAU3], abs(t3))
    fs[F_SPEED] = max(fs[F_SPEED], abs(d1), abs(d2), abs(d3))
    fs[F_Q1], fs[F_Q2], fs[F_Q3], fs[F_D1], fs[F_D2], fs[F_D3] = q1, q2, q3, d1, d2, d3
    if step > 0:
        fs[F_SMOOTH] += ((t2 - fs[F_PREV2]) ** 2 + (t3 - fs[F_PREV3]) ** 2) / (dt * dt)
    fs[F_PREV2], fs[F_PREV3] = t2, t3
    if every > 0 and step % every == 0:
        _record(r, st[I_SAMPLES], step * dt, q1, q2, q3, d1, d2, d3, t2, t3, mode, rec_t, rec_q, rec_qd, rec_tau,
                rec_mode)
        st[I_SAMPLES] += 1
    if bad_torque:
        st[I_STATUS] = NONFINITE_TORQUE
        return True
    level = setup[r, S_LEVEL]
    if retire and mode == 1 and level > 0.0 and step * dt > setup[r, S_PUSH_END] and \
            modal_bound(cert[r], x1, x2, x3, d1, d2, d3) <= level:
        st[I_STATUS] = RETIRED
        return True
    return False


@njit(cache=True)
def modal_bound(cert, x1, x2, x3, d1, d2, d3):
    """:math:`\\max_i \\sum_m |c_m| |v_{m,i}|` with :math:`c = V^{-1} x`: a bound on every future :math:`|x_i|` of the sampled linear loop."""
    x = (x1, x2, x3, d1, d2, d3)
    bound = 0.0
    amplitude = np.empty(6)
    for m in range(6):
        re, im = 0.0, 0.0
        for j in range(6):
            re += cert[6 * m + j] * x[j]
            im += cert[36 + 6 * m + j] * x[j]
        amplitude[m] = math.sqrt(re * re + im * im)
    for i in range(6):
        total = 0.0
        for m in range(6):
            total += amplitude[m] * cert[72 + 6 * i + m]
        bound = max(bound, total)
    return bound


@njit(cache=True)
def _record_last(r, step, dt, every, istate, fstate, rec_t, rec_q, rec_qd, rec_tau, rec_mode):
    """A stopped rollout's last good state as its last sample, unless the grid already holds it."""
    st = istate[r]
    fs = fstate[r]
    if every > 0 and step % every != 0:
        _record(r, st[I_SAMPLES], step * dt, fs[F_Q1], fs[F_Q2], fs[F_Q3], fs[F_D1], fs[F_D2], fs[F_D3],
                fs[F_PREV2], fs[F_PREV3], st[I_MODE], rec_t, rec_q, rec_qd, rec_tau, rec_mode)
        st[I_SAMPLES] += 1


@njit(cache=True)
def apply_pushes(r, t, pushes, qfrc):
    """Generalized forces of the rollout's pushes at time t into ``qfrc`` [N m]."""
    qfrc[0], qfrc[1], qfrc[2] = 0.0, 0.0, 0.0
    for k in range(pushes.shape[1]):
        sigma = pushes[r, k, 1]
        if sigma <= 0.0:
            continue
        u = (t - pushes[r, k, 0]) / sigma
        if abs(u) < 4.0:
            w = math.exp(-0.5 * u * u)
            for j in range(3):
                qfrc[j] += w * pushes[r, k, 2 + j]


@njit(cache=True)
def check_state(qpos, qvel, warnings):
    """RUNNING, or why the state left the finite world."""
    for i in range(3):
        if not (math.isfinite(qpos[i]) and math.isfinite(qvel[i])):
            return NONFINITE_STATE
    for i in range(3):
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
    if actuate(r, step, dt, mode, tau_cmd, ctrl, qpos, qvel, setup, cert, delay_line, istate, fstate, rollout_ids,
               seed, every, rec_t, rec_q, rec_qd, rec_tau, rec_mode, retire):
        _record_last(r, step, dt, every, istate, fstate, rec_t, rec_q, rec_qd, rec_tau, rec_mode)
        return True
    if step == n_steps:
        st[I_STATUS] = FINISHED
        return True
    if pushes.shape[1] > 0:
        apply_pushes(r, step * dt, pushes, qfrc)
    _mj_step(model_ptr, data_ptr)
    fs = fstate[r]
    fs[F_INT_TAU2] += (ctrl[0] * ctrl[0] + ctrl[1] * ctrl[1]) * dt
    fs[F_WORK] += abs(ctrl[0] * qvel[1] + ctrl[1] * qvel[2]) * dt
    status = check_state(qpos, qvel, warnings)
    if status != RUNNING:
        st[I_STATUS] = status
        qpos[0], qpos[1], qpos[2] = fs[F_Q1], fs[F_Q2], fs[F_Q3]
        qvel[0], qvel[1], qvel[2] = fs[F_D1], fs[F_D2], fs[F_D3]
        _record_last(r, step, dt, every, istate, fstate, rec_t, rec_q, rec_qd, rec_tau, rec_mode)
        return True
    st[I_STEP] = step + 1
    return False


@njit(nogil=True, cache=True)
def start_rollout(r, model_ptr, data_ptr, qpos, qvel, x0, istate, fstate, memory, memory0, delay_line):
    """Reset the data to x0 and the rollout's state to its start."""
    _mj_reset(model_ptr, data_ptr)
    for i in range(3):
        qpos[i] = x0[r, i]
        qvel[i] = x0[r, 3 + i]
    istate[r, :] = 0
    istate[r, I_SWITCH] = -1
    istate[r, I_REGION] = -1
    istate[r, I_OUTSIDE] = -1
    istate[r, I_LEFT_GOAL] = -1
    fstate[r, :] = 0.0
    for i in range(3):
        fstate[r, F_Q1 + i] = x0[r, i]
        fstate[r, F_D1 + i] = x0[r, 3 + i]
    memory[r, :] = memory0
    delay_line[r, :, :] = 0.0


@kernel
def _never(q1, q2, q3, d1, d2, d3, t, params, memory, tau):
    return 0


@njit(cache=True)
def call_controller(first, second, condition, q1, q2, q3, d1, d2, d3, t, params, memory, tau):
    """One evaluation of a packed controller (see :func:`pack`): ``first`` until ``condition`` first holds,
    then ``second`` for good; returns the mode of the controller that acted."""
    n1, n2, s1, s2 = int(params[0]), int(params[1]), int(params[2]), int(params[3])
    if memory[0] == 0.0 and condition(q1, q2, q3, d1, d2, d3, t, params[4 + n1 + n2:], memory[:1], tau) != 0:
        memory[0] = 1.0
    if memory[0] != 0.0:
        return second(q1, q2, q3, d1, d2, d3, t, params[4 + n1:4 + n1 + n2], memory[1 + s1:1 + s1 + s2], tau)
    return first(q1, q2, q3, d1, d2, d3, t, params[4:4 + n1], memory[1:1 + s1], tau)


_ADVANCE_SIG = types.int64(
    KERNEL_TYPE, KERNEL_TYPE, KERNEL_TYPE, types.int64, types.int64, types.float64[:], types.intp, types.intp,
    types.float64[:], types.float64[:], types.float64[:], types.float64[:], types.int32[:], types.float64,
    types.int64, types.int64, types.boolean, types.float64[:, :], types.float64[:, :], types.float64[:, :, :],
    types.float64[:, :], types.float64[:, :, :], types.int64[:, :], types.float64[:, :], types.int64[:], types.int64,
    types.float64[:, :], types.float64[:, :, :], types.float64[:, :, :], types.float64[:, :, :], types.int8[:, :])


@njit(_ADVANCE_SIG, nogil=True, cache=True)
def advance_compiled(first, second, condition, r, step_to, params, model_ptr, data_ptr, qpos, qvel, ctrl, qfrc,
                     warnings, dt, n_steps, every, retire, setup, cert, pushes, memory, delay_line, istate, fstate,
                     rollout_ids, seed, rec_t, rec_q, rec_qd, rec_tau, rec_mode):
    """Run rollout ``r`` with a compiled controller from its current step through ``step_to``."""
    seen = np.empty(6)
    tau = np.empty(2)
    st = istate[r]
    mem = memory[r]
    while st[I_STATUS] == RUNNING and st[I_STEP] <= step_to:
        step = st[I_STEP]
        measure(r, step, qpos, qvel, setup, rollout_ids, seed, seen)
        mode = call_controller(first, second, condition, seen[0], seen[1], seen[2], seen[3], seen[4], seen[5],
                               step * dt, params, mem, tau)
        if finish_step(r, step, mode, tau, model_ptr, data_ptr, qpos, qvel, ctrl, qfrc, warnings, dt, n_steps, every,
                       retire, setup, cert, pushes, delay_line, istate, fstate, rollout_ids, seed,
                       rec_t, rec_q, rec_qd, rec_tau, rec_mode):
            break
    return st[I_STATUS]


@njit(types.int64(KERNEL_TYPE, KERNEL_TYPE, KERNEL_TYPE, *(types.float64,) * 7, types.float64[:], types.float64[:],
                   types.float64[:]), cache=True)
def evaluate_once(first, second, condition, q1, q2, q3, d1, d2, d3, t, params, memory, tau):
    """:func:`call_controller` with a fixed signature, so that calls from Python compile once."""
    return call_controller(first, second, condition, q1, q2, q3, d1, d2, d3, t, params, memory, tau)


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
    """Torques [tau2, tau3] and modes of a compiled form at states (N, 3), (N, 3), from ``memory`` (default: initial)."""
    packed = pack(form)
    q, qd = np.atleast_2d(np.asarray(q, float)), np.atleast_2d(np.asarray(qd, float))
    tau, modes = np.empty((len(q), 2)), np.empty(len(q), np.int64)
    out = np.empty(2)
    for i in range(len(q)):
        mem = (packed.memory if memory is None else np.asarray(memory, float)).copy()
        modes[i] = evaluate_once(packed.first, packed.second, packed.condition, *q[i], *qd[i], float(t),
                                 packed.params, mem, out)
        tau[i] = out
    return tau, modes


# --- the Python side: plans, certificates, threads ----------------------------------------------------

def retirement_certificate(plant, K, dt):
    """(certificate, level) of the retirement rule for ``plant`` under tau = -K x, or (zeros, 0) if none.

    The certificate holds Re V^-1, Im V^-1 and the moduli of V (row by row) for the
    eigenvectors V of the closed loop Phi = Ad - Bd K of the plant linearised at
    UDD and sampled with zero-order hold at ``dt``; ``level`` =
    :data:`RETIRE_FRACTION` x BALANCE_TOL.
    """
    from ..theory.linear import sampled_closed_loop

    none = np.zeros(N_CERT), 0.0
    if K is None:
        return none
    phi = sampled_closed_loop(plant, K, dt)
    if not np.all(np.isfinite(phi)):
        return none
    eigenvalues, vectors = np.linalg.eig(phi)
    if np.max(np.abs(eigenvalues)) >= 1.0 or np.linalg.cond(vectors) > 1e8:
        return none
    inverse = np.linalg.inv(vectors)
    cert = np.concatenate([inverse.real.reshape(-1), inverse.imag.reshape(-1), np.abs(vectors).reshape(-1)])
    return cert, RETIRE_FRACTION * BALANCE_TOL


@dataclass
class Plan:
    """What to run: N rollouts of one time step and length on one or more plant models.

    Attributes
    ----------
    models : list of mujoco.MjModel
        The distinct plants (same sizes, time step and integrator).
    model_index : ndarray (N,) of int
        Which plant each rollout runs on.
    x0 : ndarray (N, 6)
        Initial states [q1, q2, q3, d1, d2, d3].
    setup : ndarray (N, N_SETUP)
        Torque limits, noise levels, delay, retirement level, end of the pushes.
    cert : ndarray (N, N_CERT)
        The retirement certificate of each rollout (:func:`retirement_certificate`).
    pushes : ndarray (N, K, 5)
        Pushes (t_center [s], sigma [s], f1, f2, f3 [N m]); K may be 0.
    rollout_ids : ndarray (N,) of int
        Global rollout numbers: the noise of a rollout depends on (seed, id, step) only.
    seed : int
    dt : float
    n_steps : int
    every : int
        Record a sample every ``every`` steps (0: record nothing).
    retire : bool
        Stop rollouts early by the retirement rule (module docstring).
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

    def __len__(self):
        return len(self.x0)


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
        self.istate = np.zeros((n, N_ISTATE), np.int64)
        self.fstate = np.zeros((n, N_FSTATE))
        self.memory = np.zeros((n, max(1, memory_size)))
        self.delay_line = np.zeros((n, int(np.max(plan.setup[:, S_DELAY], initial=0)) + 1, 2))
        capacity = plan.n_steps // plan.every + 2 if plan.every else 0
        self.rec_t = np.zeros((n, capacity))
        self.rec_q = np.zeros((n, capacity, 3))
        self.rec_qd = np.zeros((n, capacity, 3))
        self.rec_tau = np.zeros((n, capacity, 2))
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
    else of a step runs in :func:`measure` and :func:`finish_step`, their arguments bound once: the
    Python between two physics steps is what a hand-written ``mj_step`` loop would have, and little more.
    """
    rows = [int(r) for r in rows]
    datas = [mujoco.MjData(plan.models[plan.model_index[r]]) for r in rows]
    views = [_data_views(d) for d in datas]
    for r, data in zip(rows, datas):
        arrays.start(plan, r, plan.models[plan.model_index[r]], data, np.zeros(1))
    reset_controller(controller)
    seen = np.zeros((len(rows), 6))
    seen_q, seen_qd = seen[:, :3], seen[:, 3:]
    step_args, state_args = arrays.step_args(plan), arrays.state_args(plan)
    seed, dt, status = int(plan.seed), plan.dt, arrays.istate[:, I_STATUS]
    measure_args = [(r, views[k][0], views[k][1], plan.setup, plan.rollout_ids, seed, seen[k])
                    for k, r in enumerate(rows)]
    step_tails = [(plan.models[plan.model_index[r]]._address, datas[k]._address, *views[k], *step_args,
                   arrays.delay_line, *state_args) for k, r in enumerate(rows)]
    active = list(range(len(rows)))
    batch = (len(rows),)
    try:
        for step in range(plan.n_steps + 1):
            for k in active:
                r, qpos, qvel, setup, ids, seed_, out = measure_args[k]
                measure(r, step, qpos, qvel, setup, ids, seed_, out)
            tau = torque_of(controller, seen_q, seen_qd, step * dt)
            modes = mode_of(controller, batch)
            for k in active:
                finish_step(rows[k], step, int(modes[k]), tau[k], *step_tails[k])
            if step % SEGMENT == 0:
                bar.refresh()
            if any(status[rows[k]] != RUNNING for k in active):
                active = [k for k in active if status[rows[k]] == RUNNING]
                if not active:
                    break
    except KeyboardInterrupt:
        return True
    return False
