"""RealAIGym's simulator, step for step, compiled: the physics and the disturbances of their benchmark protocols.

This is ``double_pendulum``'s ``Simulator.simulate`` (dfki-ric-underactuated-lab, commit 1e8544e6) for any
chain of the family, in their angles: q1 from hanging down (paa_mj's q1 + pi), so that hanging at rest is an
exact equilibrium here as it is in their code (sin 0 = 0, where sin(-pi) is 1.2e-16 and would start a swing of
its own); the controller sees paa_mj's angles, q1 - pi, at its boundary (:func:`measure_or_reset`).
Each step k, from the true state x_k at time t_k (t accumulated as ``t += dt``, as theirs is):

1. measurement: x_meas = x_{max(k + 1 - d, 0)} + N(0, sigma_meas), d = int(delay / dt) + 1 (the whole state is
   delayed, their ``delay_mode="posvel"``);
2. the controller's torques (one per motor of the robot) at (x_meas, t_k), x_meas in paa_mj's angles, as the
   command u (n: joint 1 first; zero on the joints without a motor, :func:`command`);
3. the motor: nu = nu_{k-1} + r (u - nu_{k-1}) + N(0, sigma_u), nu_{-1} = 0 (r the responsiveness), clipped to
   +-limit per joint, then the perturbation p_j[int(t_k / dt)] added; nu is what is recorded as the torque;
4. physics: x_{k+1} = RK4 over dt with nu held, of

   .. math:: M_r(q)\\,\\ddot q = B\\,\\nu - H(q, \\dot q) - G(q) - b\\,\\dot q - c_f \\arctan(100\\,\\dot q)

   where B = diag(limit_j != 0) (the plant of their robustness benchmark, given the limits, drops a torque on a
   joint without a motor, pulses included; their other two protocols' plant has B = I, which runs the same here:
   no torque reaches joint 1 in performance v2, and the global test drives every joint), b the viscous damping,
   c_f the Coulomb friction of their ``coulomb_vector`` (smooth, not MuJoCo's ``frictionloss``), and M_r the chain's mass matrix with their rotor inertia: every joint's motor has a rotor
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
from ..jit import lazy_njit
from ..sim.compiled.step import evaluate_once

_C1, _C2 = types.float64[::1], types.float64[:, ::1]


def plant_constants(m, l, lc, J, g, damping, coulomb, limit, rotor_inertia=0.0, gear_ratio=1.0,
                    actuated=None) -> np.ndarray:
    """The constants P of one plant (module docstring) from per-link arrays [SI units]; J about the COM, which may be
    negative here (their benchmark varies the first moment m r at a fixed pivot inertia I = J + m r^2); ``actuated``:
    the joints the controller's torques go to, 0-based (default joints 2..n). Layout, which the step's functions
    read by offsets: A (n n), -b (n) (:mod:`paa_mj.model.chain`'s gravity constants in their angles, from hanging
    down: b cos(phi) = -b cos(phi + pi)), damping (n), Coulomb (n), limit (n), the controller's motor of each joint
    (n, -1: none; :func:`paa_mj.model.chain.drive_map`), then I_r and g_r."""
    n = len(m)
    A, b = chain.chain_constants(SimpleNamespace(m=np.asarray(m, float), l=np.asarray(l, float),
                                                 lc=np.asarray(lc, float), J=np.asarray(J, float), g=float(g)))
    return np.concatenate([A.ravel(), -b, np.broadcast_to(damping, (n,)), np.broadcast_to(coulomb, (n,)),
                           np.broadcast_to(limit, (n,)), chain.drive_map(n, actuated),
                           [float(rotor_inertia), float(gear_ratio)]])


@register_jitable
def motors(P, n):
    """The number of the controller's torques the plant ``P`` of n joints takes (its driven joints)."""
    count = 0
    for i in range(n):
        if P[n * n + 4 * n + i] >= 0.0:
            count += 1
    return count


@register_jitable
def limits(P, n):
    """The torque limit of each of the n joints of the plant ``P`` [N m] (0: no motor there)."""
    return P[n * n + 3 * n:n * n + 4 * n]


@register_jitable
def inertia_constants(P, n):
    """The chain's inertia constants A (n, n) of the plant ``P``: the 2-d view the step's functions take beside it
    (every function here indexes arrays plainly, so that the device engine runs this very source)."""
    return P[:n * n].reshape((n, n))


@register_jitable
def work_size(n):
    """Scratch numbers the step needs for n links: zeros, phi, rate and a torque (4 n), then five states (10 n);
    besides it, the step takes an (n, n) and an (n, 1) array (:func:`scratch`)."""
    return 14 * n


@register_jitable
def scratch(n):
    """The scratch of one rollout's step: work (:func:`work_size`), the mass matrix (n, n), the force (n, 1)."""
    return np.empty(work_size(n)), np.empty((n, n)), np.empty((n, 1))


@register_jitable
def _acceleration(A, P, q, qd, tau, out, work, mass, force):
    """qdd of the module's equation into ``out`` (n); ``tau`` (n) per joint [N m]; ``work``, ``mass``, ``force``:
    scratch (:func:`scratch`)."""
    n = q.size
    zeros, phi, rate = work[0:n], work[n:2 * n], work[2 * n:3 * n]
    for i in range(n):
        zeros[i] = 0.0
    chain._mass_matrix_with(A, zeros, q, mass, phi)
    ir, gr = P[P.size - 2], P[P.size - 1]
    if ir != 0.0:
        mass[0, 0] += gr * gr * ir
        for j in range(1, n):
            mass[j - 1, j - 1] += ir
            mass[j, j] += gr * gr * ir
            mass[j - 1, j] -= gr * ir
            mass[j, j - 1] -= gr * ir
    chain._bias_with(A, P[n * n:n * n + n], q, qd, out, phi, rate)
    for i in range(n):
        drive = tau[i] if P[n * n + 3 * n + i] != 0.0 else 0.0
        damping, coulomb = P[n * n + n + i], P[n * n + 2 * n + i]
        force[i, 0] = drive - out[i] - damping * qd[i] - coulomb * math.atan(100.0 * qd[i])
    if not chain._solve_in_place(mass, force):
        for i in range(n):
            force[i, 0] = math.nan
    for i in range(n):
        out[i] = force[i, 0]


@register_jitable
def _field(A, P, x, tau, out, work, mass, force):
    n = x.size // 2
    _acceleration(A, P, x[0:n], x[n:2 * n], tau, out[n:2 * n], work, mass, force)
    for i in range(n):
        out[i] = x[n + i]


@register_jitable
def rk4_step(A, P, x, tau, dt, work, mass, force):
    """Their ``runge_integrator`` and ``step``: x + dt (k1 + 2 (k2 + k3) + k4) / 6, in place."""
    m = x.size
    base = 2 * m  # the acceleration's scratch is work[:base]
    k1, k2, k3, k4, y = (work[base:base + m], work[base + m:base + 2 * m], work[base + 2 * m:base + 3 * m],
                         work[base + 3 * m:base + 4 * m], work[base + 4 * m:base + 5 * m])
    _field(A, P, x, tau, k1, work, mass, force)
    for i in range(m):
        y[i] = x[i] + 0.5 * dt * k1[i]
    _field(A, P, y, tau, k2, work, mass, force)
    for i in range(m):
        y[i] = x[i] + 0.5 * dt * k2[i]
    _field(A, P, y, tau, k3, work, mass, force)
    for i in range(m):
        y[i] = x[i] + dt * k3[i]
    _field(A, P, y, tau, k4, work, mass, force)
    for i in range(m):
        x[i] = x[i] + dt * ((k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i]) / 6.0)


@register_jitable
def gravity_torque(A, P, q, out, work):
    """The torque that holds the chain still at q [N m] (their gravity compensation -B g(x), B = I)."""
    n = q.size
    zeros, phi, rate = work[0:n], work[n:2 * n], work[2 * n:3 * n]
    for i in range(n):
        zeros[i] = 0.0
    chain._bias_with(A, P[n * n:n * n + n], q, zeros, out, phi, rate)


@register_jitable
def measure(X, k, delay_steps, sigma_meas, normals_k, out):
    """Step 1 of the module's docstring into ``out`` (2n)."""
    row = max(k + 1 - delay_steps, 0)
    for i in range(out.size):
        out[i] = X[row, i] + sigma_meas[i] * normals_k[i]


@register_jitable
def actuate(P, u, U, k, responsiveness, sigma_u, normals_k, perturbation, pulses, index):
    """Step 3 of the module's docstring into ``U[k]`` (n) from the command ``u`` (n) and the last applied
    ``U[k - 1]`` (none before step 0); the first ``pulses`` columns of ``perturbation`` are the pulses."""
    n = u.size
    for j in range(n):
        last = 0.0
        if k > 0:  # a statement, not an expression: the device evaluates both sides of an expression
            last = U[k - 1, j]
        limit = P[n * n + 3 * n + j]
        value = last + responsiveness * (u[j] - last)
        value = value + sigma_u[j] * normals_k[2 * n + j]
        value = min(max(value, -limit), limit)
        if index < pulses:
            value += perturbation[j, index]
        U[k, j] = value


@register_jitable
def advance(A, P, X, U, k, T, dt, u, responsiveness, sigma_u, normals_k, perturbation, pulses, work, mass, force):
    """Steps 3 and 4: U[k] from the command u, X[k + 1] from X[k]; False once the state is not finite."""
    actuate(P, u, U, k, responsiveness, sigma_u, normals_k, perturbation, pulses, int(T[k] / dt))
    m = X.shape[1]
    for i in range(m):
        X[k + 1, i] = X[k, i]
    rk4_step(A, P, X[k + 1], U[k], dt, work, mass, force)
    finite = True
    for i in range(m):
        if not math.isfinite(X[k + 1, i]):
            finite = False
    return finite


@register_jitable
def command(P, u, tau):
    """The controller's torques ``tau`` (one per motor) as the command ``u`` (n) of the plant ``P``: each on the
    joint its motor drives, zero on the others (joint 1 for the paper's family)."""
    n = u.size
    for j in range(n):
        motor = int(P[n * n + 4 * n + j])
        value = 0.0
        if motor >= 0:  # a statement, not an expression: the device evaluates both sides of an expression
            value = tau[motor]
        u[j] = value


# --- the global policy test (their GlobalPolicyTestingControllerV2) -------------------------------------------

#: Layout of the reset record: mode, timer, counter, last t, count of PID errors, the PID's gains kp, ki, kd and its
#: time step, the reset length, the number of resets R, then the reset times (R + 1, the last infinite), the targets
#: (R + 1 rows of n angles, theirs) and the PID's state per joint: the sum of its errors (n), its last two (2 n).
_MODE, _TIMER, _COUNT, _LAST_T, _NERR, _KP, _KI, _KD, _PID_DT, _LENGTH, _R, _TIMES = range(12)


def reset_record(reset_times, targets, length, kp=10.0, ki=0.1, kd=1.0, pid_dt=0.001) -> np.ndarray:
    """The record :func:`reset_command` keeps: R reset times [s] (their last, infinite, is added), R + 1 target
    angles (R + 1, n) [rad, theirs], the reset's length [s], their PID's gains and its time step [s] (their
    wrapper keeps the PID's default 0.001 s whatever the simulation's step)."""
    times = np.append(np.asarray(reset_times, float), np.inf)
    targets = np.asarray(targets, float)
    head = np.zeros(_TIMES)
    head[[_KP, _KI, _KD, _PID_DT, _LENGTH, _R]] = kp, ki, kd, pid_dt, length, len(times) - 1
    return np.concatenate([head, times, targets.ravel(), np.zeros(3 * targets.shape[1])])


@register_jitable
def reset_command(W, A, P, x, t, u, work):
    """Their reset wrapper: from each reset time on, for at least the reset's length, a PID on every joint towards
    a random target plus gravity compensation, instead of the controller. Writes ``u`` (n) and returns True while
    resetting; False: the controller acts. Their PID, for each joint j: e = target_j - x_j (no wrapping),
    u_j = kp e + ki dt_pid sum(e) + kd (e - e_prev) / dt_pid (the last term from the third error on, errors counted
    over every reset of the run), clipped to the joint's limit. ``work``: the step's scratch."""
    n = x.size // 2
    count, resets = int(W[_COUNT]), int(W[_R])
    targets = _TIMES + resets + 1
    state = targets + (resets + 1) * n
    if W[_MODE] == 0.0 and t >= W[_TIMES + count]:
        W[_MODE] = 1.0
        W[_TIMER] = 0.0
        W[_COUNT] += 1.0
    if W[_TIMER] > W[_LENGTH] and W[_MODE] == 1.0:
        W[_MODE] = 0.0
    if W[_MODE] == 0.0:
        W[_LAST_T] = t
        return False
    row = targets + (int(W[_COUNT]) - 1) * n
    W[_NERR] += 1.0
    grav = work[3 * n:4 * n]
    gravity_torque(A, P, x[0:n], grav, work)
    for j in range(n):
        limit = P[n * n + 3 * n + j]
        e = W[row + j] - x[j]
        W[state + j] += e
        W[state + n + 2 * j] = W[state + n + 2 * j + 1]
        W[state + n + 2 * j + 1] = e
        d = W[_KD] * (e - W[state + n + 2 * j]) / W[_PID_DT] if W[_NERR] > 2.0 else 0.0
        value = W[_KP] * e + W[_KI] * W[state + j] * W[_PID_DT] + d
        u[j] = min(max(value, -limit), limit) + grav[j]
    W[_TIMER] += t - W[_LAST_T]
    W[_LAST_T] = t
    return True


@register_jitable
def measure_or_reset(A, P, X, k, T, delay_steps, sigma_meas, normals_k, reset, resetting, x_meas, seen, u, work):
    """Step 1 into ``x_meas`` (their angles), then the global test's reset (``resetting``: a run with a reset record
    ``reset``): True where the controller is to act on ``seen``, the measurement in paa_mj's angles (q1 - pi),
    False where the reset has written the command ``u``."""
    measure(X, k, delay_steps, sigma_meas, normals_k, x_meas)
    if resetting:  # two statements, not "and": the device may evaluate both sides of an expression
        if reset_command(reset, A, P, x_meas, T[k], u, work):
            return False
    for i in range(x_meas.size):
        seen[i] = x_meas[i]
    seen[0] = x_meas[0] - math.pi
    return True


@lazy_njit(types.int64(KERNEL_TYPE, KERNEL_TYPE, KERNEL_TYPE, _C1, _C1, _C1, _C2, _C2, _C1, types.float64, types.int64, _C1,
                  types.float64, _C1, _C2, _C2, _C1), cache=True, nogil=True)
def rollout_compiled(first, second, condition, params, memory, P, X, U, T, dt, delay_steps, sigma_meas,
                     responsiveness, sigma_u, normals, perturbation, reset):
    """A whole rollout with a compiled controller (:func:`~paa_mj.sim.compiled.step.evaluate_once`): X (N + 1, 2n) holds x0
    in its first row and gets the states (their angles), U (N, n) the applied torques; ``reset``: the global-policy
    test's record (:func:`reset_command`), empty for none. Returns the steps run (N, or fewer when the state blew
    up). Releases the GIL: rollouts run on threads side by side. The device engine
    (:mod:`paa_mj.realaigym.simulator_warp`) runs this loop's body."""
    n = X.shape[1] // 2
    A = inertia_constants(P, n)
    work, mass, force = scratch(n)
    x_meas, seen, u, tau = np.empty(2 * n), np.empty(2 * n), np.zeros(n), np.empty(motors(P, n))
    resetting, pulses = reset.size > 0, perturbation.shape[1]
    for k in range(U.shape[0]):
        if measure_or_reset(A, P, X, k, T, delay_steps, sigma_meas, normals[k], reset, resetting, x_meas, seen, u,
                            work):
            evaluate_once(first, second, condition, seen, T[k], params, memory, tau)
            command(P, u, tau)
        if not advance(A, P, X, U, k, T, dt, u, responsiveness, sigma_u, normals[k], perturbation, pulses, work,
                       mass, force):
            return k + 1
    return U.shape[0]


#: The step's two stages compiled on their own, for a controller called from Python between them.
measure_or_reset_compiled = njit(cache=True)(measure_or_reset)
advance_compiled = njit(cache=True)(advance)
