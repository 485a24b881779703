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
                          M_NEXT, M_SOLVES, M_T0, M_VALID, MEMORY_HEADER, _clamp, _forward, energy, ilqr, ilqr_steps,
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
# the iLQR iterations a control call gives a restart once the law has made a plan (0: a restart is solved in one call):
# a restart is then spread over calls (:func:`restart_steps`)
H_SPREAD = 31
# the RK4 sub-steps per knot (mpc_kernels.substeps at H_FAST's turn) beyond which a spinning chain is braked, not
# planned for, until it is slower (0: always planned for)
H_SPIN_CAP = 32
# the spread restart's header in its block of the memory (:func:`restart_views`): its stage (0: none; 1 the kept
# plan shifted, 2 the energy-pumping guess, 3 the LQR's, 4 the braking one), whether the stage's guess is made, its
# iterations done, iLQR's regularisation and stop flag, the best cost so far, its start time and knots
R_STAGE, R_INIT, R_ITERS, R_MU, R_STOP, R_BEST, R_T0, R_KNOTS = range(8)
R_HEADER = 8


@njit(cache=True)
def memory_size(n, nu, knots):
    """The law's memory: the plan's (:func:`paa_mj.control.mpc_kernels.memory_size`), then the estimator's
    (:func:`paa_mj.control.mpc_estimator.memory_size`), then the spread restart's (:func:`restart_views`)."""
    return (mk.memory_size(n, nu, knots) + mpc_estimator.memory_size(n, nu) + R_HEADER + 2 * n + nu
            + 2 * mk.plan_size(n, nu, knots))


@njit(cache=True)
def restart_views(params, memory):
    """The spread restart's block of the memory: header (R_*), the state and previous torque it solves from (nx, nu),
    the plan being solved (X, U, K) and the best plan so far (X, U, K), each of the restart's knots (R_KNOTS) in room
    for the longest plan."""
    n, nu = int(params[H_N]), int(params[H_NU])
    nx = 2 * n
    room = plan_knots(params)
    a = mk.memory_size(n, nu, room) + mpc_estimator.memory_size(n, nu)
    head = chain.vector_view(memory, a, R_HEADER)
    a += R_HEADER
    knots = max(int(head[R_KNOTS]), 1)
    x0 = chain.vector_view(memory, a, nx)
    a += nx
    u0 = chain.vector_view(memory, a, nu)
    a += nu
    Xc, Uc, Kc = _plan_at(memory, a, knots, room, nx, nu)
    Xb, Ub, Kb = _plan_at(memory, a + mk.plan_size(n, nu, room), knots, room, nx, nu)
    return head, x0, u0, Xc, Uc, Kc, Xb, Ub, Kb


@njit(cache=True)
def _plan_at(memory, a, knots, room, nx, nu):
    """The views X (N + 1, nx), U (N, nu), K (N, nu, nx + nu) of a plan of ``knots`` knots stored from memory[a] in
    room for ``room`` knots (:func:`~paa_mj.control.mpc_kernels.plan_size`)."""
    X = chain.matrix_view(memory, a, knots + 1, nx)
    a += (room + 1) * nx
    U = chain.matrix_view(memory, a, knots, nu)
    a += room * nu
    K = np.ascontiguousarray(memory[a:a + knots * nu * (nx + nu)]).reshape((knots, nu, nx + nu))
    return X, U, K


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
def _fresh_guess(params, model, x, guess, U, X):
    """Fresh first guess number ``guess`` from x into U, X, in the order a restart tries them: 0 the energy-pumping
    guess, 1 the clamped LQR's, 2 on a spinning chain (E - E* > respin) the braking guess; returns False where there
    is no such guess."""
    if guess == 0:
        pump_guess(params, model, x, U, X, params[H_PUMP], params[H_PUMP_KP], params[H_PUMP_KD])
    elif guess == 1:
        lqr_guess(params, model, x, U, X)
    elif guess == 2 and params[H_BRAKE] > 0.0 and energy(model, x) - params[H_E_GOAL] > params[H_RESPIN]:
        pump_guess(params, model, x, U, X, 0.0, 0.0, params[H_BRAKE] * params[H_PUMP_KD])
    else:
        return False
    return True


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
    X, U, K = _plan_at(memory, a + nu, knots, room, nx, nu)
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
    _shifted_guess(params, model, x, t, memory, Ug, Xg, Kg)
    uprev = plan_views(params, memory)[0]
    return ilqr(params, model, x, uprev, Ug, Xg, Kg, iterations)


@njit(cache=True)
def _shifted_guess(params, model, x, t, memory, Ug, Xg, Kg):
    """:func:`_shifted_solve`'s first guess, into Ug, Xg, Kg."""
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
    spread = int(params[H_SPREAD]) if memory[M_SOLVES] > 0.0 else 0
    if restart and spread > 0:
        _begin_restart(params, model, x, t, memory, 1 if valid else 2, spread)
        return
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
        elif spread > 0:  # the kept plan ran away: it is dropped, and a restart from the guesses spread
            memory[M_VALID] = 0.0
            _begin_restart(params, model, x, t, memory, 2, max(spread - int(params[H_ITERS]), 0))
            return
    if restart or best == math.inf:
        memory[M_COLD] = t
        for guess in range(3):
            if not _fresh_guess(params, model, x, guess, Ug, Xg):
                break
            cost = ilqr(params, model, x, uprev, Ug, Xg, Kg, int(params[H_ITERS_COLD]))
            if cost < best:
                best = cost
                U[:, :] = Ug
                X[:, :] = Xg
                K[:, :, :] = Kg
    _kept(memory, ustart, uprev, knots, t, best)
    memory[M_NEXT] = t + params[H_PERIOD]
    memory[M_SOLVES] += 1.0


@njit(cache=True)
def _begin_restart(params, model, x, t, memory, stage, budget):
    """Start a restart spread over calls from x at t (stage 1: from the kept plan shifted, then the guesses; 2: the
    guesses only) and give it ``budget`` iterations now (:func:`restart_steps`)."""
    uprev = plan_views(params, memory)[0]
    head = restart_views(params, memory)[0]
    head[R_KNOTS] = climb_knots(params, model, x)
    head[R_STAGE] = stage
    head[R_INIT] = 0.0
    head[R_BEST] = math.inf
    head[R_T0] = t
    views = restart_views(params, memory)
    views[1][:] = x
    views[2][:] = uprev
    memory[M_COLD] = t
    restart_steps(params, t, memory, budget)


@njit(cache=True)
def restart_steps(params, t, memory, budget):
    """Carry the restart in progress on by at most ``budget`` iLQR iterations at time t: :func:`replan`'s restart
    (from x0 at t0: the kept plan shifted, the energy-pumping guess, the LQR's and, on a spinning chain, the braking
    one, each improved by cold_iterations, the cheapest kept), one stage after another, iLQR resumed where the last
    call left it (:func:`~paa_mj.control.mpc_kernels.ilqr_steps`: the plans one call would make); when the last stage
    is done, the best plan becomes the kept one (made at t0, followed from t)."""
    head, x0, u0, Xc, Uc, Kc, Xb, Ub, Kb = restart_views(params, memory)
    knots = int(head[R_KNOTS])
    if knots != int(params[H_KNOTS]):
        params = _climb_weights(params)
    model = unpack(params)
    params = _fast(params, x0)
    iters = int(params[H_ITERS_COLD])
    state = np.empty(2)
    while head[R_STAGE] > 0.0 and (budget > 0 or head[R_INIT] == 0.0):
        stage = int(head[R_STAGE])
        if head[R_INIT] == 0.0:
            if stage == 1:
                _shifted_guess(params, model, x0, head[R_T0], memory, Uc, Xc, Kc)
            elif not _fresh_guess(params, model, x0, stage - 2, Uc, Xc):
                _adopt(params, t, memory)
                return
            head[R_INIT], head[R_ITERS], head[R_MU], head[R_STOP] = 1.0, 0.0, 1e-6, 0.0
            if budget <= 0:
                return
        step_iters = min(budget, iters - int(head[R_ITERS]))
        state[0], state[1] = head[R_MU], head[R_STOP]
        cost = ilqr_steps(params, model, x0, u0, Uc, Xc, Kc, step_iters, state)
        head[R_MU], head[R_STOP] = state[0], state[1]
        head[R_ITERS] += step_iters
        budget -= step_iters
        if head[R_STOP] != 0.0 or head[R_ITERS] >= iters:
            if cost < head[R_BEST]:
                head[R_BEST] = cost
                Xb[:, :] = Xc
                Ub[:, :] = Uc
                Kb[:, :, :] = Kc
                _keep(params, memory)
            head[R_STAGE] = stage + 1.0
            head[R_INIT] = 0.0


@njit(cache=True)
def _adopt(params, t, memory):
    """The spread restart's best plan (none finite: the brake until the next solve) becomes the kept plan, made at its
    start t0; the next solve one period after t."""
    _keep(params, memory)
    restart_views(params, memory)[0][R_STAGE] = 0.0
    memory[M_NEXT] = t + params[H_PERIOD]
    memory[M_SOLVES] += 1.0


@njit(cache=True)
def _keep(params, memory):
    """The spread restart's best plan so far becomes the kept plan (none finite: the brake)."""
    head, x0, u0, Xc, Uc, Kc, Xb, Ub, Kb = restart_views(params, memory)
    knots = int(head[R_KNOTS])
    best = head[R_BEST]
    uprev, ustart, X, U, K = _plan_block(params, memory, knots)
    if best < math.inf:
        X[:, :] = Xb
        U[:, :] = Ub
        K[:, :, :] = Kb
    _kept(memory, ustart, u0, knots, head[R_T0], best)


@njit(cache=True)
def _kept(memory, ustart, u0, knots, t0, best):
    """The plan of ``knots`` knots just written into the plan's block (cost ``best``; none finite: inf, and the law
    brakes until the next solve) is the kept one, made at t0 with the torque u0 applied."""
    ustart[:] = u0
    memory[M_KNOTS] = knots
    memory[M_T0] = t0
    memory[M_BRAKE] = 1.0 if best == math.inf else 0.0
    memory[M_VALID] = 0.0 if best == math.inf else 1.0
    memory[M_COST] = best


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
        restart_views(params, memory)[0][R_STAGE] = 0.0
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
def _too_fast(params, x):
    """Whether x spins a link so fast that a plan's knots would take more than H_SPIN_CAP RK4 sub-steps of H_FAST rad
    (a chain spun beyond what the motors can brake in a horizon, where every solve would cost tens of them)."""
    cap = params[H_SPIN_CAP]
    if cap <= 0.0 or params[H_FAST] <= 0.0:
        return False
    return mk.fastest_rate(x) * params[H_STEP] > cap * params[H_FAST]


@njit(cache=True)
def _interim(params, model, x, tau):
    """The torque while a spread restart proceeds without a plan to follow: the LQR's where its cost-to-go is below
    twice rho_out (the chain just left its region), else the energy-pumping guess's law."""
    if lqr_cost(model, x) < 2.0 * params[H_RHO_OUT]:
        lqr_torque(model, x, tau)
    else:
        pump_torque(params, model, x, params[H_PUMP], params[H_PUMP_KP], params[H_PUMP_KD], tau)


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
    restarting = restart_views(params, memory)[0]
    if mode == 1.0:
        lqr_torque(model, x, tau)
        for j in range(nu):
            uprev[j] = tau[j]
        memory[M_VALID] = 0.0
        memory[M_BRAKE] = 0.0
        restarting[R_STAGE] = 0.0
        return 1
    if (restarting[R_STAGE] > 0.0 or (memory[M_VALID] == 0.0 and memory[M_BRAKE] == 0.0)
            or t >= memory[M_NEXT] - 1e-9) and _too_fast(params, x):
        restarting[R_STAGE] = 0.0
        memory[M_VALID] = 0.0
        memory[M_BRAKE] = 1.0
        memory[M_NEXT] = t + params[H_PERIOD]
    elif restarting[R_STAGE] > 0.0:
        restart_steps(params, t, memory, int(params[H_SPREAD]))
    elif (memory[M_VALID] == 0.0 and memory[M_BRAKE] == 0.0) or t >= memory[M_NEXT] - 1e-9:
        replan(params, model, x, t, memory)
    if restarting[R_STAGE] > 0.0 and memory[M_VALID] == 0.0:
        _interim(params, model, x, tau)
        uprev[:] = tau
        return 0
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
