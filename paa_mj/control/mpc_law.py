r"""The compiled law of :mod:`paa_mj.control.mpc`: the plan it keeps, its first guesses, when it solves again, the LQR
hand-over, and the state estimator in front of it. The solver (iLQR over the chain's RK4 knots) is
:mod:`paa_mj.control.mpc_kernels`.

The estimator (:func:`estimate`) turns the measured state y_k = [q, qd] at time t_k into the state the law acts on.
It keeps the torques the law commanded (c_{k-1}, c_{k-2}, ...) and

1. scores each latency of d = 0 .. :data:`LAGS` - 1 control calls by how well the model explains the measured
   angles' second difference with the torque that latency would have applied:

   .. math:: s_d \leftarrow \lambda s_d + \left\| \frac{q_k - 2 q_{k-1} + q_{k-2}}{\Delta t^2}
             - \ddot q\left(q_{k-1}, \frac{q_k - q_{k-2}}{2 \Delta t}, \tfrac12 (c_{k-1-d} + c_{k-2-d})\right)
             \right\|^2, \qquad \lambda = e^{-\Delta t / T_\lambda},

   \ddot q from (1) on the model, over the steps where the best d explains the angles within a torque of g (the
   gate; a push explains nothing of the latency); the latency D is the best-scoring d (switched only on a score
   10 % lower; none is scored with T_\lambda = 0);
2. filters the delayed state: x^- = F_{\Delta t}(\hat x, c_{k-1-D}) (one RK4 step of (1)), then, per joint,

   .. math:: \hat q = q^- + \alpha\, \nu, \qquad
             \hat{\dot q} = \dot q^- + \min(a, \beta)\, \nu / \Delta t + b\, (\dot q_k - \dot q^-), \qquad
             \nu = \mathrm{wrap}(q_k - q^-),

   (\alpha, \beta) the steady-state Kalman gains of an angle measured with noise \sigma whose acceleration the model
   knows to white noise of intensity w (:func:`tracking_gains`, at \lambda = w \Delta t^{3/2} / \sigma); \sigma is
   estimated from the measurements alone (a): exact angles (\sigma = 0) give \alpha = 1, \beta = 2, the angles
   trusted and the speeds corrected by a of the angles' innovation over the step and b of the measured speeds';

   a. each angle's residual r_k = q_k - 2 q_{k-1} + q_{k-2} - \Delta t^2 \ddot q(\hat x_{k-1}, c) (the model's
      second difference over the two steps) is white noise's [1, -2, 1] filter, whose lag-one autocovariance is
      -4 \sigma^2, plus the model's error, whose lag-one autocovariance is >= 0 (smooth) or 0 (white); over a
      running mean of memory T_n (``noise_memory``) \sigma^2 = max(0, -c_1 / 4 - 2 s), s = c_0 / (4 \sqrt N) the
      mean's standard error over N = 2 T_n / \Delta t samples (so that a model error is not taken for noise);
3. predicts over the latency: x = F_{\Delta t}(\cdots F_{\Delta t}(\hat x, c_{k-D}) \cdots, c_{k-1}).

A gap in time (more than :data:`GAP` s since the last call, or time running back) starts the estimate afresh from
the measurement (the latency's scores are kept: the loop's latency is the loop's). Everything it reads is the
measured state, the time and its own past torques.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..model import chain
from ..model.states import wrap
from .mpc_kernels import (H_E_GOAL, H_ITERS, H_ITERS_COLD, H_KNOTS, H_N, H_NU, H_PERIOD, H_PUMP, H_PUMP_KD, H_PUMP_KP,
                          H_RESTART, H_RHO_IN, H_RHO_OUT, H_STEP, H_TURN, M_COST, M_MODE, M_NEXT, M_SOLVES, M_T0,
                          M_VALID, MEMORY_HEADER, _clamp, _forward, acceleration, energy, ilqr, lqr_cost, lqr_torque,
                          scratch, step, substeps, unpack)
from . import mpc_kernels as mk

#: Latencies the estimator scores, in control calls (0 .. LAGS - 1: up to 46 ms at RealAIGym's 2 ms).
LAGS = 24
#: A gap between calls [s] beyond which the estimate starts afresh.
GAP = 0.05
# parameters of the estimator in the parameter vector's header
H_ESTIMATE, H_OBS_ANGLE, H_OBS_SPEED, H_LAG_MEMORY, H_LAG_GATE = 16, 17, 18, 19, 21  # mpc_kernels.H_NU: 23
H_OBS_ACCEL, H_NOISE_MEMORY = 25, 26
# the energy above the goal's [J] beyond which a plan is solved afresh every 5 periods (0: never)
H_RESPIN = 22
# the braking guess's gain in units of pump_kd (0: none)
H_BRAKE = 24
# the turn per knot [rad] of a link at a solve's state beyond which that solve's knots take RK4 sub-steps of at most
# that turn (mpc_kernels.H_TURN in its copy of the parameters; 0: never)
H_FAST = 15
# the memory's slots of the time of the last fresh solve, and of the flag "no finite plan: brake until the next solve"
M_COLD, M_BRAKE = MEMORY_HEADER - 1, MEMORY_HEADER - 2
# the estimator's header in the memory
E_VALID, E_T, E_TM1, E_TM2, E_COUNT, E_LAG, E_WEIGHT = range(7)
E_HEADER = 8


@njit(cache=True)
def memory_size(n, nu, knots):
    """The law's memory: the plan's (:func:`paa_mj.control.mpc_kernels.memory_size`), then the estimator's: its
    header, the estimate (2n), the two previous measured angles (n each), the commanded torques (LAGS + 1, nu), the
    latencies' scores (LAGS) and the angles' noise statistics (3n)."""
    return mk.memory_size(n, nu, knots) + E_HEADER + 7 * n + (LAGS + 1) * nu + LAGS


@njit(cache=True)
def estimator_views(params, memory, n, nu):
    """The estimator's part of the memory: header, estimate (2n), angles at k - 1 and k - 2 (n each), commanded
    torques (LAGS + 1, nu; row 0 the last), scores (LAGS), the angles' noise statistics (3, n: the last residual r,
    the running means of r^2 and of r_k r_{k-1}, :func:`_angle_noise`)."""
    a = mk.memory_size(n, nu, int(params[H_KNOTS]))
    head = chain.vector_view(memory, a, E_HEADER)
    a += E_HEADER
    xhat = chain.vector_view(memory, a, 2 * n)
    a += 2 * n
    q1 = chain.vector_view(memory, a, n)
    a += n
    q2 = chain.vector_view(memory, a, n)
    a += n
    hist = chain.matrix_view(memory, a, LAGS + 1, nu)
    a += (LAGS + 1) * nu
    score = chain.vector_view(memory, a, LAGS)
    a += LAGS
    stats = chain.matrix_view(memory, a, 3, n)
    return head, xhat, q1, q2, hist, score, stats


@njit(cache=True, inline="always")
def _score_lags(params, y, dt, head, q1, q2, hist, score, ws):
    """Step 1 of the module docstring (the angles at k - 1 and k - 2 a step dt apart each)."""
    n = q1.size
    nu = hist.shape[1]
    nx = 2 * n
    xm = np.empty(nx)
    a0 = np.empty(nx)
    a1 = np.empty(nx)
    u = np.zeros(nu)
    for i in range(n):
        xm[i] = q1[i]
        xm[n + i] = (y[i] - q2[i]) / (2.0 * dt)
    acceleration(params, xm, u, a0, ws)
    decay = math.exp(-dt / params[H_LAG_MEMORY])
    # qdd is affine in u: qdd(u) = a0 + sum_j B_j u_j, B_j from a unit torque
    bcol = np.empty((nu, n))
    for j in range(nu):
        u[j] = 1.0
        acceleration(params, xm, u, a1, ws)
        u[j] = 0.0
        for i in range(n):
            bcol[j, i] = a1[n + i] - a0[n + i]
    # per latency, the squared residual in torque units (divided by |B|^2): a step none of them explains within the
    # gate (a push, a reset, a blow) says nothing of the latency and is skipped
    norm = 0.0
    for j in range(nu):
        for i in range(n):
            norm += bcol[j, i] * bcol[j, i]
    residual = np.empty(LAGS)
    least = math.inf
    for d in range(LAGS):
        total = 0.0
        for i in range(n):
            r = (y[i] - 2.0 * q1[i] + q2[i]) / (dt * dt) - a0[n + i]
            for j in range(nu):
                r -= bcol[j, i] * 0.5 * (hist[d, j] + hist[d + 1, j])
            total += r * r
        residual[d] = total / norm
        least = min(least, residual[d])
    if least > params[H_LAG_GATE] ** 2:
        return
    for d in range(LAGS):
        score[d] = decay * score[d] + residual[d]
    best = int(head[E_LAG])
    for d in range(LAGS):
        if score[d] < 0.9 * score[best]:
            best = d
    head[E_LAG] = best


@njit(cache=True, inline="always")
def _angle_noise(params, y, dt, head, xhat, q1, q2, u, stats, ws):
    """Step 2a of the module docstring: the running statistics of each angle's residual r (the measured angles'
    second difference at k - 1 less the model's over the two steps, from the estimate at k - 1 with the torque u);
    returns nothing, the variances are read by :func:`angle_variance`."""
    n = q1.size
    acc = np.empty(2 * n)
    acceleration(params, xhat, u, acc, ws)
    decay = math.exp(-dt / params[H_NOISE_MEMORY])
    head[E_WEIGHT] = decay * head[E_WEIGHT] + (1.0 - decay)
    for i in range(n):
        r = wrap(y[i] - q1[i]) - wrap(q1[i] - q2[i]) - dt * dt * acc[n + i]
        stats[1, i] = decay * stats[1, i] + (1.0 - decay) * r * r
        stats[2, i] = decay * stats[2, i] + (1.0 - decay) * r * stats[0, i]
        stats[0, i] = r


@njit(cache=True)
def angle_variance(params, dt, head, stats, i):
    """The variance [rad^2] of angle i's measurement noise from its residual's statistics (module docstring, 2a):
    -c_1 / 4 less twice its standard error c_0 / (4 sqrt(N)) (N = 2 T_n / dt samples in the running means), 0 where
    that is not positive (a smooth or white model error is not noise on the angles)."""
    w = head[E_WEIGHT]
    if params[H_NOISE_MEMORY] <= 0.0 or w <= 0.0:
        return 0.0
    c0, c1 = stats[1, i] / w, stats[2, i] / w
    samples = min(2.0 * params[H_NOISE_MEMORY] / dt, w * params[H_NOISE_MEMORY] / dt + 1.0)
    return max(0.0, -0.25 * c1 - 0.5 * c0 / math.sqrt(samples))


@njit(cache=True, inline="always")
def tracking_gains(index):
    """(alpha, beta) of the steady-state Kalman filter of an angle measured with noise sigma whose acceleration is
    white noise of sigma_w per step dt (the alpha-beta filter), at the tracking index lambda = sigma_w dt^2 / sigma
    (Kalata 1984): r = (4 + lambda - sqrt(8 lambda + lambda^2)) / 4, alpha = 1 - r^2,
    beta = 2 (2 - alpha) - 4 sqrt(1 - alpha); (1, 2) at lambda = inf (exact angles)."""
    if not index < math.inf:
        return 1.0, 2.0
    r = 0.25 * (4.0 + index - math.sqrt(8.0 * index + index * index))
    alpha = 1.0 - r * r
    return alpha, 2.0 * (2.0 - alpha) - 4.0 * math.sqrt(max(1.0 - alpha, 0.0))


@njit(cache=True, inline="always")
def estimate(params, y, t, memory, x):
    """The state the law acts on (module docstring) from the measurement y at time t, into x."""
    nx = y.size
    n = nx // 2
    nu = int(params[H_NU])
    head, xhat, q1, q2, hist, score, stats = estimator_views(params, memory, n, nu)
    dt = t - head[E_T]
    if head[E_VALID] == 0.0 or dt <= 0.0 or dt > GAP:
        xhat[:] = y
        x[:] = y
        q1[:] = y[:n]
        head[E_TM1] = t
        head[E_T] = t
        head[E_COUNT] = 0.0
        head[E_VALID] = 1.0
        stats[0, :] = 0.0  # no residual yet (the noise's statistics are kept: the sensor's noise is the sensor's)
        for k in range(LAGS + 1):
            for j in range(nu):
                hist[k, j] = 0.0
        return
    ws = scratch(n)
    count = head[E_COUNT] + 1.0
    # the latency, once the torques of every latency scored are the law's own
    even = abs((t - head[E_TM1]) - (head[E_TM1] - head[E_TM2])) < 1e-3 * dt
    if params[H_LAG_MEMORY] > 0.0 and count > LAGS + 2 and even:
        _score_lags(params, y, dt, head, q1, q2, hist, score, ws)
    lag = int(head[E_LAG])
    # the angles' noise, from their residuals against the model
    if params[H_NOISE_MEMORY] > 0.0 and count >= 2.0 and even:
        u = np.empty(nu)
        for j in range(nu):
            u[j] = 0.5 * (hist[lag, j] + hist[lag + 1, j])
        _angle_noise(params, y, dt, head, xhat, q1, q2, u, stats, ws)
    # the delayed state: the model's step with the torque that latency applied, corrected by the measurement
    prior = np.empty(nx)
    step(params, xhat, hist[lag], dt, prior, ws)
    a, b = params[H_OBS_ANGLE], params[H_OBS_SPEED]
    process = params[H_OBS_ACCEL] * dt * math.sqrt(dt)
    for i in range(n):
        variance = angle_variance(params, dt, head, stats, i)
        alpha, beta = tracking_gains(process / math.sqrt(variance) if variance > 0.0 else math.inf)
        innovation = wrap(y[i] - prior[i])
        xhat[i] = prior[i] + alpha * innovation
        xhat[n + i] = prior[n + i] + min(a, beta) * innovation / dt + b * (y[n + i] - prior[n + i])
    # over the latency with the torques commanded since
    x[:] = xhat
    nxt = np.empty(nx)
    for k in range(lag - 1, -1, -1):
        step(params, x, hist[k], dt, nxt, ws)
        x[:] = nxt
    q2[:] = q1
    q1[:] = y[:n]
    head[E_TM2] = head[E_TM1]
    head[E_TM1] = t
    head[E_T] = t
    head[E_COUNT] = count


@njit(cache=True, inline="always")
def remember_torque(params, memory, tau, n):
    """Keep the torque commanded now as the estimator's c_k."""
    nu = tau.size
    head, xhat, q1, q2, hist, score, stats = estimator_views(params, memory, n, nu)
    for k in range(LAGS, 0, -1):
        for j in range(nu):
            hist[k, j] = hist[k - 1, j]
    for j in range(nu):
        hist[0, j] = tau[j]


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
    U (N, nu), K (N, nu, nx + nu)."""
    n, nu = int(params[H_N]), int(params[H_NU])
    nx = 2 * n
    knots = int(params[H_KNOTS])
    a = MEMORY_HEADER
    uprev = chain.vector_view(memory, a, nu)
    a += nu
    ustart = chain.vector_view(memory, a, nu)
    a += nu
    X = chain.matrix_view(memory, a, knots + 1, nx)
    a += (knots + 1) * nx
    U = chain.matrix_view(memory, a, knots, nu)
    a += knots * nu
    K = np.ascontiguousarray(memory[a:a + knots * nu * (nx + nu)]).reshape((knots, nu, nx + nu))
    return uprev, ustart, X, U, K


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
        Kg[k] = K[min(max(int(s + k + 0.5), 0), knots - 1)]
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
    a fast state plans with RK4 sub-steps (:func:`_fast`)."""
    nu = int(params[H_NU])
    knots = int(params[H_KNOTS])
    uprev, ustart, X, U, K = plan_views(params, memory)
    params = _fast(params, x)
    Ug = np.empty((knots, nu))
    Xg = np.empty((knots + 1, x.size))
    Kg = np.empty((knots, nu, x.size + nu))
    valid = memory[M_VALID] != 0.0
    restart = not valid or _far(params, model, x, t, memory)
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
    for r in range(nu):
        v = _plan_torque(U, s, r, ustart[r])
        for j in range(nx):
            d = wrap(x[j] - ref[j]) if j < n else x[j] - ref[j]
            v += K[i, r, j] * d
        tau[r] = _clamp(v, umax[r])
    for j in range(nu):
        uprev[j] = tau[j]
    return 0
