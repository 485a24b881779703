"""The analytic model on NumPy arrays: the equation of motion (1) with (2)-(7), for any chain of the family.

.. math::

    M(q)\\,\\ddot q + H(q, \\dot q) + G(q) + D\\,\\dot q = B\\,\\tau

Every method takes arrays with any leading batch shape: ``q`` and ``qd`` of
shape (..., n) [rad, rad/s], ``tau`` of shape (..., n - 1) [N m]. Energies are in J.
For the paper's gymnast (three links, no damping, no armature) the formulas are
the paper's closed forms of :mod:`paa_mj.model.equations` (shared with the compiled
controllers); for every other chain they are the general ones of
:mod:`paa_mj.model.chain`. An :class:`AnalyticModel` is built from
:class:`~paa_mj.model.params.RobotParams`, normally read back from the MuJoCo
model being simulated.
"""
from __future__ import annotations

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
    """M, H, G, P and E of a chain of the family; the paper's closed forms (2)-(7) for the gymnast.

    Attributes
    ----------
    params : RobotParams
    constants : ndarray (9,) or None
        For the paper's shape (:attr:`RobotParams.is_paper_shape`) the vector ``c`` of
        :mod:`paa_mj.model.equations`: a11, a22, a33, a12, a13, a23 (3) [kg m^2] and
        b1, b2, b3 (4) [J], also as attributes; None for other chains.
    inertia_constants : ndarray (n, n)
        A of :mod:`paa_mj.model.chain` [kg m^2].
    gravity_constants : ndarray (n,)
        b of :mod:`paa_mj.model.chain` [J] (for the gymnast, b1, b2, b3 of (4)).
    """

    params: RobotParams
    constants: np.ndarray | None = field(repr=False)
    inertia_constants: np.ndarray = field(repr=False, default=None)
    gravity_constants: np.ndarray = field(repr=False, default=None)

    @classmethod
    def from_params(cls, p: RobotParams) -> "AnalyticModel":
        A, b = chain.chain_constants(p)
        return cls(params=p, constants=eq.robot_constants(p) if p.is_paper_shape else None, inertia_constants=A,
                   gravity_constants=b)

    def __getattr__(self, name):
        if name in eq.CONSTANTS:
            if self.constants is None:
                raise AttributeError(f"{name} is a constant of the paper's 3-link model; this robot has"
                                     f" {self.params.n_links} links (see inertia_constants, gravity_constants)")
            return float(self.constants[eq.CONSTANTS.index(name)])
        raise AttributeError(name)

    @property
    def paper_shape(self) -> bool:
        """The paper's gymnast: (1)-(7) hold as written (three links, no damping, no armature)."""
        return self.constants is not None

    @property
    def n_links(self) -> int:
        return self.params.n_links

    @property
    def n_motors(self) -> int:
        return self.params.n_links - 1

    @property
    def input_matrix(self) -> np.ndarray:
        """B of (1), shape (n, n - 1)."""
        return chain.input_matrix(self.n_links)

    def key(self) -> tuple:
        """Hashable identity of the robot (for caches)."""
        return self.params.key()

    @property
    def beta(self) -> np.ndarray:
        """The gravity constants [b1, ..., bn] [J] ((4) for the gymnast)."""
        return self.gravity_constants.copy()

    @property
    def E_r(self) -> float:
        """Energy at the folded goal (8): link 1 up, the others hanging, E_r = b1 - b2 - ... - bn ((9) for n = 3) [J]."""
        return self.goal_energy("folded")

    def goal_energy(self, goal="folded") -> float:
        """E_r = P(q*): the energy at rest at a goal of the family [J] ((9) for the gymnast's UDD)."""
        from .states import goal_angles

        if self.paper_shape and goal == "folded":
            return float(eq.udd_energy(self.constants))
        return float(self.potential(goal_angles(goal, self.n_links)))

    def mass_matrix_23(self, q2, q3):
        """Inertia matrix (2) of the gymnast as a function of (q2, q3) only; shape (..., 3, 3)."""
        self._require_paper("mass_matrix_23")
        return _matrix3(*eq.inertia(self.constants, np.asarray(q2, float), np.asarray(q3, float)))

    def _require_paper(self, what):
        if not self.paper_shape:
            raise AttributeError(f"{what} is the paper's 3-link closed form; use mass_matrix(q) for this chain")

    def mass_matrix(self, q):
        """M(q) [kg m^2], shape (..., n, n); (2) for the gymnast."""
        if self.paper_shape:
            _, q2, q3 = _split(q)
            return self.mass_matrix_23(q2, q3)
        return chain.batch_mass_matrix(self.inertia_constants, self.params.armature, q)

    def coriolis(self, q, qd):
        """H(q, qd) [N m], shape (..., n)."""
        if self.paper_shape:
            _, q2, q3 = _split(q)
            h = eq.coriolis(self.constants, q2, q3, *_split(qd))
            return np.stack(np.broadcast_arrays(*h), -1)
        return self.bias(q, qd) - self.gravity(q)

    def damping_force(self, qd):
        """D qd: the joints' viscous damping [N m], shape (..., n) (zero for the gymnast)."""
        return self.params.damping * np.asarray(qd, float)

    def potential(self, q):
        """P(q) = sum_k b_k cos(q1 + ... + qk) ((7) for the gymnast) [J]."""
        if self.paper_shape:
            return eq.potential(self.constants, *_split(q))
        return chain.batch_potential(self.gravity_constants, q)

    def gravity(self, q):
        """G(q) = dP/dq [N m], shape (..., n)."""
        if self.paper_shape:
            return np.stack(eq.gravity(self.constants, *_split(q)), -1)
        q = np.asarray(q, float)
        return chain.batch_bias(self.inertia_constants, self.gravity_constants, q, np.zeros_like(q))

    def gravity_jacobian(self, q):
        """dG/dq = Hessian of P [N m/rad], shape (..., n, n); used to linearise (1)."""
        if self.paper_shape:
            k1, k2, k3 = eq.gravity_jacobian(self.constants, *_split(q))
            return _matrix3(k1, k2, k3, k2, k3, k3)
        return chain.batch_gravity_jacobian(self.gravity_constants, q)

    def bias(self, q, qd):
        """H(q, qd) + G(q): MuJoCo's ``qfrc_bias`` for this model [N m] (damping is in ``qfrc_passive``)."""
        if self.paper_shape:
            return self.coriolis(q, qd) + self.gravity(q)
        return chain.batch_bias(self.inertia_constants, self.gravity_constants, q, qd)

    def kinetic_energy(self, q, qd):
        """1/2 qd^T M qd [J] (armature included, as MuJoCo counts it)."""
        if self.paper_shape:
            _, q2, q3 = _split(q)
            return eq.kinetic(*eq.inertia(self.constants, q2, q3), *_split(qd))
        qd = np.asarray(qd, float)
        return 0.5 * np.einsum("...i,...ij,...j->...", qd, self.mass_matrix(q), qd)

    def energy(self, q, qd):
        """Total mechanical energy E = 1/2 qd^T M qd + P (6) [J]."""
        if self.paper_shape:
            return eq.energy(self.constants, *_split(q), *_split(qd))
        return self.kinetic_energy(q, qd) + self.potential(q)

    def acceleration(self, q, qd, tau):
        """qdd = M^-1 (B tau - H - G - D qd) [rad/s^2], shape (..., n)."""
        tau = np.asarray(tau, dtype=float)
        if self.paper_shape:
            qdd = eq.acceleration(self.constants, *_split(q), *_split(qd), tau[..., 0], tau[..., 1])
            return np.stack(np.broadcast_arrays(*qdd), -1)
        q, qd = np.asarray(q, float), np.asarray(qd, float)
        mass = self.mass_matrix(q)
        force = tau @ self.input_matrix.T - self.bias(q, qd) - self.damping_force(qd)
        force = np.broadcast_to(force, np.broadcast_shapes(force.shape, mass.shape[:-1]))
        mass = np.broadcast_to(mass, force.shape + mass.shape[-1:])
        return np.linalg.solve(mass, force[..., None])[..., 0]

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
        B_lin : ndarray, shape (2n, n - 1)
        """
        n = self.n_links
        M = self.mass_matrix(q_eq)
        A = np.zeros((2 * n, 2 * n))
        A[:n, n:] = np.eye(n)
        # H is quadratic in qd, so only gravity (and damping) survive at qd = 0.
        A[n:, :n] = -np.linalg.solve(M, self.gravity_jacobian(q_eq))
        if np.any(self.params.damping):
            A[n:, n:] = -np.linalg.solve(M, np.diag(self.params.damping))
        B_lin = np.zeros((2 * n, n - 1))
        B_lin[n:, :] = np.linalg.solve(M, self.input_matrix)
        return A, B_lin
