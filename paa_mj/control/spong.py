"""Spong's acrobot swing-up, as Drake's ``AcrobotSpongController`` states it.

Spong (1995), "The swing up control problem for the Acrobot", IEEE Control Systems 15(1): collocated
partial feedback linearisation of the elbow with energy pumping, handed to an LQR near the upright.
This module follows, formula by formula, Drake's ``examples/acrobot/spong_controller.h``
(RobotLocomotion/drake), with its defaults: k_e = 5, k_p = 50, k_d = 5, a switch to the LQR where
its cost-to-go is below 1e3, the LQR of the linearisation at the upright with
Q = diag(10, 10, 1, 1), R = 1, and the torque clamped to [-20, 20] N m.

Coordinates. Drake's acrobot has theta1 = 0 hanging down and the upright at theta1 = pi; paa_mj has
q = 0 with every link up, both about the same axis (+y), so that

.. math::

    \\theta_1 = q_1 + \\pi, \\qquad \\theta_2 = q_2, \\qquad \\dot\\theta = \\dot q, \\qquad u = \\tau_2,

and Drake's mass matrix, bias and energy at theta are paa_mj's at q (``paa-mj peers`` checks it).
With M(q) the mass matrix, ``bias`` = H(q, qd) + G(q) + D qd (Drake's ``DynamicsBiasTerm``:
Coriolis, gravity and the joints' viscous damping), :math:`M^{-1} = [[a_1, a_2], [a_2, a_3]]`,
E = 1/2 qd^T M qd + P(q) and E_d = P(0) = (m1 lc1 + m2 (l1 + lc2)) g the energy at rest upright:

- swing-up (mode 0):

  .. math::

      y = -k_p \\theta_2 - k_d \\dot\\theta_2, \\qquad
      u_p = (a_2\\, \\mathrm{bias}_1 + y) / a_3 + \\mathrm{bias}_2, \\qquad
      u_e = -k_e (E - E_d)\\, \\dot\\theta_2, \\qquad u = u_p + u_e

  (u_p makes the elbow's acceleration y; u_e pumps energy: dE/dt = -k_e (E - E_d) qd2^2 plus the
  work of u_p and of the damping). theta2 is used as it is, not wrapped, as in Drake;
- balance (mode 1), where the cost-to-go x~^T S x~ < threshold, with x~ the error from the upright,
  theta1 wrapped to [0, 2 pi) and theta2 to [-pi, pi) as Drake wraps them (``math::wrap_to``):

  .. math::

      \\tilde x = (\\mathrm{wrap}_{[0, 2\\pi)}(\\theta_1) - \\pi,\\ \\mathrm{wrap}_{[-\\pi, \\pi)}(\\theta_2),\\
      \\dot\\theta_1,\\ \\dot\\theta_2), \\qquad u = -K \\tilde x;

- then u is clamped to [-20, 20] N m.

S and K solve the LQR of the linearisation of (1) (damping included, as Drake's ``Linearize`` of its
plant) at the upright, x = [q - 0, qd] = [theta - (pi, 0), thetadot] (the same numbers in both
coordinates). The switch has no hysteresis: the mode is recomputed at every state, so a trajectory
whose cost-to-go crosses the threshold back goes back to the swing-up law. Drake's controller
uses its plant's parameters; here they are the analytic model's (:mod:`paa_mj.model.chain`), the
robot's own. Units (Drake's): k_e [s] (u_e [N m] = k_e [s] (E - E_d) [J] qd2 [rad/s]), k_p [1/s^2],
k_d [1/s] (y is an acceleration [rad/s^2]), torques [N m].
"""
from __future__ import annotations

import math

import numpy as np
from numba import types
from numba.extending import register_jitable

from ..errors import PaaError
from ..jit import lazy_njit
from ..model import chain
from ..model.dynamics import AnalyticModel
from ..task import Task
from .base import CompiledForm, Controller, kernel
from .record import controller

#: Drake's defaults (``SpongControllerParams``): energy gain k_e, elbow gains k_p [1/s^2] and k_d [1/s],
#: the threshold of the LQR cost-to-go below which the LQR acts.
K_E, K_P, K_D, THRESHOLD = 5.0, 50.0, 5.0, 1e3
#: Drake's clamp of the elbow torque [N m] (``ku_upper_bound``, hard-coded in spong_controller.h).
TORQUE_CLAMP = 20.0
#: The LQR weights of Drake's controller: Q = diag(10, 10, 1, 1) on [theta - (pi, 0), thetadot], R = 1.
LQR_Q = np.diag([10.0, 10.0, 1.0, 1.0])
LQR_R = np.eye(1)

# Layout of the parameter vector.
_KE, _KP, _KD, _THR, _CLAMP, _ED = range(6)
_A, _B, _DAMP, _ARM, _S, _K = 6, 10, 12, 14, 16, 32
_SIZE = 36


@register_jitable
def wrap_to(value, low, high):
    """Drake's ``math::wrap_to``: ``value`` wrapped into [low, high), value - range floor((value - low) / range)."""
    span = high - low
    return value - span * math.floor((value - low) / span)


#: Scratch numbers of :func:`spong_torque` (the mass matrix, the bias, two angle pairs), the controller's memory.
_WORK = 10


@register_jitable
def spong_torque(params, x, tau, work):
    """Drake's Spong law at one state x = [q1, q2, qd1, qd2] (paa_mj's coordinates) into ``tau`` (1);
    returns the mode, 1 where the LQR acts (cost-to-go below the threshold), else 0. ``work``: :data:`_WORK`
    scratch numbers (nothing is allocated but one vector, so that a Warp device runs this very source)."""
    q, qd = chain.vector_view(x, 0, 2), chain.vector_view(x, 2, 2)
    e = np.empty(4)
    e[0] = wrap_to(q[0] + math.pi, 0.0, 2.0 * math.pi) - math.pi
    e[1] = wrap_to(q[1], -math.pi, math.pi)
    e[2] = qd[0]
    e[3] = qd[1]
    cost = 0.0
    for i in range(4):
        row = 0.0
        for j in range(4):
            row += params[_S + 4 * i + j] * e[j]
        cost += e[i] * row
    if cost < params[_THR]:
        u = 0.0
        for j in range(4):
            u -= params[_K + j] * e[j]
        mode = 1
    else:
        A, b, arm = chain.matrix_view(params, _A, 2, 2), chain.vector_view(params, _B, 2), \
            chain.vector_view(params, _ARM, 2)
        M, bias = chain.matrix_view(work, 0, 2, 2), chain.vector_view(work, 4, 2)
        phi, rate = chain.vector_view(work, 6, 2), chain.vector_view(work, 8, 2)
        chain._mass_matrix_with(A, arm, q, M, phi)
        chain._bias_with(A, b, q, qd, bias, phi, rate)
        bias[0] += params[_DAMP] * qd[0]
        bias[1] += params[_DAMP + 1] * qd[1]
        det = M[0, 0] * M[1, 1] - M[0, 1] * M[1, 0]
        a2 = -M[0, 1] / det
        a3 = M[0, 0] / det
        energy = chain.kinetic(M, qd) + chain.potential(b, q)
        u_e = -params[_KE] * (energy - params[_ED]) * qd[1]
        y = -params[_KP] * q[1] - params[_KD] * qd[1]
        u_p = (a2 * bias[0] + y) / a3 + bias[1]
        u = u_e + u_p
        mode = 0
    clamp = params[_CLAMP]
    if u >= clamp:
        u = clamp
    if u <= -clamp:
        u = -clamp
    tau[0] = u
    return mode


@kernel
def spong_kernel(x, t, params, memory, tau):
    """Compiled Spong law (:func:`spong_torque`); the mode is recomputed at every step (the memory is scratch)."""
    return spong_torque(params, x, tau, memory)


# the layouts of KERNEL_SIG, which the kernel passes (its memory the scratch ``work``): the law is compiled once for
# both
@lazy_njit(types.void(types.float64[:], types.float64[:, :], types.float64[:, :], types.int8[:], types.float64[:]),
           cache=True)
def _spong_rows(params, x, tau, mode, work):
    for r in range(x.shape[0]):
        mode[r] = spong_torque(params, x[r], tau[r], work)


def spong_lqr(model: AnalyticModel, task: Task, Q=LQR_Q, R=LQR_R):
    """(S, K) of the LQR at the upright (the stretched task's goal): S the stabilising solution of the continuous
    Riccati equation of the linearisation of (1) at q = 0 (damping included) with x = [q, qd], K = R^-1 B^T S
    (SciPy)."""
    from scipy.linalg import solve_continuous_are

    from ..theory.linear import goal_linearization

    A, B = goal_linearization(model, task)
    S = solve_continuous_are(A, B, Q, R)
    return S, np.linalg.solve(R, B.T @ S)


class SpongController(Controller):
    """Spong's swing-up with Drake's LQR switch (module docstring), for a two-link robot (an acrobot).

    Parameters
    ----------
    model : AnalyticModel
        The robot's analytic model: M, bias, energy and the linearisation come from it.
    k_e, k_p, k_d : float
        Energy gain and the elbow's PD gains of the collocated linearisation (Drake's defaults).
    threshold : float
        The LQR acts where its cost-to-go x~^T S x~ is below this (Drake's ``balancing_threshold``).
    clamp : float
        The torque is clamped to [-clamp, clamp] [N m] (Drake's 20 N m).
    task : Task, optional
        The stretched task (every link up), the only one Spong's law aims at; default its defaults.

    Attributes
    ----------
    mode : int8 or ndarray of int8
        Per state of the last call: 1 where the LQR acted, 0 where the swing-up law did.
    S, K : ndarray (4, 4), (1, 4)
        The LQR's cost-to-go matrix and gain, on x = [q, qd] about the upright.
    """

    name = "spong"

    def __init__(self, model: AnalyticModel, k_e=K_E, k_p=K_P, k_d=K_D, threshold=THRESHOLD, clamp=TORQUE_CLAMP,
                 task: Task | None = None):
        if model.n_links != 2:
            raise PaaError(f"spong is Spong's acrobot swing-up, for robots of 2 links; this one has {model.n_links}")
        from ..theory.linear import require_passive_first

        require_passive_first(model, "spong (Spong's acrobot swing-up, its motor at the elbow)")
        task = Task.named("stretched", model) if task is None else task
        if task.name != "stretched":
            raise PaaError("spong swings the acrobot up to the stretched upright (every link up): use the stretched"
                           " task (--goal stretched)")
        values = {"k_e": k_e, "k_p": k_p, "k_d": k_d, "threshold": threshold, "clamp": clamp}
        for key, value in values.items():
            if not (isinstance(value, (int, float, np.floating, np.integer)) and not isinstance(value, bool)
                    and math.isfinite(value) and value > 0):
                raise PaaError(f"spong's {key} must be a positive finite number, got {value!r}")
        self.model = model
        self.k_e, self.k_p, self.k_d = float(k_e), float(k_p), float(k_d)
        self.threshold, self.clamp = float(threshold), float(clamp)
        self.S, self.K = spong_lqr(model, task)
        p = model.params
        self.E_desired = task.goal_energy(model)  # P(0) = (m1 lc1 + m2 (l1 + lc2)) g
        params = np.zeros(_SIZE)
        params[:_A] = [self.k_e, self.k_p, self.k_d, self.threshold, self.clamp, self.E_desired]
        params[_A:_B] = model.inertia_constants.reshape(-1)
        params[_B:_DAMP] = model.gravity_constants
        params[_DAMP:_ARM] = p.damping
        params[_ARM:_S] = p.armature
        params[_S:_K] = self.S.reshape(-1)
        params[_K:] = self.K.reshape(-1)
        self.params = params
        self.mode = np.int8(0)
        self.bind(model, task)

    def reset(self):
        self.mode = np.int8(0)

    def cost_to_go(self, q, qd):
        """x~^T S x~ at states (..., 2), (..., 2), with Drake's wrapping; shape (...)."""
        q, qd = np.broadcast_arrays(np.asarray(q, float), np.asarray(qd, float))
        span = 2.0 * np.pi
        e1 = (q[..., 0] + np.pi) - span * np.floor((q[..., 0] + np.pi) / span) - np.pi
        e2 = q[..., 1] - span * np.floor((q[..., 1] + np.pi) / span)
        e = np.stack([e1, e2, qd[..., 0], qd[..., 1]], -1)
        return np.einsum("...i,ij,...j->...", e, self.S, e)

    def law(self, q, qd, t):
        q, qd = np.broadcast_arrays(q, qd)
        batch = q.shape[:-1]
        x = np.ascontiguousarray(np.concatenate([q, qd], axis=-1).reshape(-1, 4))
        tau = np.empty((x.shape[0], 1))
        mode = np.empty(x.shape[0], np.int8)
        _spong_rows(self.params, x, tau, mode, np.empty(_WORK))
        self.mode = mode.reshape(batch) if batch else mode[0]
        return tau.reshape(batch + (1,))

    def compiled(self) -> CompiledForm:
        return CompiledForm(spong_kernel, self.params, memory=np.zeros(_WORK), balance_gain=self.K)

    def describe(self) -> dict:
        return {"controller": self.name, "k_e": self.k_e, "k_p": self.k_p, "k_d": self.k_d,
                "switch": f"LQR cost-to-go < {self.threshold:g} (Q = diag(10, 10, 1, 1), R = 1), no hysteresis",
                "clamp": self.clamp}


@controller("spong", "Spong's acrobot swing-up, then LQR below a cost-to-go (Drake's defaults; 2 links, --goal"
            " stretched)", links=2, goals=("stretched",), hands_over=True, device=True,
            kernels=(spong_kernel,))
def build_spong(robot, task, gains=None, check=True):
    """Spong's acrobot swing-up with Drake's defaults (module docstring): two links, stretched goal."""
    if robot.params.n_links != 2:
        raise PaaError(f"spong is Spong's acrobot swing-up, for robots of 2 links; {robot.name} has"
                       f" {robot.params.n_links}")
    return SpongController(robot.analytic, task=task)
