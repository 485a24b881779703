r"""The state estimator in front of the law of :mod:`paa_mj.control.mpc`: :func:`estimate` turns the measured state
y_k = [q, qd] at time t_k into the state the law acts on. It keeps the torques the law commanded (c_{k-1}, c_{k-2},
...) and

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
from .mpc_kernels import H_NU, acceleration, plan_knots, scratch, step
from . import mpc_kernels as mk

#: Latencies the estimator scores, in control calls (0 .. LAGS - 1: up to 46 ms at RealAIGym's 2 ms).
LAGS = 24
#: A gap between calls [s] beyond which the estimate starts afresh.
GAP = 0.05
# parameters of the estimator in the parameter vector's header (mpc_kernels.H_NU: 23, H_CLIMB_KNOTS: 20; mpc_law's H_*:
# 15, 22, 24, 27..30)
H_ESTIMATE, H_OBS_ANGLE, H_OBS_SPEED, H_LAG_MEMORY, H_LAG_GATE = 16, 17, 18, 19, 21
H_OBS_ACCEL, H_NOISE_MEMORY = 25, 26
# the estimator's header in the memory
E_VALID, E_T, E_TM1, E_TM2, E_COUNT, E_LAG, E_WEIGHT = range(7)
E_HEADER = 8


@njit(cache=True)
def memory_size(n, nu):
    """The estimator's memory, after the plan's: its header, the estimate (2n), the two previous measured angles (n
    each), the commanded torques (LAGS + 1, nu), the latencies' scores (LAGS) and the angles' noise statistics (3n)."""
    return E_HEADER + 7 * n + (LAGS + 1) * nu + LAGS


@njit(cache=True)
def estimator_views(params, memory, n, nu):
    """The estimator's part of the memory: header, estimate (2n), angles at k - 1 and k - 2 (n each), commanded
    torques (LAGS + 1, nu; row 0 the last), scores (LAGS), the angles' noise statistics (3, n: the last residual r,
    the running means of r^2 and of r_k r_{k-1}, :func:`_angle_noise`)."""
    a = mk.memory_size(n, nu, plan_knots(params))
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
