"""The analytic model of the paper on NumPy arrays: equation of motion (1) with (2)-(7).

.. math::

    M(q)\\,\\ddot q + H(q, \\dot q) + G(q) = B\\,\\tau

Every method takes arrays with any leading batch shape: ``q`` and ``qd`` of
shape (..., 3) [rad, rad/s], ``tau`` of shape (..., 2) [N m]. Energies are in J.
The formulas themselves live in :mod:`paa_mj.model.equations` (shared with the
compiled controllers); this class gathers them into matrices. An
:class:`AnalyticModel` is built from :class:`~paa_mj.model.params.RobotParams`,
normally read back from the MuJoCo model being simulated.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import equations as eq
from .params import RobotParams

#: The input matrix B of (1): the motors act on joints 2 and 3.
B = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])


def _matrix3(m11, m12, m13, m22, m23, m33):
    m11, m12, m13, m22, m23, m33 = np.broadcast_arrays(m11, m12, m13, m22, m23, m33)
    return np.stack([np.stack([m11, m12, m13], -1), np.stack([m12, m22, m23], -1),
                     np.stack([m13, m23, m33], -1)], -2)


def _split(x):
    x = np.asarray(x, dtype=float)
    return x[..., 0], x[..., 1], x[..., 2]


@dataclass(frozen=True, eq=False)
class AnalyticModel:
    """Closed-form M, H, G, P and E of the 3-link gymnast.

    Attributes
    ----------
    params : RobotParams
    constants : ndarray (9,)
        The vector ``c`` of :mod:`paa_mj.model.equations`: a11, a22, a33, a12,
        a13, a23 (3) [kg m^2] and b1, b2, b3 (4) [J], also as attributes.
    """

    params: RobotParams
    constants: np.ndarray = field(repr=False)

    @classmethod
    def from_params(cls, p: RobotParams) -> "AnalyticModel":
        return cls(params=p, constants=eq.robot_constants(p))

    def __getattr__(self, name):
        if name in eq.CONSTANTS:
            return float(self.constants[eq.CONSTANTS.index(name)])
        raise AttributeError(name)

    def key(self) -> tuple:
        """Hashable identity of the robot (for caches)."""
        return self.params.key()

    @property
    def beta(self) -> np.ndarray:
        """[b1, b2, b3] of (4) [J]."""
        return self.constants[eq.B1:eq.B3 + 1].copy()

    @property
    def E_r(self) -> float:
        """Energy at the UDD equilibrium, E_r = b1 - b2 - b3 (9) [J]."""
        return float(eq.udd_energy(self.constants))

    def mass_matrix_23(self, q2, q3):
        """Inertia matrix (2) as a function of (q2, q3) only; shape (..., 3, 3)."""
        return _matrix3(*eq.inertia(self.constants, np.asarray(q2, float), np.asarray(q3, float)))

    def mass_matrix(self, q):
        """M(q) of (2) [kg m^2], shape (..., 3, 3)."""
        _, q2, q3 = _split(q)
        return self.mass_matrix_23(q2, q3)

    def coriolis(self, q, qd):
        """H(q, qd) [N m], shape (..., 3)."""
        _, q2, q3 = _split(q)
        h = eq.coriolis(self.constants, q2, q3, *_split(qd))
        return np.stack(np.broadcast_arrays(*h), -1)

    def potential(self, q):
        """P(q) = b1 cos q1 + b2 cos(q1+q2) + b3 cos(q1+q2+q3) (7) [J]."""
        return eq.potential(self.constants, *_split(q))

    def gravity(self, q):
        """G(q) = dP/dq [N m], shape (..., 3)."""
        return np.stack(eq.gravity(self.constants, *_split(q)), -1)

    def gravity_jacobian(self, q):
        """dG/dq = Hessian of P [N m/rad], shape (..., 3, 3); used to linearise (1)."""
        k1, k2, k3 = eq.gravity_jacobian(self.constants, *_split(q))
        return _matrix3(k1, k2, k3, k2, k3, k3)

    def bias(self, q, qd):
        """H(q, qd) + G(q): MuJoCo's ``qfrc_bias`` for this model [N m]."""
        return self.coriolis(q, qd) + self.gravity(q)

    def kinetic_energy(self, q, qd):
        """1/2 qd^T M qd [J]."""
        _, q2, q3 = _split(q)
        return eq.kinetic(*eq.inertia(self.constants, q2, q3), *_split(qd))

    def energy(self, q, qd):
        """Total mechanical energy E = 1/2 qd^T M qd + P (6) [J]."""
        return eq.energy(self.constants, *_split(q), *_split(qd))

    def acceleration(self, q, qd, tau):
        """qdd = M^-1 (B tau - H - G) [rad/s^2], shape (..., 3)."""
        tau = np.asarray(tau, dtype=float)
        qdd = eq.acceleration(self.constants, *_split(q), *_split(qd), tau[..., 0], tau[..., 1])
        return np.stack(np.broadcast_arrays(*qdd), -1)

    def state_derivative(self, x, tau):
        """(1) as a first-order system: d/dt [q, qd] = [qd, qdd(q, qd, tau)], shape (..., 6)."""
        x = np.asarray(x, dtype=float)
        return np.concatenate([x[..., 3:], self.acceleration(x[..., :3], x[..., 3:], tau)], axis=-1)

    def closed_loop(self, controller):
        """The right-hand side f(t, x) of (1) closed by ``controller`` (torque(q, qd, t)), as ODE solvers take it."""
        def field(t, x):
            return self.state_derivative(x, controller.torque(x[..., :3], x[..., 3:], t))
        return field

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
