"""The analytic model on NumPy arrays: the equation of motion (1) with (2)-(7), for any chain of the family.

.. math::

    M(q)\\,\\ddot q + H(q, \\dot q) + G(q) + D\\,\\dot q = B\\,\\tau

Every method takes arrays with any leading batch shape: ``q`` and ``qd`` of
shape (..., n) [rad, rad/s], ``tau`` of shape (..., m) [N m], the torques of the m motors on the joints
``params.actuated`` (B, n x m, selects them; by default joints 2..n, m = n - 1). Energies are in J.
An :class:`AnalyticModel` is one protocol with two implementations, chosen once by
:meth:`AnalyticModel.from_params`: :class:`PaperModel`, the paper's closed forms (2)-(7) of
:mod:`paa_mj.model.equations` (shared with the compiled controllers) for its gymnast (three links,
no damping, no armature), and :class:`ChainModel`, the general formulas of :mod:`paa_mj.model.chain`
for every other chain. It is built from :class:`~paa_mj.model.params.RobotParams`, normally read
back from the MuJoCo model being simulated.
"""
from __future__ import annotations

import hashlib
from dataclasses import dataclass, field

import numpy as np

from . import chain
from . import equations as eq
from .params import RobotParams

#: The input matrix B of (1) for the gymnast: the motors act on joints 2 and 3.
B = chain.input_matrix(3)


def _matrix3(m11, m12, m13, m22, m23, m33):
    m11, m12, m13, m22, m23, m33 = np.broadcast_arrays(m11, m12, m13, m22, m23, m33)
    return np.stack([np.stack([m11, m12, m13], -1), np.stack([m12, m22, m23], -1),
                     np.stack([m13, m23, m33], -1)], -2)


def _split(x):
    x = np.asarray(x, dtype=float)
    return x[..., 0], x[..., 1], x[..., 2]


@dataclass(frozen=True, eq=False)
class AnalyticModel:
    """M, H, G, P and E of a chain of the family (:class:`PaperModel` or :class:`ChainModel`).

    Attributes
    ----------
    params : RobotParams
    inertia_constants : ndarray (n, n)
        A of :mod:`paa_mj.model.chain` [kg m^2].
    gravity_constants : ndarray (n,)
        b of :mod:`paa_mj.model.chain` [J] (for the gymnast, b1, b2, b3 of (4)).
    """

    params: RobotParams
    inertia_constants: np.ndarray = field(repr=False, default=None)
    gravity_constants: np.ndarray = field(repr=False, default=None)
    #: The paper's gymnast, where (1)-(7) hold as written (three links, no damping, no armature).
    paper_shape = False

    @classmethod
    def from_params(cls, p: RobotParams) -> "AnalyticModel":
        """:class:`PaperModel` for the paper's shape (:attr:`RobotParams.is_paper_shape`), else :class:`ChainModel`."""
        A, b = chain.chain_constants(p)
        if p.is_paper_shape:
            return PaperModel(params=p, inertia_constants=A, gravity_constants=b, constants=eq.robot_constants(p))
        return ChainModel(params=p, inertia_constants=A, gravity_constants=b)

    @property
    def n_links(self) -> int:
        return self.params.n_links

    @property
    def n_motors(self) -> int:
        """m, the number of motors."""
        return self.params.n_motors

    @property
    def actuated(self) -> tuple:
        """The joints that carry the motors, 0-based (motor k drives joint ``actuated[k]``)."""
        return self.params.actuated

    @property
    def passive_first(self) -> bool:
        """Joint 1 alone passive: the paper's family, where its theory and controllers (12), (40) apply."""
        return self.params.passive_first

    @property
    def input_matrix(self) -> np.ndarray:
        """B of (1), shape (n, m): the identity's columns of the driven joints."""
        return self.params.input_matrix

    def joint_torques(self, tau):
        """B tau: the motors' torques ``tau`` (..., m) as generalised forces on the n joints (..., n) [N m]."""
        tau = np.asarray(tau, dtype=float)
        out = np.zeros(tau.shape[:-1] + (self.n_links,))
        out[..., list(self.actuated)] = tau
        return out

    def key(self) -> tuple:
        """Hashable identity of the robot (for caches)."""
        return self.params.key()

    @property
    def digest(self) -> str:
        """A short digest of the parameters (what a built controller records of its robot)."""
        return hashlib.sha256(np.asarray(self.key(), dtype=float).tobytes()).hexdigest()[:12]

    @property
    def beta(self) -> np.ndarray:
        """The gravity constants [b1, ..., bn] [J] ((4) for the gymnast)."""
        return self.gravity_constants.copy()

    def damping_force(self, qd):
        """D qd: the joints' viscous damping [N m], shape (..., n) (zero for the gymnast)."""
        return self.params.damping * np.asarray(qd, float)

    def state_derivative(self, x, tau):
        """(1) as a first-order system: d/dt [q, qd] = [qd, qdd(q, qd, tau)], shape (..., 2n)."""
        x = np.asarray(x, dtype=float)
        n = self.n_links
        return np.concatenate([x[..., n:], self.acceleration(x[..., :n], x[..., n:], tau)], axis=-1)

    def linearize(self, q_eq):
        """Linearisation of (1) about the equilibrium (q_eq, 0).

        Returns
        -------
        A : ndarray, shape (2n, 2n)
            x_dot = A x + B_lin tau with x = [q - q_eq, qd].
        B_lin : ndarray, shape (2n, m)
        """
        n = self.n_links
        M = self.mass_matrix(q_eq)
        A = np.zeros((2 * n, 2 * n))
        A[:n, n:] = np.eye(n)
        # H is quadratic in qd, so only gravity (and damping) survive at qd = 0.
        A[n:, :n] = -np.linalg.solve(M, self.gravity_jacobian(q_eq))
        if np.any(self.params.damping):
            A[n:, n:] = -np.linalg.solve(M, np.diag(self.params.damping))
        B_lin = np.zeros((2 * n, self.n_motors))
        B_lin[n:, :] = np.linalg.solve(M, self.input_matrix)
        return A, B_lin

    # --- the protocol, one implementation per subclass ---------------------------------------------------

    def mass_matrix(self, q):
        """M(q) [kg m^2], shape (..., n, n); (2) for the gymnast."""
        raise NotImplementedError

    def coriolis(self, q, qd):
        """H(q, qd) [N m], shape (..., n)."""
        raise NotImplementedError

    def potential(self, q):
        """P(q) = sum_k b_k cos(q1 + ... + qk) ((7) for the gymnast) [J]."""
        raise NotImplementedError

    def gravity(self, q):
        """G(q) = dP/dq [N m], shape (..., n)."""
        raise NotImplementedError

    def gravity_jacobian(self, q):
        """dG/dq = Hessian of P [N m/rad], shape (..., n, n); used to linearise (1)."""
        raise NotImplementedError

    def bias(self, q, qd):
        """H(q, qd) + G(q): MuJoCo's ``qfrc_bias`` for this model [N m] (damping is in ``qfrc_passive``)."""
        raise NotImplementedError

    def kinetic_energy(self, q, qd):
        """1/2 qd^T M qd [J] (armature included, as MuJoCo counts it)."""
        raise NotImplementedError

    def energy(self, q, qd):
        """Total mechanical energy E = 1/2 qd^T M qd + P (6) [J]."""
        raise NotImplementedError

    def acceleration(self, q, qd, tau):
        """qdd = M^-1 (B tau - H - G - D qd) [rad/s^2], shape (..., n)."""
        raise NotImplementedError

    def kernel_constants(self):
        """(constants, closed_form): the robot as compiled code reads it, the paper's ``c`` (closed_form True) or
        the chain's A (n x n, row by row), b, damping, armature and the motor of each joint
        (:func:`~paa_mj.model.chain.drive_map`) (closed_form False)."""
        raise NotImplementedError

    def symbolic_acceleration(self, ca, x, u):
        """qdd of (1) as a CasADi column of n expressions of the symbols x = [q, qd] and u = tau, with the
        CasADi module ``ca`` (:func:`~paa_mj.model.equations.casadi_module`): the same formulas, for exact
        derivatives and trajectory optimisation."""
        raise NotImplementedError


@dataclass(frozen=True, eq=False)
class PaperModel(AnalyticModel):
    """The paper's gymnast: (1)-(7) in their closed forms (:mod:`paa_mj.model.equations`).

    Attributes
    ----------
    constants : ndarray (9,)
        The vector ``c`` of :mod:`paa_mj.model.equations`: a11, a22, a33, a12, a13, a23 (3) [kg m^2] and
        b1, b2, b3 (4) [J], also as attributes.
    """

    constants: np.ndarray = field(repr=False, default=None)
    paper_shape = True

    def __getattr__(self, name):
        if name in eq.CONSTANTS:
            return float(self.constants[eq.CONSTANTS.index(name)])
        raise AttributeError(name)

    @property
    def E_r(self) -> float:
        """E_r = b1 - b2 - b3 (9): the energy of the folded up-down-down equilibrium (8) [J]."""
        return float(eq.udd_energy(self.constants))

    def mass_matrix_23(self, q2, q3):
        """Inertia matrix (2) of the gymnast as a function of (q2, q3) only; shape (..., 3, 3)."""
        return _matrix3(*eq.inertia(self.constants, np.asarray(q2, float), np.asarray(q3, float)))

    def mass_matrix(self, q):
        _, q2, q3 = _split(q)
        return self.mass_matrix_23(q2, q3)

    def coriolis(self, q, qd):
        _, q2, q3 = _split(q)
        h = eq.coriolis(self.constants, q2, q3, *_split(qd))
        return np.stack(np.broadcast_arrays(*h), -1)

    def potential(self, q):
        return eq.potential(self.constants, *_split(q))

    def gravity(self, q):
        return np.stack(eq.gravity(self.constants, *_split(q)), -1)

    def gravity_jacobian(self, q):
        k1, k2, k3 = eq.gravity_jacobian(self.constants, *_split(q))
        return _matrix3(k1, k2, k3, k2, k3, k3)

    def bias(self, q, qd):
        return self.coriolis(q, qd) + self.gravity(q)

    def kinetic_energy(self, q, qd):
        _, q2, q3 = _split(q)
        return eq.kinetic(*eq.inertia(self.constants, q2, q3), *_split(qd))

    def energy(self, q, qd):
        return eq.energy(self.constants, *_split(q), *_split(qd))

    def acceleration(self, q, qd, tau):
        tau = np.asarray(tau, dtype=float)
        qdd = eq.acceleration(self.constants, *_split(q), *_split(qd), tau[..., 0], tau[..., 1])
        return np.stack(np.broadcast_arrays(*qdd), -1)

    def kernel_constants(self):
        return self.constants, True

    def symbolic_acceleration(self, ca, x, u):
        return ca.vertcat(*eq.acceleration(self.constants, x[0], x[1], x[2], x[3], x[4], x[5], u[0], u[1]))


@dataclass(frozen=True, eq=False)
class ChainModel(AnalyticModel):
    """Any chain of the family: the general formulas of :mod:`paa_mj.model.chain` (damping and armature included)."""

    def mass_matrix(self, q):
        return chain.batch_mass_matrix(self.inertia_constants, self.params.armature, q)

    def coriolis(self, q, qd):
        return self.bias(q, qd) - self.gravity(q)

    def potential(self, q):
        return chain.batch_potential(self.gravity_constants, q)

    def gravity(self, q):
        q = np.asarray(q, float)
        return chain.batch_bias(self.inertia_constants, self.gravity_constants, q, np.zeros_like(q))

    def gravity_jacobian(self, q):
        return chain.batch_gravity_jacobian(self.gravity_constants, q)

    def bias(self, q, qd):
        return chain.batch_bias(self.inertia_constants, self.gravity_constants, q, qd)

    def kinetic_energy(self, q, qd):
        qd = np.asarray(qd, float)
        return 0.5 * np.einsum("...i,...ij,...j->...", qd, self.mass_matrix(q), qd)

    def energy(self, q, qd):
        return self.kinetic_energy(q, qd) + self.potential(q)

    def acceleration(self, q, qd, tau):
        tau = np.asarray(tau, dtype=float)
        q, qd = np.asarray(q, float), np.asarray(qd, float)
        mass = self.mass_matrix(q)
        force = tau @ self.input_matrix.T - self.bias(q, qd) - self.damping_force(qd)
        force = np.broadcast_to(force, np.broadcast_shapes(force.shape, mass.shape[:-1]))
        mass = np.broadcast_to(mass, force.shape + mass.shape[-1:])
        return np.linalg.solve(mass, force[..., None])[..., 0]

    def kernel_constants(self):
        p = self.params
        return np.concatenate([self.inertia_constants.ravel(), self.gravity_constants, p.damping, p.armature,
                               chain.drive_map(p.n_links, p.actuated)]), False

    def symbolic_acceleration(self, ca, x, u):
        """The formulas of :mod:`paa_mj.model.chain` (absolute angles, M = T^T M^abs T + diag(armature),
        H + G = T^T (c + grad_phi P)) written for CasADi."""
        n = self.n_links
        A, b, p = self.inertia_constants, self.gravity_constants, self.params
        phi, rate, total, total_rate = [], [], 0, 0
        for k in range(n):
            total, total_rate = total + x[k], total_rate + x[n + k]
            phi.append(total)
            rate.append(total_rate)
        absolute = [[A[i, j] * ca.cos(phi[i] - phi[j]) for j in range(n)] for i in range(n)]
        mass = ca.SX(n, n)
        for k in range(n):
            for m in range(n):
                mass[k, m] = sum(absolute[i][j] for i in range(k, n) for j in range(m, n)) + \
                    (p.armature[k] if k == m else 0)
        c = [sum(A[i, j] * ca.sin(phi[i] - phi[j]) * rate[j] ** 2 for j in range(n)) - b[i] * ca.sin(phi[i])
             for i in range(n)]
        motor = {j: k for k, j in enumerate(p.actuated)}
        force = ca.vertcat(*[(u[motor[k]] if k in motor else 0) - sum(c[k:]) - p.damping[k] * x[n + k]
                             for k in range(n)])
        return ca.solve(mass, force)
