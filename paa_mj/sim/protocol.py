"""RealAIGym's simulator, step for step, compiled: the physics and the disturbances of their benchmark protocols.

This is ``double_pendulum``'s ``Simulator.simulate`` (dfki-ric-underactuated-lab, commit 1e8544e6) for any
chain of the family, in paa_mj's angles (q1 from the upward vertical; theirs is q1 + pi, from hanging down).
Each step k, from the true state x_k at time t_k (t accumulated as ``t += dt``, as theirs is):

1. measurement: x_meas = x_{max(k + 1 - d, 0)} + N(0, sigma_meas), d = int(delay / dt) + 1 (the whole state is
   delayed, their ``delay_mode="posvel"``);
2. the controller's torque u (n: joint 1 first) at (x_meas, t_k);
3. the motor: nu = nu_{k-1} + r (u - nu_{k-1}) + N(0, sigma_u), nu_{-1} = 0 (r the responsiveness), clipped to
   +-limit per joint, then the perturbation p_j[int(t_k / dt)] added; nu is what is recorded as the torque;
4. physics: x_{k+1} = RK4 over dt with nu held, of

   .. math:: M_r(q)\\,\\ddot q = B\\,\\nu - H(q, \\dot q) - G(q) - b\\,\\dot q - c_f \\arctan(100\\,\\dot q)

   where B = diag(limit_j != 0) (their plant drops a torque on a joint without a motor, perturbations
   included), b the viscous damping, c_f the Coulomb friction of their ``coulomb_vector`` (smooth, not MuJoCo's
   ``frictionloss``), and M_r the chain's mass matrix with their rotor inertia: every joint's motor has a rotor
   I_r behind a gear of ratio g_r, joint 1's fixed to the bar, joint j's carried by link j - 1, which adds
   g_r^2 I_r to M_11 and, for each j >= 2, I_r to M_{j-1,j-1}, g_r^2 I_r to M_jj and -g_r I_r to M_{j-1,j}
   and M_{j,j-1} (for two links their ``mass_matrix`` exactly).

Their random numbers come from NumPy's global legacy generator, 5n normals a step in this order: 2n for the
measurement, n for the motor, 2n of process noise (always with sigma 0 in their protocols, so they move nothing
but the stream). A rollout here takes those normals as an array (``normals`` (N, 5n)), drawn by the caller.
"""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
from numba import njit, types
from numba.extending import register_jitable

from ..model import chain
from ..control.base import KERNEL_TYPE
from .step import evaluate_once

_C1, _C2 = types.float64[::1], types.float64[:, ::1]

#: Layout of a plant's constants: A (n n), b (n), damping (n), Coulomb (n), limit (n), then I_r and g_r.
_ROTOR, _GEAR = -2, -1


def plant_constants(m, l, lc, J, g, damping, coulomb, limit, rotor_inertia=0.0, gear_ratio=1.0) -> np.ndarray:
    """The constants of one plant (module docstring) from per-link arrays [SI units]; J about the COM, which may be
    negative here (their benchmark varies the first moment m r at a fixed pivot inertia I = J + m r^2)."""
    n = len(m)
    A, b = chain.chain_constants(SimpleNamespace(m=np.asarray(m, float), l=np.asarray(l, float),
                                                 lc=np.asarray(lc, float), J=np.asarray(J, float), g=float(g)))
    return np.concatenate([A.ravel(), b, np.broadcast_to(damping, (n,)), np.broadcast_to(coulomb, (n,)),
                           np.broadcast_to(limit, (n,)), [float(rotor_inertia), float(gear_ratio)]])


@register_jitable
def limits(P, n):
    """The torque limit of each of the n joints of the plant ``P`` [N m] (0: no motor there)."""
    return P[n * n + 3 * n:n * n + 4 * n]


@register_jitable
def work_size(n):
    """Scratch numbers :func:`rk4_step` needs for n links: the acceleration's n^2 + 4 n, then five states."""
    return n * n + 14 * n


@njit(cache=True)
def _acceleration(P, q, qd, tau, out, work):
    """qdd of the module's equation into ``out`` (n); ``tau`` (n) per joint [N m]; ``work``: scratch."""
    n = q.size
    A = P[:n * n].reshape((n, n))
    b = P[n * n:n * n + n]
    damping, coulomb, limit = P[n * n + n:n * n + 2 * n], P[n * n + 2 * n:n * n + 3 * n], limits(P, n)
    ir, gr = P[_ROTOR], P[_GEAR]
    mass = work[:n * n].reshape((n, n))
    zeros, phi, rate = work[n * n:n * n + n], work[n * n + n:n * n + 2 * n], work[n * n + 2 * n:n * n + 3 * n]
    force = work[n * n + 3 * n:n * n + 4 * n].reshape((n, 1))
    zeros[:] = 0.0
    chain._mass_matrix_with(A, zeros, q, mass, phi)
    if ir != 0.0:
        mass[0, 0] += gr * gr * ir
        for j in range(1, n):
            mass[j - 1, j - 1] += ir
            mass[j, j] += gr * gr * ir
            mass[j - 1, j] -= gr * ir
            mass[j, j - 1] -= gr * ir
    chain._bias_with(A, b, q, qd, out, phi, rate)
    for i in range(n):
        drive = tau[i] if limit[i] != 0.0 else 0.0
        force[i, 0] = drive - out[i] - damping[i] * qd[i] - coulomb[i] * math.atan(100.0 * qd[i])
    if not chain._solve_in_place(mass, force):
        force[:, 0] = np.nan
    for i in range(n):
        out[i] = force[i, 0]


@njit(cache=True)
def _field(P, x, tau, out, work):
    n = x.size // 2
    _acceleration(P, x[:n], x[n:], tau, out[n:], work)
    out[:n] = x[n:]


@njit(cache=True)
def rk4_step(P, x, tau, dt, work):
    """Their ``runge_integrator`` and ``step``: x + dt (k1 + 2 (k2 + k3) + k4) / 6, in place."""
    m = x.size
    base = (m // 2) ** 2 + 2 * m  # the acceleration's scratch is work[:base]
    k1, k2, k3, k4, y = (work[base:base + m], work[base + m:base + 2 * m], work[base + 2 * m:base + 3 * m],
                         work[base + 3 * m:base + 4 * m], work[base + 4 * m:base + 5 * m])
    _field(P, x, tau, k1, work)
    y[:] = x + 0.5 * dt * k1
    _field(P, y, tau, k2, work)
    y[:] = x + 0.5 * dt * k2
    _field(P, y, tau, k3, work)
    y[:] = x + dt * k3
    _field(P, y, tau, k4, work)
    for i in range(m):
        x[i] = x[i] + dt * ((k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i]) / 6.0)


@njit(cache=True)
def gravity_torque(P, q, out):
    """The torque that holds the chain still at q [N m] (their gravity compensation -B g(x), B = I)."""
    n = q.size
    A, b = P[:n * n].reshape((n, n)), P[n * n:n * n + n]
    chain._bias_with(A, b, q, np.zeros(n), out, np.empty(n), np.empty(n))


@njit(cache=True)
def measure(X, k, delay_steps, sigma_meas, normals_k, out):
    """Step 1 of the module's docstring into ``out`` (2n)."""
    row = max(k + 1 - delay_steps, 0)
    for i in range(out.size):
        out[i] = X[row, i] + sigma_meas[i] * normals_k[i]


@njit(cache=True)
def actuate(P, u, last, responsiveness, sigma_u, normals_k, perturbation, index, out):
    """Step 3 of the module's docstring into ``out`` (n) from the command ``u`` (n) and the last applied ``last``."""
    n = u.size
    limit = limits(P, n)
    for j in range(n):
        value = last[j] + responsiveness * (u[j] - last[j])
        value = value + sigma_u[j] * normals_k[2 * n + j]
        value = min(max(value, -limit[j]), limit[j])
        if index < perturbation.shape[1]:
            value += perturbation[j, index]
        out[j] = value


@njit(cache=True)
def advance(P, X, U, k, T, dt, u, responsiveness, sigma_u, normals_k, perturbation, work):
    """Steps 3 and 4: U[k] from the command u, X[k + 1] from X[k]; False once the state is not finite."""
    last = U[k - 1] if k > 0 else np.zeros(U.shape[1])
    actuate(P, u, last, responsiveness, sigma_u, normals_k, perturbation, int(T[k] / dt), U[k])
    X[k + 1] = X[k]
    rk4_step(P, X[k + 1], U[k], dt, work)
    return np.all(np.isfinite(X[k + 1]))


# --- the global policy test (their GlobalPolicyTestingControllerV2) -------------------------------------------

#: Layout of the reset record: mode, timer, counter, last t, count of PID errors, the PID's gains kp, ki, kd and its
#: time step, the reset length, the number of resets R, then the reset times (R + 1, the last infinite), the targets
#: (R + 1 rows of n angles, paa_mj's) and the PID's state per joint: the sum of its errors (n), its last two (2 n).
_MODE, _TIMER, _COUNT, _LAST_T, _NERR, _KP, _KI, _KD, _PID_DT, _LENGTH, _R, _TIMES = range(12)


def reset_record(reset_times, targets, length, kp=10.0, ki=0.1, kd=1.0, pid_dt=0.001) -> np.ndarray:
    """The record :func:`reset_command` keeps: R reset times [s] (their last, infinite, is added), R + 1 target
    angles (R + 1, n) [rad, paa_mj's], the reset's length [s], their PID's gains and its time step [s] (their
    wrapper keeps the PID's default 0.001 s whatever the simulation's step)."""
    times = np.append(np.asarray(reset_times, float), np.inf)
    targets = np.asarray(targets, float)
    head = np.zeros(_TIMES)
    head[[_KP, _KI, _KD, _PID_DT, _LENGTH, _R]] = kp, ki, kd, pid_dt, length, len(times) - 1
    return np.concatenate([head, times, targets.ravel(), np.zeros(3 * targets.shape[1])])


@njit(cache=True)
def reset_command(W, P, x, t, u):
    """Their reset wrapper: from each reset time on, for at least the reset's length, a PID on every joint towards
    a random target plus gravity compensation, instead of the controller. Writes ``u`` (n) and returns True while
    resetting; False: the controller acts. Their PID, for each joint j: e = target_j - x_j (no wrapping),
    u_j = kp e + ki dt_pid sum(e) + kd (e - e_prev) / dt_pid (the last term from the third error on, errors counted
    over every reset of the run), clipped to the joint's limit."""
    n = x.size // 2
    count, resets = int(W[_COUNT]), int(W[_R])
    targets = _TIMES + resets + 1
    state = targets + (resets + 1) * n
    if W[_MODE] == 0.0 and t >= W[_TIMES + count]:
        W[_MODE], W[_TIMER] = 1.0, 0.0
        W[_COUNT] = count + 1
    if W[_TIMER] > W[_LENGTH] and W[_MODE] == 1.0:
        W[_MODE] = 0.0
    if W[_MODE] == 0.0:
        W[_LAST_T] = t
        return False
    row = targets + (int(W[_COUNT]) - 1) * n
    W[_NERR] += 1.0
    limit = limits(P, n)
    grav = np.empty(n)
    gravity_torque(P, x[:n], grav)
    for j in range(n):
        e = W[row + j] - x[j]
        W[state + j] += e
        W[state + n + 2 * j], W[state + n + 2 * j + 1] = W[state + n + 2 * j + 1], e
        d = W[_KD] * (e - W[state + n + 2 * j]) / W[_PID_DT] if W[_NERR] > 2.0 else 0.0
        value = W[_KP] * e + W[_KI] * W[state + j] * W[_PID_DT] + d
        u[j] = min(max(value, -limit[j]), limit[j]) + grav[j]
    W[_TIMER] += t - W[_LAST_T]
    W[_LAST_T] = t
    return True


@njit(types.int64(KERNEL_TYPE, KERNEL_TYPE, KERNEL_TYPE, _C1, _C1, _C1, _C2, _C2, _C1, types.float64, types.int64, _C1,
                  types.float64, _C1, _C2, _C2, _C1), cache=True)
def rollout_compiled(first, second, condition, params, memory, P, X, U, T, dt, delay_steps, sigma_meas,
                     responsiveness, sigma_u, normals, perturbation, reset):
    """A whole rollout with a compiled controller (:func:`~paa_mj.sim.step.evaluate_once`): X (N + 1, 2n) holds x0
    in its first row and gets the states, U (N, n) the applied torques; ``reset``: the global-policy test's
    record (:func:`reset_command`), empty for none. Returns the steps run (N, or fewer when the state blew up)."""
    n = X.shape[1] // 2
    work = np.empty(work_size(n))
    x_meas, u, tau = np.empty(2 * n), np.zeros(n), np.empty(n - 1)
    for k in range(U.shape[0]):
        measure(X, k, delay_steps, sigma_meas, normals[k], x_meas)
        if reset.size == 0 or not reset_command(reset, P, x_meas, T[k], u):
            evaluate_once(first, second, condition, x_meas, T[k], params, memory, tau)
            u[0] = 0.0
            u[1:] = tau
        if not advance(P, X, U, k, T, dt, u, responsiveness, sigma_u, normals[k], perturbation, work):
            return k + 1
    return U.shape[0]
