"""The analytic model of the paper: equation of motion (1) with (2)-(7).

    M(q) qdd + H(q, qd) + G(q) = B tau,   B = [[0, 0], [1, 0], [0, 1]]

Every function takes arrays with any leading batch shape: ``q`` and ``qd`` of
shape (..., 3) [rad, rad/s], ``tau`` of shape (..., 2) [N m]. Energies are in J.
An :class:`AnalyticModel` is built from :class:`~paa_mj.params.RobotParams`,
normally read back from the MuJoCo model that is being simulated.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .params import RobotParams

#: The input matrix B of (1): the motors act on joints 2 and 3.
B = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])


@dataclass(frozen=True, eq=False)
class AnalyticModel:
    """Closed-form M, H, G, P and E of the 3-link gymnast.

    Attributes
    ----------
    a11, a22, a33, a12, a13, a23 : float
        Inertia constants (3) [kg m^2].
    b1, b2, b3 : float
        Gravity constants (4) [J]: b1 = (m1 lc1 + m2 l1 + m3 l1) g, ...
    """

    params: RobotParams
    a11: float
    a22: float
    a33: float
    a12: float
    a13: float
    a23: float
    b1: float
    b2: float
    b3: float

    @classmethod
    def from_params(cls, p: RobotParams) -> "AnalyticModel":
        m1, m2, m3 = p.m
        l1, l2, _ = p.l
        c1, c2, c3 = p.lc
        J1, J2, J3 = p.J
        g = p.g
        return cls(
            params=p,
            a11=J1 + m1 * c1**2 + (m2 + m3) * l1**2,
            a22=J2 + m2 * c2**2 + m3 * l2**2,
            a33=J3 + m3 * c3**2,
            a12=(m2 * c2 + m3 * l2) * l1,
            a13=m3 * l1 * c3,
            a23=m3 * l2 * c3,
            b1=(m1 * c1 + m2 * l1 + m3 * l1) * g,
            b2=(m2 * c2 + m3 * l2) * g,
            b3=m3 * c3 * g,
        )

    def key(self) -> tuple:
        """Hashable identity of the robot (for caches)."""
        p = self.params
        return tuple(np.concatenate([p.m, p.l, p.lc, p.J, [p.g]]).tolist())

    @property
    def beta(self) -> np.ndarray:
        """[b1, b2, b3] of (4) [J]."""
        return np.array([self.b1, self.b2, self.b3])

    @property
    def E_r(self) -> float:
        """Energy at the UDD equilibrium, E_r = b1 - b2 - b3 (9) [J]."""
        return self.b1 - self.b2 - self.b3

    # --- (2) -----------------------------------------------------------------
    def mass_matrix_23(self, q2, q3):
        """Inertia matrix (2) as a function of (q2, q3) only; shape (..., 3, 3)."""
        q2, q3 = np.asarray(q2), np.asarray(q3)
        c2, c3, c23 = np.cos(q2), np.cos(q3), np.cos(q2 + q3)
        m33 = np.broadcast_to(self.a33, c2.shape)
        m23 = self.a33 + self.a23 * c3
        m22 = self.a22 + self.a33 + 2 * self.a23 * c3
        m13 = self.a33 + self.a13 * c23 + self.a23 * c3
        m12 = self.a22 + self.a33 + self.a12 * c2 + self.a13 * c23 + 2 * self.a23 * c3
        m11 = (self.a11 + self.a22 + self.a33 + 2 * self.a12 * c2 + 2 * self.a13 * c23
               + 2 * self.a23 * c3)
        return np.stack([np.stack([m11, m12, m13], -1),
                         np.stack([m12, m22, m23], -1),
                         np.stack([m13, m23, m33], -1)], -2)

    def mass_matrix(self, q):
        """M(q) of (2) [kg m^2], shape (..., 3, 3)."""
        q = np.asarray(q)
        return self.mass_matrix_23(q[..., 1], q[..., 2])

    # --- Coriolis and centrifugal terms -----------------------------------------
    def coriolis(self, q, qd):
        """H(q, qd) [N m], shape (..., 3)."""
        q, qd = np.asarray(q), np.asarray(qd)
        s2, s3, s23 = np.sin(q[..., 1]), np.sin(q[..., 2]), np.sin(q[..., 1] + q[..., 2])
        d1, d2, d3 = qd[..., 0], qd[..., 1], qd[..., 2]
        h1 = (-self.a12 * (2 * d1 + d2) * d2 * s2
              - self.a13 * (2 * d1 + d2 + d3) * (d2 + d3) * s23
              - self.a23 * (2 * d1 + 2 * d2 + d3) * d3 * s3)
        h2 = (self.a12 * d1**2 * s2 + self.a13 * d1**2 * s23
              - self.a23 * (2 * d1 + 2 * d2 + d3) * d3 * s3)
        h3 = self.a13 * d1**2 * s23 + self.a23 * (d1 + d2)**2 * s3
        return np.stack([h1, h2, h3], -1)

    # --- (7) and its derivatives -------------------------------------------------
    def potential(self, q):
        """P(q) = b1 cos q1 + b2 cos(q1+q2) + b3 cos(q1+q2+q3) (7) [J]."""
        q = np.asarray(q)
        q12 = q[..., 0] + q[..., 1]
        return self.b1 * np.cos(q[..., 0]) + self.b2 * np.cos(q12) + self.b3 * np.cos(q12 + q[..., 2])

    def gravity(self, q):
        """G(q) = dP/dq [N m], shape (..., 3)."""
        q = np.asarray(q)
        q12 = q[..., 0] + q[..., 1]
        g3 = -self.b3 * np.sin(q12 + q[..., 2])
        g2 = -self.b2 * np.sin(q12) + g3
        g1 = -self.b1 * np.sin(q[..., 0]) + g2
        return np.stack([g1, g2, g3], -1)

    def gravity_jacobian(self, q):
        """dG/dq = Hessian of P [N m/rad], shape (..., 3, 3); used to linearise (1)."""
        q = np.asarray(q)
        q12 = q[..., 0] + q[..., 1]
        k3 = -self.b3 * np.cos(q12 + q[..., 2])
        k2 = -self.b2 * np.cos(q12) + k3
        k1 = -self.b1 * np.cos(q[..., 0]) + k2
        return np.stack([np.stack([k1, k2, k3], -1),
                         np.stack([k2, k2, k3], -1),
                         np.stack([k3, k3, k3], -1)], -2)

    def bias(self, q, qd):
        """H(q, qd) + G(q): MuJoCo's ``qfrc_bias`` for this model [N m]."""
        return self.coriolis(q, qd) + self.gravity(q)

    # --- (6) -----------------------------------------------------------------
    def kinetic_energy(self, q, qd):
        qd = np.asarray(qd)
        return 0.5 * np.einsum("...i,...ij,...j->...", qd, self.mass_matrix(q), qd)

    def energy(self, q, qd):
        """Total mechanical energy E = 1/2 qd^T M qd + P (6) [J]."""
        return self.kinetic_energy(q, qd) + self.potential(q)

    def acceleration(self, q, qd, tau):
        """qdd = M^-1 (B tau - H - G) [rad/s^2], shape (..., 3)."""
        rhs = np.asarray(tau) @ B.T - self.bias(q, qd)
        return np.linalg.solve(self.mass_matrix(q), rhs[..., None])[..., 0]

    def linearize(self, q_eq):
        """Linearisation of (1) about the equilibrium (q_eq, 0).

        Returns
        -------
        A : ndarray, shape (6, 6)
            x_dot = A x + B_lin tau with x = [q - q_eq, qd].
        B_lin : ndarray, shape (6, 2)
        """
        M = self.mass_matrix(q_eq)
        A = np.zeros((6, 6))
        A[:3, 3:] = np.eye(3)
        # H is quadratic in qd, so only gravity survives at qd = 0.
        A[3:, :3] = -np.linalg.solve(M, self.gravity_jacobian(q_eq))
        B_lin = np.zeros((6, 2))
        B_lin[3:, :] = np.linalg.solve(M, B)
        return A, B_lin
