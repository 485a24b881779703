"""The virtual composite link (VCL) of links 2 and 3, (13)-(21).

Links 2 and 3 act on gravity like one virtual link whose angle from link 1 is
q2 + theta(q3) and whose gravity constant is beta2bar(q3). Like
:mod:`paa_mj.model.equations`, each function runs on scalars or NumPy arrays
and compiles inside numba kernels. Angles in rad, b2, b3 and beta2bar in J.
"""
from __future__ import annotations

import numpy as np
from numba.extending import register_jitable


@register_jitable
def beta2bar_squared(b2, b3, q3):
    """beta2bar(q3)^2 = b2^2 + b3^2 + 2 b2 b3 cos q3, from (16) [J^2]."""
    return b2 * b2 + b3 * b3 + 2.0 * b2 * b3 * np.cos(q3)


@register_jitable
def beta2bar(b2, b3, q3):
    """beta2bar(q3) = sqrt(b2^2 + b3^2 + 2 b2 b3 cos q3) (16) [J]."""
    return np.sqrt(beta2bar_squared(b2, b3, q3))


@register_jitable
def theta(b2, b3, q3):
    """Angle of the VCL relative to link 2, (17): theta(0) = 0 [rad].

    sin theta = b3 sin q3 / beta2bar and cos theta = (b2 + b3 cos q3) / beta2bar,
    so theta = atan2(b3 sin q3, b2 + b3 cos q3).
    """
    return np.arctan2(b3 * np.sin(q3), b2 + b3 * np.cos(q3))


@register_jitable
def psi(b2, b3, q3):
    """psi(q3) = d theta / d q3 = b3 (b3 + b2 cos q3) / beta2bar^2 (20)."""
    return b3 * (b3 + b2 * np.cos(q3)) / beta2bar_squared(b2, b3, q3)


def qbar_a(b2, b3, q2, q3):
    """VCL coordinates qbar_a = [q2 + theta(q3), q3] (13), (18); shape (..., 2)."""
    return np.stack([q2 + theta(b2, b3, q3), np.broadcast_to(q3, np.shape(q2 + q3))], -1)


def Psi(b2, b3, q3):
    """Psi(q3) = [[1, psi], [0, 1]] (21), so that d qbar_a / dt = Psi qd_a; shape (..., 2, 2)."""
    p = psi(b2, b3, q3)
    one, zero = np.ones_like(p), np.zeros_like(p)
    return np.stack([np.stack([one, p], -1), np.stack([zero, one], -1)], -2)
