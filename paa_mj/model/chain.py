"""The equation of motion of any planar chain on the bar: n >= 2 links, m motors on the driven joints.

.. math::

    M(q)\\,\\ddot q + H(q, \\dot q) + G(q) + D\\,\\dot q = B\\,\\tau, \\qquad
    B = \\begin{bmatrix} e_{a_1} & \\cdots & e_{a_m} \\end{bmatrix}

B's columns are the unit vectors of the driven joints a_1 < ... < a_m (by default joints 2..n, joint 1 on
the bar passive: :math:`B = [0; I_{n-1}]`, the paper's family; a pendubot drives joint 1 alone).

q are the relative joint angles [rad] (q1 of link 1 from the upward vertical, q_k of
link k from link k-1), :math:`\\phi = T q` the absolute angles (:math:`\\phi_k = q_1 + \\dots + q_k`,
T lower-triangular ones). With :math:`S_k = m_{k+1} + \\dots + m_n`, the chain's constants are

.. math::

    A_{kk} = J_k + m_k l_{c,k}^2 + l_k^2 S_k, \\qquad
    A_{ij} = l_i (m_j l_{c,j} + l_j S_j) \\;(i < j), \\qquad
    b_k = g (m_k l_{c,k} + l_k S_k),

and in absolute angles :math:`M^{abs}_{ij} = A_{ij} \\cos(\\phi_i - \\phi_j)`, the Coriolis and
centrifugal forces :math:`c_i = \\sum_j A_{ij} \\sin(\\phi_i - \\phi_j) \\dot\\phi_j^2` and the potential
:math:`P = \\sum_k b_k \\cos \\phi_k`. Joint space follows by :math:`M = T^T M^{abs} T + \\mathrm{diag}(a)`
(a the armature), :math:`H = T^T c`, :math:`G = T^T \\nabla_\\phi P`; D = diag(d) is the joints'
viscous damping. For n = 3 without damping and armature these are the paper's (2)-(7), whose
closed forms live in :mod:`paa_mj.model.equations`; the tests check that the two agree.

The formulas are written once, for one state, compiled by numba (the compiled controllers call
them); the ``batch_*`` functions run them over NumPy batches of any leading shape (``q``, ``qd`` of
shape (..., n)) for :class:`~paa_mj.model.dynamics.AnalyticModel`.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit
from numba.extending import register_jitable


def chain_constants(params):
    """The constants (A, b) of a :class:`~paa_mj.model.params.RobotParams` (module docstring).

    Returns
    -------
    A : ndarray (n, n)
        Symmetric inertia constants [kg m^2].
    b : ndarray (n,)
        Gravity constants [J]: link k's mass moment about its joint plus that of the links below it, times g.
    """
    m, l, lc, J = params.m, params.l, params.lc, params.J
    below = np.concatenate([np.cumsum(m[::-1])[::-1][1:], [0.0]])  # S_k = m_{k+1} + ... + m_n
    moment = m * lc + l * below  # about joint k, per unit of cos(phi_k)
    upper = np.triu(l[:, None] * moment[None, :], 1)
    A = upper + upper.T + np.diag(J + m * lc**2 + l**2 * below)
    return A, params.g * moment


def input_matrix(n, actuated=None):
    """B (n, m): the motors act on the 0-based joints ``actuated`` (default 1..n-1: joints 2..n, joint 1, the hands
    on the bar, passive)."""
    return np.eye(n)[:, list(range(1, n) if actuated is None else actuated)]


def drive_map(n, actuated=None) -> np.ndarray:
    """For each of the n joints, the index of the motor that drives it, -1 where none (floats, as kernel constants
    carry it): the form of B the compiled :func:`acceleration_into` reads."""
    out = np.full(n, -1.0)
    for k, j in enumerate(range(1, n) if actuated is None else actuated):
        out[j] = float(k)
    return out


# --- one state, compiled ---------------------------------------------------------------------------------

@register_jitable
def matrix_view(work, start, rows, cols):
    """``work[start:start + rows cols]`` as a (rows, cols) matrix that shares its numbers: how a compiled law takes
    its 2-d scratch from one flat float64 array, as :func:`paa_mj.sim.warp.translate` runs it on a Warp device too.
    ``work`` must be contiguous (a controller's memory is): NumPy would copy another silently."""
    return np.ascontiguousarray(work[start:start + rows * cols]).reshape((rows, cols))


@register_jitable
def vector_view(work, start, length):
    """``work[start:start + length]``, typed contiguous (so that the chain's functions compile once for it)."""
    return np.ascontiguousarray(work[start:start + length])


@njit(cache=True)
def absolute_angles(q, out):
    """phi = T q into ``out``: each link's angle from the upward vertical [rad]."""
    total = 0.0
    for i in range(q.size):
        total += q[i]
        out[i] = total


@njit(cache=True)
def mass_matrix_into(A, armature, q, M):
    """M(q) = T^T (A_ij cos(phi_i - phi_j)) T + diag(armature) into ``M`` (n, n) [kg m^2]."""
    _mass_matrix_with(A, armature, q, M, np.empty(q.size))


@njit(cache=True)
def _mass_matrix_with(A, armature, q, M, phi):
    """:func:`mass_matrix_into` with ``phi`` (n) as scratch space."""
    n = q.size
    absolute_angles(q, phi)
    for i in range(n):
        for j in range(n):
            M[i, j] = A[i, j] * math.cos(phi[i] - phi[j])
    relative_coordinates_into(M, armature)


@njit(cache=True)
def relative_coordinates_into(M, armature):
    """X (n, n) in absolute angles to T^T X T + diag(armature) in the joint angles, in place [kg m^2]: T is the
    lower triangle of ones (phi = T q), so T^T X T is suffix sums over rows, then over columns."""
    n = M.shape[0]
    for i in range(n - 2, -1, -1):
        for j in range(n):
            M[i, j] += M[i + 1, j]
    for j in range(n - 2, -1, -1):
        for i in range(n):
            M[i, j] += M[i, j + 1]
    for i in range(n):
        M[i, i] += armature[i]


@njit(cache=True)
def bias_into(A, b, q, qd, out):
    """H(q, qd) + G(q) = T^T (c + grad_phi P) into ``out`` (n) [N m] (MuJoCo's ``qfrc_bias``)."""
    _bias_with(A, b, q, qd, out, np.empty(q.size), np.empty(q.size))


@njit(cache=True)
def _bias_with(A, b, q, qd, out, phi, rate):
    """:func:`bias_into` with ``phi`` and ``rate`` (n) as scratch space."""
    n = q.size
    absolute_angles(q, phi)
    absolute_angles(qd, rate)
    for i in range(n):
        total = -b[i] * math.sin(phi[i])
        for j in range(n):
            total += A[i, j] * math.sin(phi[i] - phi[j]) * rate[j] * rate[j]
        out[i] = total
    for i in range(n - 2, -1, -1):
        out[i] += out[i + 1]


@njit(cache=True)
def potential(b, q):
    """P(q) = sum_k b_k cos phi_k [J]."""
    total, phi = 0.0, 0.0
    for i in range(q.size):
        phi += q[i]
        total += b[i] * math.cos(phi)
    return total


@njit(cache=True)
def kinetic(M, qd):
    """1/2 qd^T M qd [J]."""
    total = 0.0
    for i in range(qd.size):
        for j in range(qd.size):
            total += qd[i] * M[i, j] * qd[j]
    return 0.5 * total


@njit(cache=True)
def gravity_jacobian_into(b, q, out):
    """dG/dq = T^T diag(-b_k cos phi_k) T into ``out`` (n, n): (i, j) -> sum over k >= max(i, j) [N m/rad]."""
    n = q.size
    phi = np.empty(n)
    absolute_angles(q, phi)
    tail = np.empty(n)
    total = 0.0
    for k in range(n - 1, -1, -1):
        total += -b[k] * math.cos(phi[k])
        tail[k] = total
    for i in range(n):
        for j in range(n):
            out[i, j] = tail[max(i, j)]


@njit(cache=True)
def _solve_in_place(a, x):
    """Solve ``a`` X = ``x`` for a small square system, ``a`` (n, n) and ``x`` (n, k), by Gaussian elimination with
    partial pivoting, in place: ``x`` becomes the solution and ``a`` is overwritten; False (``x`` left partly
    eliminated) where a pivot is exactly zero, so that a law that meets a singular point can return a non-finite
    torque, which the engines report."""
    n, k = x.shape[0], x.shape[1]
    for col in range(n):
        pivot = col
        for row in range(col + 1, n):
            if abs(a[row, col]) > abs(a[pivot, col]):
                pivot = row
        if a[pivot, col] == 0.0:
            return False
        if pivot != col:
            for j in range(n):
                a[col, j], a[pivot, j] = a[pivot, j], a[col, j]
            for j in range(k):
                x[col, j], x[pivot, j] = x[pivot, j], x[col, j]
        for row in range(col + 1, n):
            factor = a[row, col] / a[col, col]
            for j in range(col, n):
                a[row, j] -= factor * a[col, j]
            for j in range(k):
                x[row, j] -= factor * x[col, j]
    for row in range(n - 1, -1, -1):
        for j in range(k):
            total = x[row, j]
            for c in range(row + 1, n):
                total -= a[row, c] * x[c, j]
            x[row, j] = total / a[row, row]
    return True


#: Scratch numbers :func:`acceleration_into` needs for n links: ACCELERATION_WORK[0] n^2 + ACCELERATION_WORK[1] n.
ACCELERATION_WORK = (1, 4)


@njit(cache=True)
def acceleration_into(A, b, damping, armature, drive, q, qd, tau, out, work):
    """qdd = M(q)^-1 (B tau - H - G - D qd) into ``out`` (n) [rad/s^2]; ``tau`` (m) the motors' torques [N m],
    ``drive`` (n) the motor of each joint (:func:`drive_map`: B); ``work``: scratch space of n^2 + 4 n numbers
    (:data:`ACCELERATION_WORK`; nothing is allocated). Solved as :func:`_solve_in_place` solves (NaN for a singular
    M, which a rigid chain never has)."""
    n = q.size
    mass, force = matrix_view(work, 0, n, n), matrix_view(work, n * n + 2 * n, n, 1)
    phi, rate = vector_view(work, n * n, n), vector_view(work, n * n + n, n)
    _mass_matrix_with(A, armature, q, mass, phi)
    _bias_with(A, b, q, qd, out, phi, rate)
    for i in range(n):
        motor = int(drive[i])
        force[i, 0] = (tau[motor] if motor >= 0 else 0.0) - out[i] - damping[i] * qd[i]
    if not _solve_in_place(mass, force):
        force[:, 0] = np.nan
    for i in range(n):
        out[i] = force[i, 0]


# --- NumPy batches -----------------------------------------------------------------------------------------

@njit(cache=True)
def _mass_rows(A, armature, q, out):
    for r in range(q.shape[0]):
        mass_matrix_into(A, armature, q[r], out[r])


@njit(cache=True)
def _bias_rows(A, b, q, qd, out):
    for r in range(q.shape[0]):
        bias_into(A, b, q[r], qd[r], out[r])


@njit(cache=True)
def _potential_rows(b, q, out):
    for r in range(q.shape[0]):
        out[r] = potential(b, q[r])


@njit(cache=True)
def _gravity_jacobian_rows(b, q, out):
    for r in range(q.shape[0]):
        gravity_jacobian_into(b, q[r], out[r])


def _rows(*arrays):
    """The arrays broadcast together and flattened to (rows, n), and the batch shape.

    Contiguous and writable (read-only inputs, such as a task's goal, copied): a kernel compiled for
    one array type serves every call."""
    arrays = np.broadcast_arrays(*(np.asarray(a, float) for a in arrays))
    shape = arrays[0].shape
    return [np.require(a.reshape(-1, shape[-1]), float, ("C", "W")) for a in arrays], shape[:-1]


def batch_mass_matrix(A, armature, q):
    """M(q) over a batch, shape (..., n, n)."""
    (q,), batch = _rows(q)
    out = np.empty(q.shape + (q.shape[1],))
    _mass_rows(A, np.asarray(armature, float), q, out)
    return out.reshape(batch + out.shape[1:])


def batch_bias(A, b, q, qd):
    """H(q, qd) + G(q) over a batch, shape (..., n)."""
    (q, qd), batch = _rows(q, qd)
    out = np.empty(q.shape)
    _bias_rows(A, b, q, qd, out)
    return out.reshape(batch + out.shape[1:])


def batch_potential(b, q):
    """P(q) over a batch, shape (...)."""
    (q,), batch = _rows(q)
    out = np.empty(q.shape[0])
    _potential_rows(b, q, out)
    return out.reshape(batch)


def batch_gravity_jacobian(b, q):
    """dG/dq over a batch, shape (..., n, n)."""
    (q,), batch = _rows(q)
    out = np.empty(q.shape + (q.shape[1],))
    _gravity_jacobian_rows(b, q, out)
    return out.reshape(batch + out.shape[1:])
