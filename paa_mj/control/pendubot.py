"""The pendubot's energy-based swing-up of Fantoni, Lozano & Spong (2000), "Energy based control of the Pendubot",
IEEE Transactions on Automatic Control 45(4), 725-729.

A pendubot is a two-link chain with its motor at the shoulder (joint 1) and the elbow (joint 2) passive: here a
robot with ``actuated == (0,)`` (``make-model --links 2 --passive 2``, ``models/realaigym_pendubot.xml``). With
its equation of motion (1), M(q) qdd + h(q, qd) = [tau, 0]^T (h = H + G + D qd, M's entries m11, m12, m22,
Delta = m11 m22 - m12^2), the energy E = 1/2 qd^T M qd + P(q) has E_dot = qd1 tau (without damping), and the
candidate of Fantoni et al.

.. math::

    V = \\frac{k_E}{2} \\tilde E^2 + \\frac{k_D}{2} \\dot q_1^2 + \\frac{k_P}{2} \\tilde q_1^2, \\qquad
    \\tilde E = E - E_{top}, \\; \\tilde q_1 = q_1 - q_1^*

has :math:`\\dot V = \\dot q_1 (k_E \\tilde E \\tau + k_D \\ddot q_1 + k_P \\tilde q_1)`. With
:math:`\\ddot q_1 = (m_{22} (\\tau - h_1) + m_{12} h_2) / \\Delta`, the torque that makes
:math:`\\dot V = -k_V \\dot q_1^2` is

.. math::

    \\tau = \\frac{-k_V \\dot q_1 - k_P \\tilde q_1 + \\frac{k_D}{\\Delta} (m_{22} h_1 - m_{12} h_2)}
                 {k_E \\tilde E + k_D \\frac{m_{22}}{\\Delta}},

defined while the denominator is positive: for every state whose energy is at least the bottom's
(:math:`\\tilde E \\ge -2 (b_1 + b_2)`) that holds when :math:`k_D / k_E > 2 (b_1 + b_2) / \\min_{q_2} (m_{22} /
\\Delta)` (:func:`kd_bound`, the condition of their analysis, written out here for paa_mj's model). The law drives
the pendubot to the homoclinic orbit of the upright, with q1 at its goal and the energy the upright's; near it
the LQR (67) takes over (region (68), or the LQR's region of attraction), as in their paper. q1 is paa_mj's
(link 1 from the upward vertical), the goal every link up: q1* = 0, E_top = P(0) = b1 + b2. The error of q1 is
not wrapped, as theirs is not.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, types

from ..errors import PaaError
from ..jit import lazy_njit
from ..model import chain
from ..model.dynamics import AnalyticModel
from ..task import Task
from .base import Binding, CompiledForm, Controller, kernel
from .combined import switched
from .lqr import lqr_kernel
from .record import controller
from .region import level_condition, region_condition

#: The default gains, relative: k_E = 1, k_D = 1.5 :func:`kd_bound`, k_P = 5 k_D, k_V = k_D: the one of 36 of a grid
#: (k_D / bound in 1.05, 1.5, 3; k_P / k_D in 0.01, 0.1, 1, 5; k_V / k_D in 0.01, 0.1, 1) with the earliest swing-up
#: of RealAIGym's pendubot in their performance v2 with the hand-over on region (68) (6.61 s; two of the 36 swing up).
K_E, KD_MARGIN, KP_RATIO, KV_RATIO = 1.0, 1.5, 5.0, 1.0

# Layout of the parameters: the gains, the goal's energy and q1, then the chain's A (2 x 2), b, damping, armature.
_KE, _KD, _KP, _KV, _ETOP, _Q1 = range(6)
_A, _B, _DAMP, _ARM = 6, 10, 12, 14
_SIZE = 16
#: Scratch numbers of :func:`fantoni_torque` (the mass matrix, the bias, two angle pairs): the controller's memory.
_WORK = 10


def kd_bound(model: AnalyticModel, k_e=K_E, samples=3601) -> float:
    """The least k_D with k_E that keeps the law's denominator positive for every energy above the bottom's:
    2 k_E (b1 + b2) / min over q2 of m22 / Delta (module docstring), on a grid of ``samples`` elbow angles."""
    q2 = np.linspace(-np.pi, np.pi, samples)
    q = np.stack([np.zeros_like(q2), q2], -1)
    M = model.mass_matrix(q)
    ratio = M[:, 1, 1] / (M[:, 0, 0] * M[:, 1, 1] - M[:, 0, 1] ** 2)
    return float(2.0 * k_e * np.sum(model.gravity_constants) / np.min(ratio))


@njit(cache=True)
def fantoni_torque(params, x, tau, work):
    """The law (module docstring) at one state x = [q1, q2, qd1, qd2] into ``tau`` (1): the shoulder's torque [N m].
    ``work``: :data:`_WORK` scratch numbers (nothing is allocated)."""
    q, qd = chain.vector_view(x, 0, 2), chain.vector_view(x, 2, 2)
    A, b, arm = chain.matrix_view(params, _A, 2, 2), chain.vector_view(params, _B, 2), chain.vector_view(params, _ARM, 2)
    M, h = chain.matrix_view(work, 0, 2, 2), chain.vector_view(work, 4, 2)
    phi, rate = chain.vector_view(work, 6, 2), chain.vector_view(work, 8, 2)
    chain._mass_matrix_with(A, arm, q, M, phi)
    chain._bias_with(A, b, q, qd, h, phi, rate)
    h[0] += params[_DAMP] * qd[0]
    h[1] += params[_DAMP + 1] * qd[1]
    delta = M[0, 0] * M[1, 1] - M[0, 1] * M[1, 0]
    energy = chain.kinetic(M, qd) + chain.potential(b, q)
    k_d = params[_KD]
    top = -params[_KV] * qd[0] - params[_KP] * (q[0] - params[_Q1]) + k_d / delta * (M[1, 1] * h[0] - M[0, 1] * h[1])
    tau[0] = top / (params[_KE] * (energy - params[_ETOP]) + k_d * M[1, 1] / delta)
    return 0


@kernel
def fantoni_kernel(x, t, params, memory, tau):
    """Compiled law (:func:`fantoni_torque`); the memory is scratch."""
    return fantoni_torque(params, x, tau, memory)


@lazy_njit(types.void(types.float64[:], types.float64[:, :], types.float64[:, :], types.float64[:]), cache=True)
def _rows(params, x, tau, work):  # the kernel's layouts (its memory the scratch): the law compiled once for both
    for r in range(x.shape[0]):
        fantoni_torque(params, x[r], tau[r], work)


class FantoniController(Controller):
    """Fantoni, Lozano & Spong's energy-based swing-up of the pendubot (module docstring), alone.

    Parameters
    ----------
    model : AnalyticModel
        A pendubot's: two links, the motor at joint 1 (refused otherwise, in one line).
    k_e, k_d, k_p, k_v : float, optional
        The gains; default :data:`K_E`, :data:`KD_MARGIN` times :func:`kd_bound`, k_P = :data:`KP_RATIO` k_D,
        k_V = :data:`KV_RATIO` k_D. A k_D at or below the bound is refused (the law could divide by zero).
    task : Task, optional
        The stretched task (every link up), the only goal the law aims at.
    """

    name = "fantoni-only"

    def __init__(self, model: AnalyticModel, k_e=None, k_d=None, k_p=None, k_v=None, task: Task | None = None):
        if model.n_links != 2 or model.actuated != (0,):
            raise PaaError(f"fantoni is the pendubot's swing-up (Fantoni, Lozano & Spong 2000): two links, the motor at"
                           f" joint 1; this robot has {model.n_links} links, {model.params.actuation_text()}")
        task = Task.named("stretched", model) if task is None else task
        if task.name != "stretched":
            raise PaaError("fantoni swings the pendubot up to the stretched upright (every link up): use the stretched"
                           " task (--goal stretched)")
        bound = kd_bound(model, K_E if k_e is None else k_e)
        k_e = K_E if k_e is None else k_e
        k_d = KD_MARGIN * bound if k_d is None else k_d
        gains = {"k_e": k_e, "k_d": k_d, "k_p": KP_RATIO * k_d if k_p is None else k_p,
                 "k_v": KV_RATIO * k_d if k_v is None else k_v}
        for key, value in gains.items():
            if not (isinstance(value, (int, float, np.floating, np.integer)) and not isinstance(value, bool)
                    and math.isfinite(value) and value > 0):
                raise PaaError(f"fantoni's {key} must be a positive finite number, got {value!r}")
        if gains["k_d"] <= bound:
            raise PaaError(f"fantoni's k_d = {gains['k_d']:.6g} must be above {bound:.6g} (2 k_E (b1 + b2) / min m22 /"
                           " Delta), or its denominator can vanish")
        self.model, self.task, self.gains, self.bound = model, task, {k: float(v) for k, v in gains.items()}, bound
        p = model.params
        params = np.zeros(_SIZE)
        params[:_A] = [gains["k_e"], gains["k_d"], gains["k_p"], gains["k_v"], task.goal_energy(model), task.goal[0]]
        params[_A:_B] = model.inertia_constants.reshape(-1)
        params[_B:_DAMP] = model.gravity_constants
        params[_DAMP:_ARM] = p.damping
        params[_ARM:] = p.armature
        self.params = params
        self.binding = Binding.of(model, task)

    def law(self, q, qd, t):
        q, qd = np.broadcast_arrays(q, qd)
        batch = q.shape[:-1]
        x = np.ascontiguousarray(np.concatenate([q, qd], axis=-1).reshape(-1, 4))
        tau = np.empty((x.shape[0], 1))
        _rows(self.params, x, tau, np.empty(_WORK))
        return tau.reshape(batch + (1,))

    def compiled(self) -> CompiledForm:
        return CompiledForm(fantoni_kernel, self.params, memory=np.zeros(_WORK))

    def describe(self) -> dict:
        return {"controller": self.name, "gains": dict(self.gains), "source": "Fantoni, Lozano & Spong (2000),"
                " IEEE TAC 45(4) 725-729"}


@controller("fantoni-only", "Fantoni, Lozano & Spong's pendubot swing-up alone", links=2, passive=(2,),
            goals=("stretched",), device=True, kernels=(fantoni_kernel,))
def build_fantoni_only(robot, task, gains=None, check=True):
    """Fantoni, Lozano & Spong's pendubot swing-up (module docstring) alone."""
    return FantoniController(robot.analytic, task=task)


@controller("fantoni", "Fantoni, Lozano & Spong's (2000) energy-based pendubot swing-up, then LQR (67) on entering"
            " (68) (2 links, the motor at joint 1, --goal stretched)", links=2, passive=(2,), goals=("stretched",),
            lqr=True, switches=True, device=True,
            kernels=(fantoni_kernel, lqr_kernel, region_condition, level_condition))
def build_fantoni(robot, task, gains=None, check=True, lqr_weights=None, switch=None, limit=None):
    """The pendubot's swing-up of Fantoni et al., then (67) switched by (68) (or by the LQR's region of attraction)."""
    return switched(robot, task, build_fantoni_only(robot, task), "fantoni", lqr_weights, switch, limit)
