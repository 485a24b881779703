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

Beyond the paper, the same law runs on any chain of the family and either goal
(:func:`chain_energy_torque`): M, H, G of :mod:`paa_mj.model.chain`, B = [0; I],
E_r = P(q*), and for (40) the virtual composite link of links 2..n,
theta = atan2(sum_k b_k sin(phi_k - phi_2), sum_k b_k cos(phi_k - phi_2)) (k >= 2; for
n = 3 this is (16), (17)), e = [q2 + theta - q2*, q3 - q3*, ..., qn - qn*], Psi = de/dq_a.
For two links (40) is the energy-based acrobot law of Xin and Kaneda (theta = 0,
Psi = 1). Joint damping D is put into H (the law compensates its effect on the
accelerations), which leaves :math:`\\dot V = -k_V \\dot q_a^\\top \\dot q_a - (E - E_r) \\dot q^\\top D \\dot q`: the last
term is the energy the damping takes, not sign-definite, and zero without damping.
The paper's closed forms run wherever the robot is its gymnast and the goal its UDD.
"""
from __future__ import annotations

import math

import numpy as np
from numba import types
from numba.extending import register_jitable

from ..jit import lazy_njit
from ..model import chain
from ..model import equations as eq
from ..model.dynamics import AnalyticModel
from ..model.states import Q_AR
from ..model.vcl import Psi, psi, theta
from ..task import Task
from ..theory.linear import require_passive_first, theorem1_covers
from .base import Binding, CompiledForm, Controller, kernel
from .combined import switched
from .gains import check_gains_for, resolve_gains
from .lqr import lqr_kernel
from .record import controller
from .region import level_condition, region_condition

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
def vcl_kernel(x, t, params, memory, tau):
    """Compiled (40); ``params`` = [robot constants, kD, kP, kV]."""
    tau[0], tau[1] = vcl_torque(params, params[_KD], params[_KP], params[_KV], x[0], x[1], x[2], x[3], x[4], x[5])
    return 0


@kernel
def conventional_kernel(x, t, params, memory, tau):
    """Compiled (12); ``params`` = [robot constants, kD, kP, kV]."""
    tau[0], tau[1] = conventional_torque(params, params[_KD], params[_KP], params[_KV], x[0], x[1], x[2], x[3], x[4],
                                         x[5])
    return 0


# --- the same law on any chain of the family, any goal ----------------------------------------------------
# params = [n, uses_vcl, kD, kP, kV, E_r, A (n x n), b (n), damping (n), armature (n), q* (n)]
_C_N, _C_VCL, _C_KD, _C_KP, _C_KV, _C_ER, _C_A = range(7)


def chain_parameters(model: AnalyticModel, task: Task, kD, kP, kV, uses_vcl):
    """The parameter vector of :func:`chain_energy_torque` for ``model`` and the task's goal."""
    p = model.params
    return np.concatenate([[p.n_links, 1.0 if uses_vcl else 0.0, kD, kP, kV, task.goal_energy(model)],
                           model.inertia_constants.reshape(-1), model.gravity_constants, p.damping, p.armature,
                           task.goal])


@register_jitable
def chain_work_size(n):
    """Scratch numbers (40) on an n-link chain takes from its memory (:func:`chain_energy_torque`): two (n, n)
    matrices, two (n - 1, n - 1), an (n - 1, 1), then vectors of n - 1 and 4 n."""
    nu = n - 1
    return 2 * n * n + 2 * nu * nu + 2 * nu + 4 * n


@register_jitable
def _chain_vectors(params):
    """The chain's n and the views of its vectors in ``params`` (:func:`chain_parameters`): b, damping, armature,
    goal (n each)."""
    n = int(params[_C_N])
    at = _C_A + n * n
    return (n, chain.vector_view(params, at, n), chain.vector_view(params, at + n, n),
            chain.vector_view(params, at + 2 * n, n), chain.vector_view(params, at + 3 * n, n))


@register_jitable
def chain_error(params, q, e, rate):
    """The error e of the actuated coordinates and Psi = de/dq_a into ``e`` (n - 1) and ``rate`` (n - 1, n - 1).

    (40): e = [q2 + theta - q2*, q3 - q3*, ...] with theta the angle of the virtual composite link of links
    2..n from link 2 (module docstring); (12): e = q_a - q_a*, Psi = I.
    """
    n, b, _, _, goal = _chain_vectors(params)
    nu = n - 1
    for i in range(nu):
        for j in range(nu):
            rate[i, j] = 1.0 if i == j else 0.0
        e[i] = q[i + 1] - goal[i + 1]
    if params[_C_VCL] == 0.0:
        return
    alpha = np.zeros(n)
    for k in range(2, n):
        alpha[k] = alpha[k - 1] + q[k]
    s, c = 0.0, 0.0
    for k in range(1, n):
        s += b[k] * math.sin(alpha[k])
        c += b[k] * math.cos(alpha[k])
    e[0] += math.atan2(s, c)
    norm = s * s + c * c
    tail_cos, tail_sin = 0.0, 0.0
    for j in range(n - 1, 1, -1):  # d theta / d q_j = (c sum_{k>=j} b_k cos alpha_k + s sum b_k sin alpha_k) / norm
        tail_cos += b[j] * math.cos(alpha[j])
        tail_sin += b[j] * math.sin(alpha[j])
        rate[0, j - 1] = (c * tail_cos + s * tail_sin) / norm


@register_jitable
def chain_energy_torque(params, x, tau, work):
    """(40) (or (12)) on a chain of the family: tau = Lambda^-1 (kD B^T M^-1 (H + G + D qd) - kV qd_a - kP Psi^T e),
    Lambda = (E - E_r) I + kD B^T M^-1 B, into ``tau`` (n - 1) [N m]; ``work``: scratch of :func:`chain_work_size`
    numbers (nothing is allocated but one vector, so that a Warp device runs this very source). A singular M or
    Lambda gives NaN torques, which the engines report."""
    n, b, damping, armature, _ = _chain_vectors(params)
    nu = n - 1
    kD, kP, kV, E_r = params[_C_KD], params[_C_KP], params[_C_KV], params[_C_ER]
    A = chain.matrix_view(params, _C_A, n, n)
    q, qd = chain.vector_view(x, 0, n), chain.vector_view(x, n, n)
    M, solved = chain.matrix_view(work, 0, n, n), chain.matrix_view(work, n * n, n, n)
    lam, rate = chain.matrix_view(work, 2 * n * n, nu, nu), chain.matrix_view(work, 2 * n * n + nu * nu, nu, nu)
    at = 2 * n * n + 2 * nu * nu
    r, e = chain.matrix_view(work, at, nu, 1), chain.vector_view(work, at + nu, nu)
    at += 2 * nu
    phi, speed, force = chain.vector_view(work, at, n), chain.vector_view(work, at + n, n), \
        chain.vector_view(work, at + 2 * n, n)
    chain._mass_matrix_with(A, armature, q, M, phi)
    chain._bias_with(A, b, q, qd, force, phi, speed)
    for i in range(n):  # [H + G + D qd, B], solved in place into [M^-1 (H + G + D qd), M^-1 B]
        solved[i, 0] = force[i] + damping[i] * qd[i]
        for j in range(1, n):
            solved[i, j] = 1.0 if i == j else 0.0
    de = chain.kinetic(M, qd) + chain.potential(b, q) - E_r
    regular = chain._solve_in_place(M, solved)
    chain_error(params, q, e, rate)
    for i in range(nu):
        for j in range(nu):
            lam[i, j] = kD * solved[i + 1, j + 1] + (de if i == j else 0.0)
        pull = 0.0
        for k in range(nu):
            pull += rate[k, i] * e[k]
        r[i, 0] = kD * solved[i + 1, 0] - kV * qd[i + 1] - kP * pull
    if regular:
        regular = chain._solve_in_place(lam, r)
    for i in range(nu):
        tau[i] = r[i, 0] if regular else math.nan


@kernel
def chain_energy_kernel(x, t, params, memory, tau):
    """Compiled (40) or (12) on any chain and goal; ``params`` of :func:`chain_parameters`, ``memory`` its scratch
    (:func:`chain_work_size`: nothing is carried from one step to the next)."""
    chain_energy_torque(params, x, tau, memory)
    return 0


# Row by row with the layouts the kernel passes (KERNEL_SIG's strided arrays, its memory the scratch ``work``), so
# that the law and its helpers are compiled once for both.
@lazy_njit(types.void(types.float64[:], types.float64[:, :], types.float64[:, :], types.float64[:]), cache=True)
def _chain_torque_rows(params, x, out, work):
    for r in range(x.shape[0]):
        chain_energy_torque(params, x[r], out[r], work)


@lazy_njit(types.void(types.float64[:], types.float64[:, ::1], types.float64[:, ::1], types.float64[:, :, ::1]), cache=True)
def _chain_error_rows(params, q, e, rate):
    for r in range(q.shape[0]):
        chain_error(params, q[r], e[r], rate[r])


class _PaperLaw:
    """(40) or (12) in the paper's closed forms, for its gymnast at its folded goal (Theorem 1's case)."""

    def __init__(self, model, kD, kP, kV, uses_vcl):
        self.model, self.gains, self.uses_vcl = model, (kD, kP, kV), uses_vcl
        self.E_r = model.E_r

    def torque(self, q, qd):
        law = vcl_torque if self.uses_vcl else conventional_torque
        t2, t3 = law(self.model.constants, *self.gains, q[..., 0], q[..., 1], q[..., 2], qd[..., 0], qd[..., 1],
                     qd[..., 2])
        return np.stack([t2, t3], -1)

    def error(self, q):
        if not self.uses_vcl:
            return np.stack([q[..., 1], q[..., 2]], -1) - Q_AR
        b2, b3 = self.model.b2, self.model.b3
        return np.stack([q[..., 1] + theta(b2, b3, q[..., 2]), q[..., 2]], -1) - Q_AR

    def rate(self, q):
        if self.uses_vcl:
            return Psi(self.model.b2, self.model.b3, q[..., 2])
        return np.broadcast_to(np.eye(2), q.shape[:-1] + (2, 2))

    def compiled(self):
        law = vcl_kernel if self.uses_vcl else conventional_kernel
        return CompiledForm(law, np.concatenate([self.model.constants, self.gains]))


class _ChainLaw:
    """(40) or (12) on any chain and goal (:func:`chain_energy_torque`)."""

    def __init__(self, model, kD, kP, kV, uses_vcl, task):
        self.params = chain_parameters(model, task, kD, kP, kV, uses_vcl)
        self.E_r = float(self.params[_C_ER])

    def torque(self, q, qd):
        x = np.concatenate(np.broadcast_arrays(q, qd), axis=-1)
        flat = np.ascontiguousarray(x.reshape(-1, x.shape[-1]))
        out = np.empty((len(flat), q.shape[-1] - 1))
        _chain_torque_rows(self.params, flat, out, np.empty(chain_work_size(int(self.params[_C_N]))))
        return out.reshape(x.shape[:-1] + (q.shape[-1] - 1,))

    def _rows(self, q):
        flat = np.ascontiguousarray(q.reshape(-1, q.shape[-1]))
        nu = q.shape[-1] - 1
        e, rate = np.empty((len(flat), nu)), np.empty((len(flat), nu, nu))
        _chain_error_rows(self.params, flat, e, rate)
        return e.reshape(q.shape[:-1] + (nu,)), rate.reshape(q.shape[:-1] + (nu, nu))

    def error(self, q):
        return self._rows(q)[0]

    def rate(self, q):
        return self._rows(q)[1]

    def compiled(self):
        return CompiledForm(chain_energy_kernel, self.params, memory=np.zeros(chain_work_size(int(self.params[_C_N]))))


class EnergyVCLController(Controller):
    """Energy + virtual-composite-link swing-up controller (40).

    The angle q2 in e is *not* wrapped: V is defined on the unwrapped coordinate,
    as in the paper. Where Theorem 1 covers the robot and task
    (:func:`~paa_mj.theory.linear.theorem1_covers`) the law is the paper's closed forms, elsewhere the
    chain's (module docstring); chosen once, here.

    Parameters
    ----------
    model : AnalyticModel
        The robot the controller believes in, normally read back from the MuJoCo model.
    kD, kP, kV : float
        Gains of (40).
    check : bool
        Validate the gains against the theory (:func:`~paa_mj.control.gains.check_gains`).
    task : Task
        What it aims at (its goal); default the paper's folded task.
    """

    name = "vcl-only"
    uses_vcl = True

    def __init__(self, model: AnalyticModel, kD, kP, kV, check=True, task: Task | None = None):
        require_passive_first(model, f"controller {'(40)' if self.uses_vcl else '(12)'} ({self.name})")
        self.model = model
        self.kD, self.kP, self.kV = float(kD), float(kP), float(kV)
        self.task = Task.named("folded", model) if task is None else task
        self.binding = Binding.of(model, self.task)
        covered = theorem1_covers(model, self.task)
        self._law = _PaperLaw(model, self.kD, self.kP, self.kV, self.uses_vcl) if covered else \
            _ChainLaw(model, self.kD, self.kP, self.kV, self.uses_vcl, self.task)
        if check:  # Theorem 1's bounds (59), (60) are proved for the paper's case only; (41) holds by definition
            check_gains_for(model, self.kD, self.kP, self.kV, self.task, stacklevel=4)

    @property
    def E_r(self) -> float:
        """The energy of the goal, P(q*) [J] ((9) at UDD)."""
        return self._law.E_r

    @property
    def gains(self) -> dict:
        return {"kD": self.kD, "kP": self.kP, "kV": self.kV}

    def vcl_error(self, q):
        """e of (34) (this controller's error of the actuated coordinates), shape (..., n - 1) [rad]."""
        return self._law.error(np.asarray(q, float))

    def error_rate_matrix(self, q):
        """Phi with de/dt = Phi qd_a: Psi (21) for (40), the identity for (12); shape (..., n - 1, n - 1)."""
        return self._law.rate(np.asarray(q, float))

    def energy_error(self, q, qd):
        """E - E_r [J]."""
        return self.model.energy(q, qd) - self.E_r

    def lyapunov(self, q, qd):
        """V of (34) (or (12)) [J^2]."""
        q, qd = np.asarray(q, float), np.asarray(qd, float)
        e = self.vcl_error(q)
        qd_a = qd[..., 1:]
        return (0.5 * self.energy_error(q, qd) ** 2 + 0.5 * self.kD * np.sum(qd_a**2, -1)
                + 0.5 * self.kP * np.sum(e**2, -1))

    def law(self, q, qd, t):
        return self._law.torque(q, qd)

    def lyapunov_rate(self, q, qd, tau=None):
        """dV/dt along (1) with torque ``tau`` (default: this controller's), from the chain rule.

        dV/dt = dE/dt (E - E_r) + kD qd_a^T qdd_a + kP e^T Phi qd_a, with dE/dt = qd_a^T tau - qd^T D qd;
        with this controller's tau it equals -kV qd_a^T qd_a (36), less (E - E_r) qd^T D qd with damping.
        """
        q, qd = np.asarray(q, float), np.asarray(qd, float)
        tau = self.torque(q, qd) if tau is None else np.asarray(tau, float)
        qdd = self.model.acceleration(q, qd, tau)
        qd_a = qd[..., 1:]
        e_rate = np.einsum("...ij,...j->...i", self.error_rate_matrix(q), qd_a)
        power = np.sum(qd_a * tau, -1) - np.sum(self.model.params.damping * qd * qd, -1)
        return (self.energy_error(q, qd) * power
                + self.kD * np.sum(qd_a * qdd[..., 1:], -1) + self.kP * np.sum(self.vcl_error(q) * e_rate, -1))

    def compiled(self) -> CompiledForm:
        return self._law.compiled()

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


# The built-in controllers of (40) and (12): each builder takes (robot, task, gains, check, **options); a robot
# outside the paper's family is refused before it, by the records (ControllerSpec.build).

@controller("vcl", "(40) swing-up, then LQR (67) on entering region (68): the paper's controller", gains=True,
            lqr=True, switches=True, compare=True, device=True,
            kernels=(vcl_kernel, chain_energy_kernel, lqr_kernel, region_condition, level_condition))
def build_vcl(robot, task, gains=None, check=True, lqr_weights=None, switch=None, limit=None):
    """The paper's controller: (40) + (67) switched by (68) (or by the LQR's region of attraction)."""
    return switched(robot, task, build_vcl_only(robot, task, gains, check), "vcl", lqr_weights, switch, limit)


@controller("vcl-only", "(40) alone", gains=True, device=True, kernels=(vcl_kernel, chain_energy_kernel))
def build_vcl_only(robot, task, gains=None, check=True):
    """Controller (40) alone, for the whole run."""
    return EnergyVCLController(robot.analytic, **resolve_gains(robot, task, **(gains or {})), check=check, task=task)


@controller("vcl-roa", "(40) swing-up, then LQR (67) once its cost-to-go is below the level of its region of"
            " attraction", gains=True, lqr=True, roa=True, device=True,
            kernels=(vcl_kernel, chain_energy_kernel, lqr_kernel, level_condition),
            checked=(("acrobot", "stretched"),))
def build_vcl_roa(robot, task, gains=None, check=True, lqr_weights=None, limit=None):
    """``vcl`` handing over to (67) on the LQR's region of attraction (``switch="roa"``) instead of (68)."""
    return switched(robot, task, build_vcl_only(robot, task, gains, check), "vcl-roa", lqr_weights, "roa", limit)


@controller("vc", "conventional candidate (12), then LQR (67) on entering (68)", gains=True, lqr=True,
            switches=True, compare=True, device=True,
            kernels=(conventional_kernel, chain_energy_kernel, lqr_kernel, region_condition, level_condition))
def build_vc(robot, task, gains=None, check=True, lqr_weights=None, switch=None, limit=None):
    """The conventional candidate (12) + (67) switched by (68) (or by the LQR's region of attraction)."""
    return switched(robot, task, build_vc_only(robot, task, gains, check), "vc", lqr_weights, switch, limit)


@controller("vc-only", "conventional candidate (12) alone", gains=True, device=True,
            kernels=(conventional_kernel, chain_energy_kernel))
def build_vc_only(robot, task, gains=None, check=True):
    """The conventional candidate (12) alone."""
    return ConventionalController(robot.analytic, **resolve_gains(robot, task, **(gains or {})), check=check,
                                  task=task)


@controller("vc-roa", "conventional candidate (12), then LQR (67) once its cost-to-go is below its region of"
            " attraction's level", gains=True, lqr=True, roa=True, device=True,
            kernels=(conventional_kernel, chain_energy_kernel, lqr_kernel, level_condition),
            checked=(("acrobot", "stretched"),))
def build_vc_roa(robot, task, gains=None, check=True, lqr_weights=None, limit=None):
    """``vc`` handing over to (67) on the LQR's region of attraction (``switch="roa"``) instead of (68)."""
    return switched(robot, task, build_vc_only(robot, task, gains, check), "vc-roa", lqr_weights, "roa", limit)
