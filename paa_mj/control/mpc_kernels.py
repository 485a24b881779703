"""The compiled core of :mod:`paa_mj.control.mpc`: iLQR (box-clamped DDP) on a chain's own equations of motion.

One knot of the plan is h seconds of (1), integrated by RK4 with the torque held (zero-order hold):

.. math::

    x_{k+1} = F(x_k, u_k), \\qquad x = [q, \\dot q] \\;(2n), \\quad u = [\\tau_{a_1}, \\dots, \\tau_{a_m}] \\;(m),

M(q) qdd + H + G + D qd = B u (:func:`paa_mj.model.chain.acceleration_into`), B the columns of the driven joints
a_1 < ... < a_m (any of them passive: the robot's drive map, :func:`paa_mj.model.chain.drive_map`). Its Jacobians F_x, F_u are forward
differences of F (step :data:`FD_EPS`). The plan's state carries the previous torque, z = [x, u_prev], so that the
cost can weigh the torque's change (their smoothness criterion):

.. math::

    J = \\sum_{k<N} h \\Big[\\sum_i w_{q,i} (1 - \\cos e_i) + \\sum_i w_{v,i} \\dot q_i^2
        + \\sum_j r_j u_{k,j}^2 + \\sum_j r_{d,j} (u_{k,j} - u_{k-1,j})^2 / h^2\\Big]
        + s\\, \\tilde e_N^\\top S \\tilde e_N

with e = q - q* the joint angles' error from the goal (periodic: no wrap needed), \\tilde e = [wrap(q - q*), qd]
and S the LQR's cost-to-go matrix at the goal (its Riccati solution), scaled by s. The angle terms are taken
Gauss-Newton: gradient w sin e, Hessian w (the residuals sin e, 1 - cos e have J^T J = 1). Torques are kept in
[-u_max, u_max] by the box-DDP rule for each torque in turn: a feed-forward step that would leave the box is cut to
it and that torque's feedback row set to zero (exact for one motor: the acrobot, the pendubot).

Every function works on one state, with flat parameter arrays whose layout :func:`offsets` states.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..model import chain
from ..model.states import wrap

#: Forward-difference step of the Jacobians of F.
FD_EPS = 1e-6

# header of the parameter vector
(H_N, H_KNOTS, H_STEP, H_PERIOD, H_ITERS, H_RHO_IN, H_RHO_OUT, H_TERM, H_PUMP, H_RESTART, H_ITERS_COLD, H_PUMP_KP,
 H_PUMP_KD, H_E_GOAL, H_TURN) = range(15)
H_NU = 23  # the number of motors m (mpc_law.H_* take 15, 22, 24, 27..32; mpc_estimator's 16..19, 21, 25, 26)
# the knots of the climb's plans, started afresh far below the goal's energy (mpc_law.climb_knots; 0: none)
H_CLIMB_KNOTS = 20
HEADER = 33

# header of the memory vector
M_T0, M_MODE, M_NEXT, M_VALID, M_CALL, M_COST, M_SOLVES = range(7)  # M_CALL: the time of the law's last call
MEMORY_HEADER = 11  # mpc_law.M_* take 7..10


@njit(cache=True)
def offsets(n, nu):
    """Where each block of the parameter vector starts, for n links and nu motors (nx = 2n): goal q* (n), u_max (nu),
    A (n n), b (n), damping (n), armature (n), the drive map (n: each joint's motor, -1 where none), w_q (n), w_v (n),
    r (nu), r_d (nu), S (nx nx), K (nu nx), the unit of iLQR's regularisation of each motor's Quu (nu: that of its
    torque weights, mpc.SIMILARITY), end."""
    nx = 2 * n
    goal = HEADER
    umax = goal + n
    a = umax + nu
    b = a + n * n
    damping = b + n
    armature = damping + n
    drive = armature + n
    wq = drive + n
    wv = wq + n
    r = wv + n
    rd = r + nu
    s = rd + nu
    k = s + nx * nx
    unit = k + nu * nx
    end = unit + nu
    return goal, umax, a, b, damping, armature, drive, wq, wv, r, rd, s, k, unit, end


@njit(cache=True)
def memory_size(n, nu, knots):
    """Numbers of the memory for n links and nu motors: header, the last torque and the torque when the plan was made
    (nu each), the plan's states (N + 1) nx, torques N nu and feedback gains N nu (nx + nu)."""
    return MEMORY_HEADER + 2 * nu + plan_size(n, nu, knots)


@njit(cache=True)
def plan_size(n, nu, knots):
    """Numbers of one plan of ``knots`` knots for n links and nu motors: its states (N + 1) nx, torques N nu and
    feedback gains N nu (nx + nu)."""
    nx = 2 * n
    return (knots + 1) * nx + knots * nu + knots * nu * (nx + nu)


@njit(cache=True)
def plan_knots(params):
    """The knots the memory keeps room for: the most a plan has (the ordinary horizon's, or the climb's,
    :data:`H_CLIMB_KNOTS`)."""
    return max(int(params[H_KNOTS]), int(params[H_CLIMB_KNOTS]))


@njit(cache=True)
def unpack(params):
    """The model and weights of the parameter vector as contiguous arrays (copied once per call): (A (n, n), b,
    damping, armature, goal, u_max, w_q, w_v, r, r_d, S (nx, nx), K (nu, nx), drive map (n))."""
    n, nu = int(params[H_N]), int(params[H_NU])
    nx = 2 * n
    o = offsets(n, nu)
    A = np.ascontiguousarray(params[o[2]:o[3]]).reshape((n, n))
    S = np.ascontiguousarray(params[o[11]:o[12]]).reshape((nx, nx))
    K = np.ascontiguousarray(params[o[12]:o[13]]).reshape((nu, nx))
    return (A, params[o[3]:o[4]].copy(), params[o[4]:o[5]].copy(), params[o[5]:o[6]].copy(),
            params[o[0]:o[0] + n].copy(), params[o[1]:o[1] + nu].copy(), params[o[7]:o[8]].copy(),
            params[o[8]:o[9]].copy(), params[o[9]:o[10]].copy(), params[o[10]:o[11]].copy(), S, K,
            params[o[6]:o[7]].copy())


@njit(cache=True)
def scratch(n):
    """Scratch of :func:`step`, flat: four stages and a state (nx each), M (n n), the force, phi and rate (n each), the
    state between sub-steps (nx)."""
    return np.empty(15 * n + n * n)


@njit(cache=True)
def acceleration(p, x, u, out, w):
    """qdd = M(q)^-1 (B u - H - G - D qd) at x = [q, qd] into ``out[n:2n]``: the formulas of
    :func:`paa_mj.model.chain.acceleration_into` (M = T^T (A_ij cos(phi_i - phi_j)) T + diag(armature),
    H + G = T^T (c + grad P)) with the model read from the parameter vector ``p`` and flat scratch ``w``
    (:func:`scratch`) so that nothing is passed but five arrays (the call's cost is its arrays), M solved by Cholesky
    (it is positive definite); a test holds the two to 1e-12."""
    n = x.size // 2
    o = offsets(n, int(p[H_NU]))
    pa, pb, pd, parm, pdrive = o[2], o[3], o[4], o[5], o[6]
    m0 = 10 * n
    f0 = m0 + n * n
    ph0 = f0 + n
    r0 = ph0 + n
    a = 0.0
    v = 0.0
    for i in range(n):
        a += x[i]
        v += x[n + i]
        w[ph0 + i] = a
        w[r0 + i] = v
    for i in range(n):
        w[m0 + i * n + i] = p[pa + i * n + i]
        total = -p[pb + i] * math.sin(w[ph0 + i])
        for j in range(n):
            if j != i:
                d = w[ph0 + i] - w[ph0 + j]
                rj = w[r0 + j]
                total += p[pa + i * n + j] * math.sin(d) * rj * rj
                if j > i:
                    c = p[pa + i * n + j] * math.cos(d)
                    w[m0 + i * n + j] = c
                    w[m0 + j * n + i] = c
        out[n + i] = total
    for i in range(n - 2, -1, -1):
        out[n + i] += out[n + i + 1]
        for j in range(n):
            w[m0 + i * n + j] += w[m0 + (i + 1) * n + j]
    for j in range(n - 2, -1, -1):
        for i in range(n):
            w[m0 + i * n + j] += w[m0 + i * n + j + 1]
    for i in range(n):
        w[m0 + i * n + i] += p[parm + i]
        motor = int(p[pdrive + i])
        w[f0 + i] = (u[motor] if motor >= 0 else 0.0) - out[n + i] - p[pd + i] * x[n + i]
    for i in range(n):  # Cholesky, lower triangle in place
        for j in range(i + 1):
            s = w[m0 + i * n + j]
            for k in range(j):
                s -= w[m0 + i * n + k] * w[m0 + j * n + k]
            if i == j:
                w[m0 + i * n + i] = math.sqrt(s) if s > 0.0 else math.nan
            else:
                w[m0 + i * n + j] = s / w[m0 + j * n + j]
    for i in range(n):
        s = w[f0 + i]
        for k in range(i):
            s -= w[m0 + i * n + k] * w[f0 + k]
        w[f0 + i] = s / w[m0 + i * n + i]
    for i in range(n - 1, -1, -1):
        s = w[f0 + i]
        for k in range(i + 1, n):
            s -= w[m0 + k * n + i] * out[n + k]
        out[n + i] = s / w[m0 + i * n + i]


@njit(cache=True)
def substeps(p, x, h):
    """The RK4 sub-steps of a step of h seconds from x: the fewest that keep every link's turn (its absolute and its
    relative rate times the sub-step) within ``p[H_TURN]`` rad (1 where that is 0). RK4 is stable on a spin of rate w
    for w h below about 2.8: a chain spun to hundreds of rad/s (their global test's resets) would run away in the
    plan's 20 ms knots."""
    turn = p[H_TURN]
    if turn <= 0.0:
        return 1
    return max(1, int(math.ceil(fastest_rate(x) * h / turn)))


@njit(cache=True)
def fastest_rate(x):
    """The fastest turn rate [rad/s] in the state x = [q, qd]: of a joint (its relative rate qd_i) or of a link (its
    absolute rate, the sum of the rates up to it)."""
    n = x.size // 2
    rate = 0.0
    fastest = 0.0
    for i in range(n):
        rate += x[n + i]
        fastest = max(fastest, abs(rate), abs(x[n + i]))
    return fastest


@njit(cache=True)
def step(p, x, u, h, out, w):
    """One step of h seconds from x with u held, into ``out``, by :func:`substeps` RK4 steps; ``w``: :func:`scratch`."""
    m = substeps(p, x, h)
    if m == 1:
        _rk4(p, x, u, h, out, w)
        return
    nx = x.size
    n = nx // 2
    z = 13 * n + n * n
    w[z:z + nx] = x
    for _ in range(m):
        _rk4(p, w[z:z + nx], u, h / m, out, w)
        w[z:z + nx] = out


@njit(cache=True)
def _rk4(p, x, u, h, out, w):
    """One RK4 step of h seconds from x with u held, into ``out``."""
    nx = x.size
    n = nx // 2
    k1, k2, k3, k4, y = 0, nx, 2 * nx, 3 * nx, 4 * nx
    acceleration(p, x, u, w[k1:k1 + nx], w)
    for i in range(n):
        w[k1 + i] = x[n + i]
    for i in range(nx):
        w[y + i] = x[i] + 0.5 * h * w[k1 + i]
    acceleration(p, w[y:y + nx], u, w[k2:k2 + nx], w)
    for i in range(n):
        w[k2 + i] = w[y + n + i]
    for i in range(nx):
        w[y + i] = x[i] + 0.5 * h * w[k2 + i]
    acceleration(p, w[y:y + nx], u, w[k3:k3 + nx], w)
    for i in range(n):
        w[k3 + i] = w[y + n + i]
    for i in range(nx):
        w[y + i] = x[i] + h * w[k3 + i]
    acceleration(p, w[y:y + nx], u, w[k4:k4 + nx], w)
    for i in range(n):
        w[k4 + i] = w[y + n + i]
    for i in range(nx):
        out[i] = x[i] + h * (w[k1 + i] + 2.0 * w[k2 + i] + 2.0 * w[k3 + i] + w[k4 + i]) / 6.0


@njit(cache=True)
def _error(model, x, e):
    """e = [wrap(q - q*), qd], the error from the goal."""
    goal = model[4]
    n = goal.size
    for i in range(x.size):
        e[i] = wrap(x[i] - goal[i]) if i < n else x[i]


@njit(cache=True)
def lqr_cost(model, x):
    """The LQR's cost-to-go e^T S e."""
    S = model[10]
    nx = x.size
    e = np.empty(nx)
    _error(model, x, e)
    total = 0.0
    for i in range(nx):
        row = 0.0
        for j in range(nx):
            row += S[i, j] * e[j]
        total += e[i] * row
    return total


@njit(cache=True)
def _clamp(u, limit):
    return min(max(u, -limit), limit)


@njit(cache=True)
def lqr_torque(model, x, tau):
    """tau = -K e, clamped to the box."""
    K, umax = model[11], model[5]
    nx = x.size
    e = np.empty(nx)
    _error(model, x, e)
    for r in range(tau.size):
        total = 0.0
        for j in range(nx):
            total += K[r, j] * e[j]
        tau[r] = _clamp(-total, umax[r])


@njit(cache=True)
def stage_cost(model, x, u, uprev, h):
    """The running cost of one knot (module docstring), h times the integrand."""
    goal, wq, wv, r, rd = model[4], model[6], model[7], model[8], model[9]
    n = goal.size
    total = 0.0
    for i in range(n):
        total += wq[i] * (1.0 - math.cos(x[i] - goal[i])) + wv[i] * x[n + i] * x[n + i]
    for j in range(u.size):
        du = u[j] - uprev[j]
        total += r[j] * u[j] * u[j] + rd[j] * du * du / (h * h)
    return h * total


@njit(cache=True)
def terminal_cost(params, model, x):
    return params[H_TERM] * lqr_cost(model, x)


@njit(cache=True)
def _with_terminal(params, model, x_end, running):
    """The plan's whole cost: the running cost plus the terminal one at its last knot; inf where it is not finite."""
    total = running + terminal_cost(params, model, x_end)
    if not math.isfinite(total):
        return math.inf
    return total


@njit(cache=True, inline="always")
def rollout(params, model, x0, uprev0, U, X, ws):
    """X[0] = x0, X[k + 1] = F(X[k], U[k]); returns the plan's cost J (inf where the state stops being finite)."""
    knots = U.shape[0]
    h = params[H_STEP]
    X[0] = x0
    total = stage_cost(model, X[0], U[0], uprev0, h)
    step(params, X[0], U[0], h, X[1], ws)
    for k in range(1, knots):
        total += stage_cost(model, X[k], U[k], U[k - 1], h)
        step(params, X[k], U[k], h, X[k + 1], ws)
    return _with_terminal(params, model, X[knots], total)


@njit(cache=True, inline="always")
def _linearise(params, x, u, h, fx, fu, base, probe, xp, up, ws):
    """F_x (nx, nx) and F_u (nx, nu) at (x, u) by forward differences."""
    nx, nu = x.size, u.size
    step(params, x, u, h, base, ws)
    for j in range(nx):
        xp[:] = x
        xp[j] += FD_EPS
        step(params, xp, u, h, probe, ws)
        for i in range(nx):
            fx[i, j] = (probe[i] - base[i]) / FD_EPS
    for j in range(nu):
        up[:] = u
        up[j] += FD_EPS
        step(params, x, up, h, probe, ws)
        for i in range(nx):
            fu[i, j] = (probe[i] - base[i]) / FD_EPS


@njit(cache=True)
def _cholesky_solve(a, rhs, L, y, out):
    """out = a^-1 rhs for a small symmetric a (m, m), rhs (m, c), by Cholesky into L; False if a is not positive
    definite."""
    m = a.shape[0]
    for i in range(m):
        for j in range(i + 1):
            s = a[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            if i == j:
                if s <= 0.0:
                    return False
                L[i, i] = math.sqrt(s)
            else:
                L[i, j] = s / L[j, j]
    for c in range(rhs.shape[1]):
        for i in range(m):
            s = rhs[i, c]
            for k in range(i):
                s -= L[i, k] * y[k]
            y[i] = s / L[i, i]
        for i in range(m - 1, -1, -1):
            s = y[i]
            for k in range(i + 1, m):
                s -= L[k, i] * out[k, c]
            out[i, c] = s / L[i, i]
    return True


@njit(cache=True, inline="always")
def _backward(params, model, X, U, uprev0, FX, FU, kff, Kfb, mu, sc):
    """The DDP backward pass over the augmented state z = [x, u_prev] (nz = nx + nu), Gauss-Newton costs; fills the
    feed-forward steps kff (N, nu) and feedback gains Kfb (N, nu, nz). Returns the expected decrease's linear and
    quadratic terms, or (nan, nan) where Quu is not positive definite (the caller raises mu)."""
    goal, umax, wq, wv, r, rd = model[4], model[5], model[6], model[7], model[8], model[9]
    S = model[10]
    n = goal.size
    nx, nu = 2 * n, U.shape[1]
    nz = nx + nu
    h = params[H_STEP]
    knots = U.shape[0]
    term = params[H_TERM]
    unit = offsets(n, nu)[13]
    Vx, Vxx, Qx, Qu, Qxx, Quu, Qux, rhs, sol, tmp, tmpu, L, y, e = sc
    _error(model, X[knots], e)
    for i in range(nz):
        Vx[i] = 0.0
        for j in range(nz):
            Vxx[i, j] = 0.0
    for i in range(nx):
        row = 0.0
        for j in range(nx):
            row += S[i, j] * e[j]
            Vxx[i, j] = 2.0 * term * S[i, j]
        Vx[i] = 2.0 * term * row
    d1 = 0.0
    d2 = 0.0
    for k in range(knots - 1, -1, -1):
        x = X[k]
        u = U[k]
        fx = FX[k]
        fu = FU[k]
        # z' = [F(x, u), u]: the x rows are F's, the u_prev rows are u's; Vxx fz and Vxx fv, fz = [[fx, 0], [0, 0]]
        for a in range(nz):
            for j in range(nx):
                s = 0.0
                for b in range(nx):
                    s += Vxx[a, b] * fx[b, j]
                tmp[a, j] = s
            for j in range(nu):
                s = Vxx[a, nx + j]
                for b in range(nx):
                    s += Vxx[a, b] * fu[b, j]
                tmpu[a, j] = s
        # Q = l + f^T V
        for i in range(nx):
            s = 0.0
            for a in range(nx):
                s += fx[a, i] * Vx[a]
            Qx[i] = s
            for j in range(nx):
                s = 0.0
                for a in range(nx):
                    s += fx[a, i] * tmp[a, j]
                Qxx[i, j] = s
            for j in range(nx, nz):
                Qxx[i, j] = 0.0
                Qxx[j, i] = 0.0
        for i in range(nu):
            Qx[nx + i] = 0.0
            for j in range(nu):
                Qxx[nx + i, nx + j] = 0.0
        for j in range(nu):
            s = Vx[nx + j]
            for a in range(nx):
                s += fu[a, j] * Vx[a]
            Qu[j] = s
            for i in range(nu):
                s = tmpu[nx + i, j]
                for a in range(nx):
                    s += fu[a, i] * tmpu[a, j]
                Quu[i, j] = s
            for i in range(nx):
                s = tmp[nx + j, i]
                for a in range(nx):
                    s += fu[a, j] * tmp[a, i]
                Qux[j, i] = s
            for i in range(nu):
                Qux[j, nx + i] = 0.0
        # the costs (Gauss-Newton)
        for i in range(n):
            Qx[i] += h * wq[i] * math.sin(x[i] - goal[i])
            Qxx[i, i] += h * wq[i]
            Qx[n + i] += 2.0 * h * wv[i] * x[n + i]
            Qxx[n + i, n + i] += 2.0 * h * wv[i]
        for j in range(nu):
            up = uprev0[j] if k == 0 else U[k - 1, j]
            rdj = rd[j] / (h * h)
            Qu[j] += 2.0 * h * (r[j] * u[j] + rdj * (u[j] - up))
            Quu[j, j] += 2.0 * h * (r[j] + rdj) + mu * params[unit + j]
            Qx[nx + j] += -2.0 * h * rdj * (u[j] - up)
            Qxx[nx + j, nx + j] += 2.0 * h * rdj
            Qux[j, nx + j] += -2.0 * h * rdj
        for i in range(nu):
            rhs[i, 0] = -Qu[i]
            for j in range(nz):
                rhs[i, j + 1] = -Qux[i, j]
        if not _cholesky_solve(Quu, rhs, L, y, sol):
            return math.nan, math.nan
        # box: a torque whose step leaves the box is cut to it, its feedback dropped
        for i in range(nu):
            step_i = sol[i, 0]
            if u[i] + step_i > umax[i]:
                step_i = umax[i] - u[i]
                for j in range(nz):
                    sol[i, j + 1] = 0.0
            elif u[i] + step_i < -umax[i]:
                step_i = -umax[i] - u[i]
                for j in range(nz):
                    sol[i, j + 1] = 0.0
            sol[i, 0] = step_i
            kff[k, i] = step_i
            for j in range(nz):
                Kfb[k, i, j] = sol[i, j + 1]
        for i in range(nu):
            d1 += kff[k, i] * Qu[i]
            for j in range(nu):
                d2 += 0.5 * kff[k, i] * Quu[i, j] * kff[k, j]
        # V = Q + K^T Quu k + K^T Qu + Qux^T k;  Vxx = Qxx + K^T Quu K + K^T Qux + Qux^T K
        for i in range(nz):
            s = Qx[i]
            for a in range(nu):
                ka = 0.0
                for b in range(nu):
                    ka += Quu[a, b] * sol[b, 0]
                s += sol[a, i + 1] * (Qu[a] + ka) + Qux[a, i] * sol[a, 0]
            Vx[i] = s
        for i in range(nz):
            for j in range(i, nz):
                s = Qxx[i, j]
                for a in range(nu):
                    s += sol[a, i + 1] * Qux[a, j] + Qux[a, i] * sol[a, j + 1]
                    for b in range(nu):
                        s += sol[a, i + 1] * Quu[a, b] * sol[b, j + 1]
                Vxx[i, j] = s
                Vxx[j, i] = s
    return d1, d2


@njit(cache=True)
def _forward(params, model, x0, uprev0, Xbar, Ubar, kff, Kfb, alpha, X, U, ws):
    """u_k = clamp(ubar_k + alpha kff_k + K_k (z_k - zbar_k)), angles of the difference wrapped; returns J."""
    umax = model[5]
    nx = x0.size
    n = nx // 2
    nu = Ubar.shape[1]
    h = params[H_STEP]
    knots = Ubar.shape[0]
    X[0] = x0
    total = 0.0
    for k in range(knots):
        for i in range(nu):
            v = Ubar[k, i] + alpha * kff[k, i]
            for j in range(nx):
                d = X[k, j] - Xbar[k, j]
                if j < n:
                    d = wrap(d)
                v += Kfb[k, i, j] * d
            if k > 0:
                for j in range(nu):
                    v += Kfb[k, i, nx + j] * (U[k - 1, j] - Ubar[k - 1, j])
            U[k, i] = _clamp(v, umax[i])
        total += stage_cost(model, X[k], U[k], uprev0 if k == 0 else U[k - 1], h)
        step(params, X[k], U[k], h, X[k + 1], ws)
    return _with_terminal(params, model, X[knots], total)


@njit(cache=True)
def ilqr(params, model, x0, uprev0, U, X, Kfb, iterations):
    """Improve the plan U (N, nu) from x0 by at most ``iterations`` iLQR iterations in place; X (N + 1, nx) its
    states, Kfb (N, nu, nx + nu) its feedback gains (on x and the previous torque). Returns the plan's cost."""
    return ilqr_steps(params, model, x0, uprev0, U, X, Kfb, iterations, np.array([1e-6, 0.0]))


@njit(cache=True)
def ilqr_steps(params, model, x0, uprev0, U, X, Kfb, iterations, state):
    """:func:`ilqr` resumable: ``state`` = [mu, stopped] carries the regularisation and whether it has stopped
    (converged or given up) from one call to the next, so that iterations split over calls (a restart spread over
    control calls, :func:`paa_mj.control.mpc_law.restart_steps`) make the plan one call would."""
    nx = x0.size
    n = nx // 2
    nu = U.shape[1]
    nz = nx + nu
    knots = U.shape[0]
    h = params[H_STEP]
    ws = scratch(n)
    sc = (np.empty(nz), np.empty((nz, nz)), np.empty(nz), np.empty(nu), np.empty((nz, nz)), np.empty((nu, nu)),
          np.empty((nu, nz)), np.empty((nu, nz + 1)), np.empty((nu, nz + 1)), np.empty((nz, nx)), np.empty((nz, nu)),
          np.zeros((nu, nu)), np.empty(nu), np.empty(nx))
    FX = np.empty((knots, nx, nx))
    FU = np.empty((knots, nx, nu))
    kff = np.zeros((knots, nu))
    Xn = np.empty((knots + 1, nx))
    Un = np.empty((knots, nu))
    base, probe, xp = np.empty(nx), np.empty(nx), np.empty(nx)
    upr = np.empty(nu)
    cost = rollout(params, model, x0, uprev0, U, X, ws)
    mu = state[0]
    if state[1] != 0.0:
        return cost
    state[1] = 1.0  # unless the loop runs out of iterations
    for it in range(iterations):
        for k in range(knots):
            _linearise(params, X[k], U[k], h, FX[k], FU[k], base, probe, xp, upr, ws)
        d1 = math.nan
        d2 = 0.0
        for attempt in range(8):
            d1, d2 = _backward(params, model, X, U, uprev0, FX, FU, kff, Kfb, mu, sc)
            if math.isfinite(d1):
                break
            mu = max(mu * 10.0, 1e-4)
        if not math.isfinite(d1):
            break
        accepted = False
        alpha = 1.0
        new = cost
        for ls in range(6):
            new = _forward(params, model, x0, uprev0, X, U, kff, Kfb, alpha, Xn, Un, ws)
            expected = -alpha * (d1 + alpha * d2)
            if new < cost and (expected <= 0.0 or (cost - new) >= 1e-4 * expected):
                accepted = True
                break
            alpha *= 0.4
        if not accepted:
            mu = max(mu * 10.0, 1e-4)
            if mu > 1e6:
                break
            continue
        improvement = cost - new
        cost = new
        X[:, :] = Xn
        U[:, :] = Un
        mu = max(mu / 10.0, 1e-8)
        if improvement < 1e-7 * (1.0 + abs(cost)):
            break
    else:
        state[1] = 0.0
    state[0] = mu
    return cost


@njit(cache=True)
def energy(model, x):
    """E = 1/2 qd^T M qd + P(q) [J]."""
    A, b, armature = model[0], model[1], model[3]
    n = b.size
    M = np.empty((n, n))
    phi = np.empty(n)
    chain._mass_matrix_with(A, armature, x[:n], M, phi)
    return chain.kinetic(M, x[n:]) + chain.potential(b, x[:n])
