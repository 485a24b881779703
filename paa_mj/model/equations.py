"""The equation of motion (1)-(7), written once for NumPy and for compiled code.

.. math::

    M(q)\\,\\ddot q + H(q, \\dot q) + G(q) = B\\,\\tau, \\qquad
    B = \\begin{bmatrix} 0 & 0 \\\\ 1 & 0 \\\\ 0 & 1 \\end{bmatrix}

Every function here is plain Python over scalars *or* NumPy arrays (elementwise,
any broadcastable shapes) and is registered with numba
(:func:`numba.extending.register_jitable`): called from Python it runs as NumPy
on whole batches; called from an ``@njit`` kernel (the controllers' compiled
forms) it is compiled for scalars. So :class:`~paa_mj.model.dynamics.AnalyticModel`,
the controllers' batched ``torque`` and their compiled kernels all evaluate the
same expressions, in the same order.

``c`` is the vector of robot constants (3), (4) laid out as :data:`CONSTANTS`
(see :func:`robot_constants`); angles are in rad, speeds in rad/s, torques in
N m, energies in J. The model is described in ``docs/model.md``.
"""
from __future__ import annotations

import numpy as np
from numba.extending import register_jitable

#: Layout of the robot-constant vector ``c``: inertia constants (3) [kg m^2], gravity constants (4) [J].
CONSTANTS = ("a11", "a22", "a33", "a12", "a13", "a23", "b1", "b2", "b3")
A11, A22, A33, A12, A13, A23, B1, B2, B3 = range(len(CONSTANTS))


#: How to get CasADi (what plans, TVLQR and certificates need).
PLAN_INSTALL = "pip install 'paa_mj[plan]'"


def casadi_module():
    """CasADi, set so that the NumPy calls of these formulas return CasADi values on CasADi symbols.

    The formulas then build symbolic expressions as they are, for exact derivatives
    (:mod:`paa_mj.control.trajopt`, :mod:`paa_mj.control.tvlqr`, :mod:`paa_mj.theory.sos`). CasADi is the
    extra ``plan`` (not needed by ``paa-mj reproduce``): without it, a one-line :class:`~paa_mj.errors.PaaError`
    naming the install.
    """
    try:
        import casadi
    except ImportError as err:
        from ..errors import PaaError

        raise PaaError(f"planned kips (trajopt, TVLQR) and sums-of-squares certificates need CasADi, not installed"
                       f" here ({err}): {PLAN_INSTALL}") from None

    try:  # CasADi 3.8+: numpy functions on CasADi values return CasADi values, silently
        casadi.GlobalOptions.setNumpyMode(-1)
    except AttributeError:
        pass
    return casadi


def robot_constants(params) -> np.ndarray:
    """The constants (3), (4) of a :class:`~paa_mj.model.params.RobotParams`, as the vector ``c``.

    a11 = J1 + m1 lc1^2 + (m2 + m3) l1^2,  a22 = J2 + m2 lc2^2 + m3 l2^2,  a33 = J3 + m3 lc3^2,
    a12 = (m2 lc2 + m3 l2) l1,  a13 = m3 l1 lc3,  a23 = m3 l2 lc3                      [kg m^2]
    b1 = (m1 lc1 + m2 l1 + m3 l1) g,  b2 = (m2 lc2 + m3 l2) g,  b3 = m3 lc3 g            [J]
    """
    m1, m2, m3 = params.m
    l1, l2, _ = params.l
    c1, c2, c3 = params.lc
    J1, J2, J3 = params.J
    g = params.g
    return np.array([
        J1 + m1 * c1**2 + (m2 + m3) * l1**2,
        J2 + m2 * c2**2 + m3 * l2**2,
        J3 + m3 * c3**2,
        (m2 * c2 + m3 * l2) * l1,
        m3 * l1 * c3,
        m3 * l2 * c3,
        (m1 * c1 + m2 * l1 + m3 * l1) * g,
        (m2 * c2 + m3 * l2) * g,
        m3 * c3 * g,
    ])


@register_jitable
def udd_energy(c):
    """E_r = b1 - b2 - b3 (9): the energy of the folded up-down-down equilibrium [J]."""
    return c[B1] - c[B2] - c[B3]


@register_jitable
def inertia(c, q2, q3):
    """The entries (m11, m12, m13, m22, m23, m33) of the symmetric M(q) of (2) [kg m^2]."""
    a22, a33, a12, a13, a23 = c[A22], c[A33], c[A12], c[A13], c[A23]
    c2, c3, c23 = np.cos(q2), np.cos(q3), np.cos(q2 + q3)
    m33 = a33 + 0.0 * c2
    m23 = a33 + a23 * c3
    m22 = a22 + a33 + 2.0 * a23 * c3
    m13 = a33 + a13 * c23 + a23 * c3
    m12 = a22 + a33 + a12 * c2 + a13 * c23 + 2.0 * a23 * c3
    m11 = c[A11] + a22 + a33 + 2.0 * a12 * c2 + 2.0 * a13 * c23 + 2.0 * a23 * c3
    return m11, m12, m13, m22, m23, m33


@register_jitable
def inverse_inertia(m11, m12, m13, m22, m23, m33):
    """The entries (i11, i12, i13, i22, i23, i33) of M^-1, by cofactors (M is symmetric positive definite)."""
    k11 = m22 * m33 - m23 * m23
    k12 = m13 * m23 - m12 * m33
    k13 = m12 * m23 - m13 * m22
    det = m11 * k11 + m12 * k12 + m13 * k13
    return (k11 / det, k12 / det, k13 / det, (m11 * m33 - m13 * m13) / det, (m12 * m13 - m11 * m23) / det,
            (m11 * m22 - m12 * m12) / det)


@register_jitable
def coriolis(c, q2, q3, d1, d2, d3):
    """The Coriolis and centrifugal terms (h1, h2, h3) = H(q, qd) of (1) [N m]."""
    a12, a13, a23 = c[A12], c[A13], c[A23]
    s2, s3, s23 = np.sin(q2), np.sin(q3), np.sin(q2 + q3)
    h1 = (-a12 * (2 * d1 + d2) * d2 * s2 - a13 * (2 * d1 + d2 + d3) * (d2 + d3) * s23
          - a23 * (2 * d1 + 2 * d2 + d3) * d3 * s3)
    h2 = a12 * d1 * d1 * s2 + a13 * d1 * d1 * s23 - a23 * (2 * d1 + 2 * d2 + d3) * d3 * s3
    h3 = a13 * d1 * d1 * s23 + a23 * (d1 + d2) * (d1 + d2) * s3
    return h1, h2, h3


@register_jitable
def gravity(c, q1, q2, q3):
    """(g1, g2, g3) = G(q) = dP/dq of the potential (7) [N m]."""
    q12 = q1 + q2
    g3 = -c[B3] * np.sin(q12 + q3)
    g2 = -c[B2] * np.sin(q12) + g3
    g1 = -c[B1] * np.sin(q1) + g2
    return g1, g2, g3


@register_jitable
def gravity_jacobian(c, q1, q2, q3):
    """The distinct entries (k1, k2, k3) of dG/dq = [[k1, k2, k3], [k2, k2, k3], [k3, k3, k3]] [N m/rad]."""
    q12 = q1 + q2
    k3 = -c[B3] * np.cos(q12 + q3)
    k2 = -c[B2] * np.cos(q12) + k3
    k1 = -c[B1] * np.cos(q1) + k2
    return k1, k2, k3


@register_jitable
def potential(c, q1, q2, q3):
    """P(q) = b1 cos q1 + b2 cos(q1 + q2) + b3 cos(q1 + q2 + q3) (7) [J]."""
    q12 = q1 + q2
    return c[B1] * np.cos(q1) + c[B2] * np.cos(q12) + c[B3] * np.cos(q12 + q3)


@register_jitable
def kinetic(m11, m12, m13, m22, m23, m33, d1, d2, d3):
    """1/2 qd^T M qd of (6) [J], from the entries of M."""
    return 0.5 * (m11 * d1 * d1 + m22 * d2 * d2 + m33 * d3 * d3
                  + 2.0 * (m12 * d1 * d2 + m13 * d1 * d3 + m23 * d2 * d3))


@register_jitable
def energy(c, q1, q2, q3, d1, d2, d3):
    """E = 1/2 qd^T M(q) qd + P(q) (6) [J]."""
    m11, m12, m13, m22, m23, m33 = inertia(c, q2, q3)
    return kinetic(m11, m12, m13, m22, m23, m33, d1, d2, d3) + potential(c, q1, q2, q3)


@register_jitable
def acceleration(c, q1, q2, q3, d1, d2, d3, tau2, tau3):
    """qdd = M^-1 (B tau - H - G) of (1) [rad/s^2], as (qdd1, qdd2, qdd3)."""
    i11, i12, i13, i22, i23, i33 = inverse_inertia(*inertia(c, q2, q3))
    h1, h2, h3 = coriolis(c, q2, q3, d1, d2, d3)
    g1, g2, g3 = gravity(c, q1, q2, q3)
    f1, f2, f3 = -(h1 + g1), tau2 - (h2 + g2), tau3 - (h3 + g3)
    return (i11 * f1 + i12 * f2 + i13 * f3, i12 * f1 + i22 * f2 + i23 * f3, i13 * f1 + i23 * f2 + i33 * f3)
