"""Compiled (numba) kernel of the hybrid controller (40) + (67) + (68), for lean rollouts.

The same mathematics as :class:`~paa_mj.controllers.SwitchingController`, written
for one state with scalars so that numba compiles it to a few hundred machine
instructions: a closed-loop MuJoCo step then costs little more than ``mj_step``
(see ``paa-mj bench``). Results equal the NumPy controllers to rounding (the
3x3 inverse is by cofactors here, by LU in NumPy); the tests check it.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .controllers import SWITCH_ANGLE, SWITCH_SPEED, SwitchingController

# Layout of the constants vector: robot constants, gains, saturation, switch enabled.
A11, A22, A33, A12, A13, A23, B1, B2, B3, E_R, KD, KP, KV, LIMIT, ENABLED = range(15)
TWO_PI = 2.0 * math.pi


def kernel_constants(controller: SwitchingController) -> tuple[np.ndarray, np.ndarray]:
    """(constants, K) for the kernels, from a SwitchingController."""
    sw, am = controller.swing_up, controller.swing_up.model
    limit = math.inf if controller.torque_limit is None else float(controller.torque_limit)
    consts = np.array([am.a11, am.a22, am.a33, am.a12, am.a13, am.a23, am.b1, am.b2, am.b3, am.E_r,
                       sw.kD, sw.kP, sw.kV, limit, 1.0 if controller.enabled else 0.0])
    return consts, np.ascontiguousarray(controller.balance.K, dtype=np.float64)


@njit(cache=True)
def _wrap(a):
    return math.pi - (math.pi - a) % TWO_PI


@njit(cache=True)
def hybrid_torque(q1, q2, q3, d1, d2, d3, c, K, mode, out):
    """Torques [tau2, tau3] into ``out``; returns the new mode (0 swing-up, 1 balance), -1 if non-finite."""
    x1, x2, x3 = _wrap(q1), _wrap(q2 + math.pi), _wrap(q3)
    if mode == 0 and c[ENABLED] != 0.0:
        if (abs(x1) < SWITCH_ANGLE and abs(x2) < SWITCH_ANGLE and abs(x3) < SWITCH_ANGLE
                and abs(d1) < SWITCH_SPEED and abs(d2) < SWITCH_SPEED and abs(d3) < SWITCH_SPEED):
            mode = 1
    if mode == 1:
        t2 = -(K[0, 0] * x1 + K[0, 1] * x2 + K[0, 2] * x3 + K[0, 3] * d1 + K[0, 4] * d2 + K[0, 5] * d3)
        t3 = -(K[1, 0] * x1 + K[1, 1] * x2 + K[1, 2] * x3 + K[1, 3] * d1 + K[1, 4] * d2 + K[1, 5] * d3)
    else:
        a11, a22, a33, a12, a13, a23 = c[A11], c[A22], c[A33], c[A12], c[A13], c[A23]
        b1, b2, b3 = c[B1], c[B2], c[B3]
        c2, c3, c23 = math.cos(q2), math.cos(q3), math.cos(q2 + q3)
        s2, s3, s23 = math.sin(q2), math.sin(q3), math.sin(q2 + q3)
        # inertia matrix (2)
        m33 = a33
        m23 = a33 + a23 * c3
        m22 = a22 + a33 + 2.0 * a23 * c3
        m13 = a33 + a13 * c23 + a23 * c3
        m12 = a22 + a33 + a12 * c2 + a13 * c23 + 2.0 * a23 * c3
        m11 = a11 + a22 + a33 + 2.0 * a12 * c2 + 2.0 * a13 * c23 + 2.0 * a23 * c3
        # M^-1 by cofactors (symmetric)
        k11 = m22 * m33 - m23 * m23
        k12 = m13 * m23 - m12 * m33
        k13 = m12 * m23 - m13 * m22
        det = m11 * k11 + m12 * k12 + m13 * k13
        i12, i13 = k12 / det, k13 / det
        i22 = (m11 * m33 - m13 * m13) / det
        i23 = (m12 * m13 - m11 * m23) / det
        i33 = (m11 * m22 - m12 * m12) / det
        # H + G
        h1 = (-a12 * (2 * d1 + d2) * d2 * s2 - a13 * (2 * d1 + d2 + d3) * (d2 + d3) * s23
              - a23 * (2 * d1 + 2 * d2 + d3) * d3 * s3)
        h2 = a12 * d1 * d1 * s2 + a13 * d1 * d1 * s23 - a23 * (2 * d1 + 2 * d2 + d3) * d3 * s3
        h3 = a13 * d1 * d1 * s23 + a23 * (d1 + d2) * (d1 + d2) * s3
        q12 = q1 + q2
        g3 = -b3 * math.sin(q12 + q3)
        g2 = -b2 * math.sin(q12) + g3
        g1 = -b1 * math.sin(q1) + g2
        f1, f2, f3 = h1 + g1, h2 + g2, h3 + g3
        # energy (6)
        kinetic = 0.5 * (m11 * d1 * d1 + m22 * d2 * d2 + m33 * d3 * d3
                         + 2.0 * (m12 * d1 * d2 + m13 * d1 * d3 + m23 * d2 * d3))
        potential = b1 * math.cos(q1) + b2 * math.cos(q12) + b3 * math.cos(q12 + q3)
        de = kinetic + potential - c[E_R]
        kD, kP, kV = c[KD], c[KP], c[KV]
        # Lambda (38)
        l11, l12, l22 = de + kD * i22, kD * i23, de + kD * i33
        # VCL error e and psi (13), (20)
        bb2 = b2 * b2 + b3 * b3 + 2.0 * b2 * b3 * c3
        e1 = q2 + math.atan2(b3 * s3, b2 + b3 * c3) + math.pi
        e2 = q3
        psi = b3 * (b3 + b2 * c3) / bb2
        r1 = kD * (i12 * f1 + i22 * f2 + i23 * f3) - kV * d2 - kP * e1
        r2 = kD * (i13 * f1 + i23 * f2 + i33 * f3) - kV * d3 - kP * (psi * e1 + e2)
        ldet = l11 * l22 - l12 * l12
        t2 = (l22 * r1 - l12 * r2) / ldet
        t3 = (l11 * r2 - l12 * r1) / ldet
    lim = c[LIMIT]
    t2 = min(max(t2, -lim), lim)
    t3 = min(max(t3, -lim), lim)
    out[0], out[1] = t2, t3
    if not (math.isfinite(t2) and math.isfinite(t3)):
        return -1
    return mode


@njit(cache=True)
def control_step(qpos, qvel, ctrl, c, K, mode):
    """Read one MjData's qpos/qvel, write its ctrl; returns the mode (-1: non-finite torque)."""
    return hybrid_torque(qpos[0], qpos[1], qpos[2], qvel[0], qvel[1], qvel[2], c, K, mode, ctrl)


@njit(cache=True)
def control_batch(qpos, qvel, ctrl, c, K, modes):
    """Batch version: qpos, qvel (N, 3), ctrl (N, 2), per-rollout constants c (N, 15) and modes (N,).

    Serial on purpose: about 0.1 us per state, and numba's worker threads would
    compete for the cores with MuJoCo's rollout threads between steps.
    """
    for i in range(qpos.shape[0]):
        modes[i] = hybrid_torque(qpos[i, 0], qpos[i, 1], qpos[i, 2], qvel[i, 0], qvel[i, 1], qvel[i, 2],
                                 c[i], K[i], modes[i], ctrl[i])
