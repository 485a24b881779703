r"""The compiled law of :mod:`paa_mj.control.mpc`: the plan it keeps, its first guesses, when it solves again, the LQR
hand-over. The solver (iLQR over the chain's RK4 knots) is :mod:`paa_mj.control.mpc_kernels`; the state estimator
in front of the law is :mod:`paa_mj.control.mpc_estimator`.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..model import chain
from ..model.states import wrap
from .mpc_kernels import (H_CLIMB_KNOTS, H_E_GOAL, H_ITERS, H_ITERS_COLD, H_KNOTS, H_N, H_NU, H_PERIOD, H_PUMP,
                          H_PUMP_KD, H_PUMP_KP, H_RESTART, H_RHO_IN, H_RHO_OUT, H_STEP, H_TURN, M_CALL, M_COST, M_MODE,
                          M_NEXT, M_SOLVES, M_T0, M_VALID, MEMORY_HEADER, _clamp, _forward, energy, ilqr,
                          lqr_cost, lqr_torque, offsets, plan_knots, scratch, step, substeps, unpack)
from . import mpc_kernels as mk
from . import mpc_estimator
from .mpc_estimator import E_VALID, H_ESTIMATE, estimate, estimator_views, remember_torque

# the energy above the goal's [J] beyond which a plan is solved afresh every 5 periods (0: never)
H_RESPIN = 22
# the braking guess's gain in units of pump_kd (0: none)
H_BRAKE = 24
# the turn per knot [rad] of a link at a solve's state beyond which that solve's knots take RK4 sub-steps of at most
# that turn (mpc_kernels.H_TURN in its copy of the parameters; 0: never)
H_FAST = 15
# the climb's plans (mpc_kernels.H_CLIMB_KNOTS knots, :func:`climb_knots`): the energy [J] below which a plan started
# afresh is one, and the factors on the weights w_speed, r and r_rate its solves take
H_CLIMB_ENERGY, H_CLIMB_R, H_CLIMB_RATE, H_CLIMB_SPEED = 27, 28, 29, 30
# the memory's slots of the time of the last fresh solve, and of the flag "no finite plan: brake until the next solve"
M_COLD, M_BRAKE = MEMORY_HEADER - 1, MEMORY_HEADER - 2
# the memory's slot of the kept plan's knots (0: the horizon's, H_KNOTS)
M_KNOTS = MEMORY_HEADER - 3
# the memory's slot of the interval between the law's last two calls [s] (mpc_kernels.M_CALL: the last call's time)
M_HOLD = MEMORY_HEADER - 4


@njit(cache=True)
def memory_size(n, nu, knots):
    """The law's memory: the plan's (:func:`paa_mj.control.mpc_kernels.memory_size`), then the estimator's
    (:func:`paa_mj.control.mpc_estimator.memory_size`)."""
    return mk.memory_size(n, nu, knots) + mpc_estimator.memory_size(n, nu)


@njit(cache=True)
def pump_torque(params, model, x, ke, kp, kd, u):
    """u_j = k_e (E* - E) qd_a - k_p wrap(q_a - q*_a) - k_d qd_a (clamped) for motor j on joint a, into u: the
    energy-pumping law; with k_e = k_p = 0 the brake (power -k_d qd_a^2 into the chain from each motor)."""
    goal, umax, drive = model[4], model[5], model[12]
    n = goal.size
    gap = params[H_E_GOAL] - energy(model, x) if ke != 0.0 else 0.0
    for a in range(n):
        j = int(drive[a])
        if j >= 0:
            qd = x[n + a]
            u[j] = _clamp(ke * gap * qd - kp * wrap(x[a] - goal[a]) - kd * qd, umax[j])


@njit(cache=True)
def pump_guess(params, model, x0, U, X, ke, kp, kd):
    """A first guess from far away: :func:`pump_torque` with (ke, kp, kd) rolled out on the model into U, X (the
    energy-pumping guess with the options pump, pump_kp, pump_kd; the braking guess with (0, 0, k_b))."""
    n = x0.size // 2
    h = params[H_STEP]
    ws = scratch(n)
    X[0] = x0
    for k in range(U.shape[0]):
        pump_torque(params, model, X[k], ke, kp, kd, U[k])
        step(params, X[k], U[k], h, X[k + 1], ws)


@njit(cache=True, inline="always")
def lqr_guess(params, model, x0, U, X):
    """A first guess near the goal: the clamped LQR tau = -K e rolled out on the model into U, X."""
    n = x0.size // 2
    h = params[H_STEP]
    ws = scratch(n)
    X[0] = x0
    for k in range(U.shape[0]):
        lqr_torque(model, X[k], U[k])
        step(params, X[k], U[k], h, X[k + 1], ws)


@njit(cache=True)
def plan_views(params, memory):
    """The plan kept in the memory: last torque (nu), the torque applied when the plan was made (nu), X (N + 1, nx),
    U (N, nu), K (N, nu, nx + nu), N its knots (M_KNOTS: the horizon's, or the climb's)."""
    knots = int(memory[M_KNOTS])
    return _plan_block(params, memory, knots if knots > 0 else int(params[H_KNOTS]))


@njit(cache=True)
def _plan_block(params, memory, knots):
    """:func:`plan_views` for a plan of ``knots`` knots, in the memory's room for the longest
    (:func:`~paa_mj.control.mpc_kernels.plan_knots`)."""
    n, nu = int(params[H_N]), int(params[H_NU])
    nx = 2 * n
    room = plan_knots(params)
    a = MEMORY_HEADER
    uprev = chain.vector_view(memory, a, nu)
    a += nu
    ustart = chain.vector_view(memory, a, nu)
    a += nu
    X = chain.matrix_view(memory, a, knots + 1, nx)
    a += (room + 1) * nx
    U = chain.matrix_view(memory, a, knots, nu)
    a += room * nu
    K = np.ascontiguousarray(memory[a:a + knots * nu * (nx + nu)]).reshape((knots, nu, nx + nu))
    return uprev, ustart, X, U, K


@njit(cache=True)
def climb_knots(params, model, x):
    """The knots of a plan started afresh from x: the climb's (H_CLIMB_KNOTS) where x's energy is below
    H_CLIMB_ENERGY (a chain far below the goal's energy, at rest near hanging: there a longer plan finds the slower,
    cheaper swing that first swings back), else the horizon's (H_KNOTS); 0 climb knots: never."""
    climb = int(params[H_CLIMB_KNOTS])
    if climb > 0 and energy(model, x) < params[H_CLIMB_ENERGY]:
        return climb
    return int(params[H_KNOTS])


@njit(cache=True)
def _climb_weights(params):
    """The parameters a climb's solves plan with: the weights w_speed, r and r_rate times H_CLIMB_SPEED, H_CLIMB_R and
    H_CLIMB_RATE."""
    n, nu = int(params[H_N]), int(params[H_NU])
    o = offsets(n, nu)
    climb = params.copy()
    for i in range(n):
        climb[o[8] + i] *= params[H_CLIMB_SPEED]
    for j in range(nu):
        climb[o[9] + j] *= params[H_CLIMB_R]
        climb[o[10] + j] *= params[H_CLIMB_RATE]
    return climb


@njit(cache=True)
def _plan_state(X, s, out):
    """The plan's state at knot position s (linear between knots, held at the ends), angles as planned."""
    last = X.shape[0] - 1
    if s <= 0.0:
        out[:] = X[0]
        return
    if s >= last:
        out[:] = X[last]
        return
    i = int(s)
    w = s - i
    for j in range(X.shape[1]):
        out[j] = (1.0 - w) * X[i, j] + w * X[i + 1, j]


@njit(cache=True)
def _plan_torque(U, s, j, start):
    """The plan's torque j at knot position s, linear between the knots' midpoints (so that each knot's mean
    torque is kept), from ``start`` (the torque applied when the plan was made: no step at a new plan) at s = 0 to
    the first midpoint, held at the end."""
    last = U.shape[0] - 1
    p = s - 0.5
    if p <= 0.0:
        w = min(max(2.0 * s, 0.0), 1.0)
        return (1.0 - w) * start + w * U[0, j]
    if p >= last:
        return U[last, j]
    i = int(p)
    w = p - i
    return (1.0 - w) * U[i, j] + w * U[i + 1, j]


@njit(cache=True, inline="always")
def _far(params, model, x, t, memory):
    """Whether the state is far from where the kept plan put it at t (a push, a reset), or is a spinning chain with
    energy to spare at a time to solve afresh (every 5 periods while E - E* > respin: the kept plan, followed from a
    spin, tends to keep spinning, and the energy-pumping guess brakes)."""
    n = x.size // 2
    uprev, ustart, X, U, K = plan_views(params, memory)
    predicted = np.empty(x.size)
    _plan_state(X, (t - memory[M_T0]) / params[H_STEP], predicted)
    gap = 0.0
    for j in range(x.size):  # speeds count a tenth: a noisy speed is no reason to start again
        d = wrap(x[j] - predicted[j]) if j < n else 0.1 * (x[j] - predicted[j])
        gap += d * d
    if gap > params[H_RESTART] ** 2:
        return True
    if params[H_RESPIN] > 0.0 and t - memory[M_COLD] >= 5.0 * params[H_PERIOD] - 1e-9:
        return energy(model, x) - params[H_E_GOAL] > params[H_RESPIN]
    return False


@njit(cache=True, inline="always")
def _shifted_solve(params, model, x, t, memory, Ug, Xg, Kg, iterations):
    """iLQR from the kept plan shifted to t and followed from x with its own feedback (an open-loop shift of a swing
    diverges), into Ug, Xg, Kg; returns its cost (inf where it runs away)."""
    n = x.size // 2
    knots, nu = Ug.shape
    uprev, ustart, X, U, K = plan_views(params, memory)
    s = (t - memory[M_T0]) / params[H_STEP]
    Xs = np.empty((knots + 1, x.size))
    Us = np.empty((knots, nu))
    for k in range(knots + 1):
        _plan_state(X, s + k, Xs[k])
    for k in range(knots):
        for j in range(nu):
            Us[k, j] = _plan_torque(U, s + k + 0.5, j, ustart[j])
        Kg[k] = K[min(max(int(s + k + 0.5), 0), K.shape[0] - 1)]
    _forward(params, model, x, uprev, Xs, Us, np.zeros((knots, nu)), Kg, 0.0, Xg, Ug, scratch(n))
    return ilqr(params, model, x, uprev, Ug, Xg, Kg, iterations)


@njit(cache=True, inline="always")
def _fast(params, x):
    """The parameters a solve from x plans with: with RK4 sub-steps (mpc_kernels.substeps) where x spins a link more
    than H_FAST rad per knot (a chain spun past its knots, where RK4 runs away; slower solves keep one step per knot,
    so that the swing from hanging is planned as before)."""
    if params[H_FAST] <= 0.0:
        return params
    fast = params.copy()
    fast[H_TURN] = params[H_FAST]
    return fast if substeps(fast, x, params[H_STEP]) > 1 else params


@njit(cache=True, inline="always")
def replan(params, model, x, t, memory):
    """Solve the plan again from the measured x at time t, warm-started from the kept plan shifted to t (and, when
    :func:`_far` or there is no plan, from the energy-pumping guess, from the clamped LQR's rollout and, on a
    spinning chain, from the braking guess: the cheapest after iLQR is kept; from zero torque iLQR finds spinning
    minima). A plan whose rollout is not finite (RK4 knots on a chain spun past them) is never kept: where none is
    finite the kept plan is dropped and the law brakes (M_BRAKE) until the next solve, which starts afresh. A solve from
    a fast state plans with RK4 sub-steps (:func:`_fast`). A plan started afresh takes its knots by
    :func:`climb_knots` (a climb's solves with its weights, :func:`_climb_weights`); the kept plan's solves keep
    its knots."""
    nu = int(params[H_NU])
    kept = plan_views(params, memory)[3].shape[0]
    valid = memory[M_VALID] != 0.0
    restart = not valid or _far(params, model, x, t, memory)
    knots = climb_knots(params, model, x) if restart else kept
    if knots != int(params[H_KNOTS]):
        params = _climb_weights(params)
        model = unpack(params)
    uprev, ustart, X, U, K = _plan_block(params, memory, knots)
    params = _fast(params, x)
    Ug = np.empty((knots, nu))
    Xg = np.empty((knots + 1, x.size))
    Kg = np.empty((knots, nu, x.size + nu))
    best = math.inf
    if valid:
        best = _shifted_solve(params, model, x, t, memory, Ug, Xg, Kg,
                              int(params[H_ITERS_COLD] if restart else params[H_ITERS]))
        if best < math.inf:
            U[:, :] = Ug
            X[:, :] = Xg
            K[:, :, :] = Kg
    if restart or best == math.inf:
        memory[M_COLD] = t
        spinning = energy(model, x) - params[H_E_GOAL] > params[H_RESPIN]
        for guess in range(3):
            if guess == 0:
                pump_guess(params, model, x, Ug, Xg, params[H_PUMP], params[H_PUMP_KP], params[H_PUMP_KD])
            elif guess == 1:
                lqr_guess(params, model, x, Ug, Xg)
            elif params[H_BRAKE] > 0.0 and spinning:
                pump_guess(params, model, x, Ug, Xg, 0.0, 0.0, params[H_BRAKE] * params[H_PUMP_KD])
            else:
                break
            cost = ilqr(params, model, x, uprev, Ug, Xg, Kg, int(params[H_ITERS_COLD]))
            if cost < best:
                best = cost
                U[:, :] = Ug
                X[:, :] = Xg
                K[:, :, :] = Kg
    ustart[:] = uprev
    memory[M_KNOTS] = knots
    memory[M_T0] = t
    memory[M_NEXT] = t + params[H_PERIOD]
    memory[M_BRAKE] = 1.0 if best == math.inf else 0.0
    memory[M_VALID] = 0.0 if best == math.inf else 1.0
    memory[M_COST] = best
    memory[M_SOLVES] += 1.0


@njit(cache=True, inline="always")
def mpc_torque(params, y, t, memory, tau):
    """The controller's law at one measured state y (nx) and time t into ``tau`` (nu); returns its mode (1: the
    LQR balances, 0: the plan acts). See :mod:`paa_mj.control.mpc`."""
    params = np.ascontiguousarray(params)
    x = np.empty(y.size)
    if params[H_ESTIMATE] != 0.0:
        estimate(params, y, t, memory, x)
    else:
        x[:] = y
    mode = _law(params, x, t, memory, tau)
    if not _finite(tau):
        # the plan (or the estimate) ran away (RK4 knots of a chain spun to hundreds of rad/s): start both afresh from
        # the measurement, and let go of the chain where even that plan is not finite
        memory[M_VALID] = 0.0
        memory[M_BRAKE] = 0.0
        memory[M_MODE] = 0.0
        estimator_views(params, memory, y.size // 2, tau.size)[0][E_VALID] = 0.0
        x[:] = y  # the measurement, in the estimate's array: _law (and the solver) compiled for one layout only
        mode = _law(params, x, t, memory, tau)
        if not _finite(tau):
            memory[M_VALID] = 0.0
            tau[:] = 0.0
    remember_torque(params, memory, tau, y.size // 2)
    memory[M_HOLD] = t - memory[M_CALL]
    memory[M_CALL] = t
    return mode


@njit(cache=True)
def _finite(v):
    for j in range(v.size):
        if not math.isfinite(v[j]):
            return False
    return True


@njit(cache=True)
def _law(params, x, t, memory, tau):
    """:func:`mpc_torque` at the estimated state x."""
    model = unpack(params)
    umax = model[5]
    nx = x.size
    n = nx // 2
    nu = tau.size
    h = params[H_STEP]
    uprev, ustart, X, U, K = plan_views(params, memory)
    cost = lqr_cost(model, x)
    mode = memory[M_MODE]
    if mode == 1.0 and cost > params[H_RHO_OUT]:
        mode = 0.0
        memory[M_VALID] = 0.0
    elif mode == 0.0 and cost < params[H_RHO_IN]:
        mode = 1.0
    memory[M_MODE] = mode
    if mode == 1.0:
        lqr_torque(model, x, tau)
        for j in range(nu):
            uprev[j] = tau[j]
        memory[M_VALID] = 0.0
        memory[M_BRAKE] = 0.0
        return 1
    if (memory[M_VALID] == 0.0 and memory[M_BRAKE] == 0.0) or t >= memory[M_NEXT] - 1e-9:
        replan(params, model, x, t, memory)
    if memory[M_BRAKE] != 0.0:
        pump_torque(params, model, x, 0.0, 0.0, max(params[H_BRAKE], 1.0) * params[H_PUMP_KD], tau)
        uprev[:] = tau
        return 0
    s = (t - memory[M_T0]) / h
    i = min(max(int(s), 0), U.shape[0] - 1)
    ref = np.empty(nx)
    _plan_state(X, s, ref)
    # a loop that calls fewer than two times a knot (its last two intervals) holds each torque too long for the
    # ramp from the applied torque to show (called once a period, it would hold that torque for ever): it gets the
    # knot's torque, held over the knot as the plan was solved
    coarse = min(t - memory[M_CALL], memory[M_HOLD]) >= 0.5 * h
    for r in range(nu):
        v = U[i, r] if coarse else _plan_torque(U, s, r, ustart[r])
        for j in range(nx):
            d = wrap(x[j] - ref[j]) if j < n else x[j] - ref[j]
            v += K[i, r, j] * d
        tau[r] = _clamp(v, umax[r])
    for j in range(nu):
        uprev[j] = tau[j]
    return 0
