"""Energy-based swing-up: the paper's controller (40) and the conventional candidate (12).

Both come from one derivation. With qd_a = [d2, d3], an error e of the actuated
coordinates and the matrix Phi with de/dt = Phi qd_a,

.. math::

    V &= \\tfrac12 (E - E_r)^2 + \\tfrac12 k_D \\dot q_a^\\top \\dot q_a + \\tfrac12 k_P e^\\top e
        &\\quad (34), (12) \\\\
    \\Lambda &= (E - E_r) I_2 + k_D B^\\top M^{-1} B &\\quad (38) \\\\
    \\tau &= \\Lambda^{-1} \\left(k_D B^\\top M^{-1} (H + G) - k_V \\dot q_a - k_P \\Phi^\\top e\\right) &\\quad (40)

make :math:`\\dot V = -k_V \\dot q_a^\\top \\dot q_a` (36) along (1). The paper's controller (40) uses
the virtual composite link, e = qbar_a - q_ar (13), (11), Phi = Psi (21); the
conventional candidate (12), which the paper set aside as hard to analyse, uses
e = q_a - q_ar and Phi = I. Units: kD [J kg m^2], kP [J^2/rad^2], kV [J^2 s/rad^2].

The torque formulas are registered with numba: the same expressions run on NumPy
batches (``torque``) and in the compiled kernels (``compiled``). See
``docs/model.md``.
"""
from __future__ import annotations

import math

import numpy as np
from numba.extending import register_jitable

from ..model import equations as eq
from ..model.dynamics import AnalyticModel
from ..model.states import Q_AR
from ..model.vcl import Psi, psi, theta
from .base import CompiledForm, Controller, kernel
from .gains import check_gains

_KD, _KP, _KV = len(eq.CONSTANTS), len(eq.CONSTANTS) + 1, len(eq.CONSTANTS) + 2


@register_jitable
def energy_terms(c, kD, kV, q1, q2, q3, d1, d2, d3):
    """The pieces of (38) and (40) at one state.

    Returns (E - E_r, kD (M^-1)_22, kD (M^-1)_23, kD (M^-1)_33, u1, u2), where the
    middle three are kD B^T M^-1 B and u = kD B^T M^-1 (H + G) - kV qd_a, so that
    Lambda = (E - E_r) I2 + kD B^T M^-1 B (38).
    """
    m11, m12, m13, m22, m23, m33 = eq.inertia(c, q2, q3)
    _, i12, i13, i22, i23, i33 = eq.inverse_inertia(m11, m12, m13, m22, m23, m33)
    h1, h2, h3 = eq.coriolis(c, q2, q3, d1, d2, d3)
    g1, g2, g3 = eq.gravity(c, q1, q2, q3)
    f1, f2, f3 = h1 + g1, h2 + g2, h3 + g3
    de = eq.kinetic(m11, m12, m13, m22, m23, m33, d1, d2, d3) + eq.potential(c, q1, q2, q3) - eq.udd_energy(c)
    u1 = kD * (i12 * f1 + i22 * f2 + i23 * f3) - kV * d2
    u2 = kD * (i13 * f1 + i23 * f2 + i33 * f3) - kV * d3
    return de, kD * i22, kD * i23, kD * i33, u1, u2


@register_jitable
def solve_symmetric2(l11, l12, l22, r1, r2):
    """The solution of [[l11, l12], [l12, l22]] tau = r, by Cramer's rule."""
    det = l11 * l22 - l12 * l12
    return (l22 * r1 - l12 * r2) / det, (l11 * r2 - l12 * r1) / det


@register_jitable
def vcl_law(c, kP, de, k22, k23, k33, u1, u2, q2, q3):
    """(40) from the pieces of :func:`energy_terms`: e = [q2 + theta(q3) + pi, q3], Phi = Psi(q3)."""
    e1 = q2 + theta(c[eq.B2], c[eq.B3], q3) + math.pi
    r2 = u2 - kP * (psi(c[eq.B2], c[eq.B3], q3) * e1 + q3)
    return solve_symmetric2(de + k22, k23, de + k33, u1 - kP * e1, r2)


@register_jitable
def conventional_law(c, kP, de, k22, k23, k33, u1, u2, q2, q3):
    """(12)'s controller from the pieces of :func:`energy_terms`: e = [q2 + pi, q3], Phi = I."""
    return solve_symmetric2(de + k22, k23, de + k33, u1 - kP * (q2 + math.pi), u2 - kP * q3)


@register_jitable
def vcl_torque(c, kD, kP, kV, q1, q2, q3, d1, d2, d3):
    """Controller (40) at one state (or elementwise over arrays)."""
    de, k22, k23, k33, u1, u2 = energy_terms(c, kD, kV, q1, q2, q3, d1, d2, d3)
    return vcl_law(c, kP, de, k22, k23, k33, u1, u2, q2, q3)


@register_jitable
def conventional_torque(c, kD, kP, kV, q1, q2, q3, d1, d2, d3):
    """The controller of the conventional candidate (12) at one state (or elementwise)."""
    de, k22, k23, k33, u1, u2 = energy_terms(c, kD, kV, q1, q2, q3, d1, d2, d3)
    return conventional_law(c, kP, de, k22, k23, k33, u1, u2, q2, q3)


@kernel
def vcl_kernel(q1, q2, q3, d1, d2, d3, t, params, memory, tau):
    """Compiled (40); ``params`` = [robot constants, kD, kP, kV]."""
    tau[0], tau[1] = vcl_torque(params, params[_KD], params[_KP], params[_KV], q1, q2, q3, d1, d2, d3)
    return 0


@kernel
def conventional_kernel(q1, q2, q3, d1, d2, d3, t, params, memory, tau):
    """Compiled (12); ``params`` = [robot constants, kD, kP, kV]."""
    tau[0], tau[1] = conventional_torque(params, params[_KD], params[_KP], params[_KV], q1, q2, q3, d1, d2, d3)
    return 0


class EnergyVCLController(Controller):
    """Energy + virtual-composite-link swing-up controller (40).

    The angle q2 in e is *not* wrapped: V is defined on the unwrapped coordinate,
    as in the paper.

    Parameters
    ----------
    model : AnalyticModel
        The robot the controller believes in, normally read back from the MuJoCo model.
    kD, kP, kV : float
        Gains of (40).
    check : bool
        Validate the gains against the theory (:func:`~paa_mj.control.gains.check_gains`).
    """

    name = "vcl-only"
    uses_vcl = True

    def __init__(self, model: AnalyticModel, kD, kP, kV, check=True):
        self.model = model
        self.kD, self.kP, self.kV = float(kD), float(kP), float(kV)
        if check:
            check_gains(model, self.kD, self.kP, self.kV, stacklevel=4)

    @property
    def gains(self) -> dict:
        return {"kD": self.kD, "kP": self.kP, "kV": self.kV}

    def _law(self):
        return vcl_torque

    def vcl_error(self, q):
        """e of (34) (this controller's error of the actuated coordinates), shape (..., 2) [rad]."""
        q = np.asarray(q, float)
        if not self.uses_vcl:
            return np.stack([q[..., 1], q[..., 2]], -1) - Q_AR
        b2, b3 = self.model.b2, self.model.b3
        return np.stack([q[..., 1] + theta(b2, b3, q[..., 2]), q[..., 2]], -1) - Q_AR

    def error_rate_matrix(self, q):
        """Phi with de/dt = Phi qd_a: Psi (21) for (40), the identity for (12); shape (..., 2, 2)."""
        q = np.asarray(q, float)
        if self.uses_vcl:
            return Psi(self.model.b2, self.model.b3, q[..., 2])
        return np.broadcast_to(np.eye(2), q.shape[:-1] + (2, 2))

    def energy_error(self, q, qd):
        """E - E_r [J]."""
        return self.model.energy(q, qd) - self.model.E_r

    def lyapunov(self, q, qd):
        """V of (34) (or (12)) [J^2]."""
        q, qd = np.asarray(q, float), np.asarray(qd, float)
        e = self.vcl_error(q)
        qd_a = qd[..., 1:]
        return (0.5 * self.energy_error(q, qd) ** 2 + 0.5 * self.kD * np.sum(qd_a**2, -1)
                + 0.5 * self.kP * np.sum(e**2, -1))

    def torque(self, q, qd, t=0.0):
        q, qd = np.asarray(q, float), np.asarray(qd, float)
        t2, t3 = self._law()(self.model.constants, self.kD, self.kP, self.kV, q[..., 0], q[..., 1], q[..., 2],
                             qd[..., 0], qd[..., 1], qd[..., 2])
        return np.stack([t2, t3], -1)

    def lyapunov_rate(self, q, qd, tau=None):
        """dV/dt along (1) with torque ``tau`` (default: this controller's), from the chain rule.

        dV/dt = (E - E_r) qd_a^T tau + kD qd_a^T qdd_a + kP e^T Phi qd_a; with this
        controller's tau it equals -kV qd_a^T qd_a (36).
        """
        q, qd = np.asarray(q, float), np.asarray(qd, float)
        tau = self.torque(q, qd) if tau is None else np.asarray(tau, float)
        qdd = self.model.acceleration(q, qd, tau)
        qd_a = qd[..., 1:]
        e_rate = np.einsum("...ij,...j->...i", self.error_rate_matrix(q), qd_a)
        return (self.energy_error(q, qd) * np.sum(qd_a * tau, -1)
                + self.kD * np.sum(qd_a * qdd[..., 1:], -1) + self.kP * np.sum(self.vcl_error(q) * e_rate, -1))

    def compiled(self) -> CompiledForm:
        law = vcl_kernel if self.uses_vcl else conventional_kernel
        return CompiledForm(law, np.concatenate([self.model.constants, [self.kD, self.kP, self.kV]]))

    def describe(self) -> dict:
        return {"controller": self.name, "gains": self.gains}


class ConventionalController(EnergyVCLController):
    """The conventional Lyapunov candidate (12): (40) with e = q_a - q_ar and Phi = I.

    The paper sets it aside because the relation between kP and the closed-loop
    equilibria is hard to analyse; Theorem 1's bounds are proved for (40) only,
    so its gains are checked against (41) (the same Lambda) and warned about
    against (59), (60) as a reference.
    """

    name = "vc-only"
    uses_vcl = False

    def _law(self):
        return conventional_torque
