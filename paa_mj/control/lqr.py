"""The LQR balance controller (67) at UDD, or at any goal of the family.

.. math::

    \\tau = -K x, \\qquad x = (q_1,\\ q_2 + \\pi,\\ q_3,\\ \\dot q_1,\\ \\dot q_2,\\ \\dot q_3)

(angles wrapped to :math:`(-\\pi, \\pi]`)
with K from the linearisation of (1) at UDD and the paper's weights
Q = 1e4 I6, R = I2 (:func:`paa_mj.theory.linear.lqr_gain`). For a chain of n links and a
goal q*, x = [wrap(q - q*), qd], Q = 1e4 I(2n), R = I(n - 1).
"""
from __future__ import annotations

import numpy as np
from numba.extending import register_jitable

from ..errors import PaaError
from ..model.dynamics import AnalyticModel
from ..model.states import wrap
from ..task import Task
from ..theory.linear import lqr_gain
from .base import Binding, CompiledForm, Controller, kernel
from .record import controller


@register_jitable
def linear_feedback(k, goal, x, tau):
    """tau = -K e of (67) into ``tau``, e = [wrap(q - q*), qd] the error of x = [q, qd] from the goal q*, with K
    flattened row by row into ``k`` ((n - 1) x 2n numbers). Runs compiled on one state, or in NumPy on a batch
    laid out along the last axis (x of shape (2n, ...), tau (n - 1, ...)), the same sums in the same order."""
    n = goal.size
    width = 2 * n
    for row in range(tau.shape[0]):
        total = 0.0
        for j in range(n):
            total += k[width * row + j] * wrap(x[j] - goal[j])
        for j in range(n):
            total += k[width * row + n + j] * x[n + j]
        tau[row] = -total


@kernel
def lqr_kernel(x, t, params, memory, tau):
    """Compiled (67); ``params`` = [q* (n), K flattened]; always in balance mode."""
    n = x.size // 2
    linear_feedback(params[n:], params[:n], x, tau)
    return 1


#: The LQR weights accepted: q and r each in this range, and q / r in :data:`WEIGHT_RATIO_RANGE`. Beyond these the
#: Riccati equation of (67) has no solution SciPy can compute (q / r = 1e-20 fails), or the gains that balance
#: in theory do not at any time step a rollout can take.
WEIGHT_RANGE = (1e-9, 1e12)
WEIGHT_RATIO_RANGE = (1e-9, 1e12)


def lqr_weights(n_links, weights=None, n_motors=None):
    """Q (2n x 2n) and R (m x m, m = ``n_motors``, default n - 1) of (67) from ``weights`` = (q, r) (Q = q I, R = r I), or the paper's
    (None: Q = 1e4 I, R = I); a one-line error, with the range accepted (:data:`WEIGHT_RANGE`,
    :data:`WEIGHT_RATIO_RANGE`), otherwise."""
    if weights is None:
        return None, None
    try:
        q, r = (float(w) for w in weights)
    except (TypeError, ValueError):
        raise PaaError(f"the LQR weights are two numbers q, r (Q = q I, R = r I), got {weights!r}") from None
    (low, high), (ratio_low, ratio_high) = WEIGHT_RANGE, WEIGHT_RATIO_RANGE
    if not (low <= q <= high and low <= r <= high):
        raise PaaError(f"the LQR weights q, r must each lie in [{low:g}, {high:g}], got {q:g}, {r:g}")
    if not ratio_low <= q / r <= ratio_high:
        raise PaaError(f"the LQR weights' ratio q / r must lie in [{ratio_low:g}, {ratio_high:g}], got {q / r:.3g}"
                       f" ({q:g} / {r:g})")
    return q * np.eye(2 * n_links), r * np.eye(n_links - 1 if n_motors is None else n_motors)


class LQRController(Controller):
    """LQR balance controller (67): tau = -K x, x the error from the goal.

    Parameters
    ----------
    K : array_like, shape (m, 2n), 1 <= m < n the motors
        State-feedback gain, normally :func:`paa_mj.theory.linear.lqr_gain` ((2, 6) for the gymnast).
    task : Task
        What it balances at: the task's goal q*. A gain given as it is binds the controller to any robot
        of the task's links; :meth:`for_model` binds it to its robot.
    """

    name = "lqr"
    mode = 1

    def __init__(self, K, task: Task, weights=None):
        #: The (q, r) the gain was computed with (Q = q I, R = r I), recorded in the run's metadata; None: the
        #: paper's, or a gain given as it is.
        self.weights = None if weights is None else tuple(float(w) for w in weights)
        if not isinstance(task, Task):
            raise PaaError(f"an LQR controller balances at a task's goal: give a paa_mj.task.Task, got"
                           f" {type(task).__name__}")
        self.K = np.asarray(K, float)
        self.task = task
        self.goal = task.goal
        n = task.n_links
        if (self.K.ndim != 2 or not 1 <= self.K.shape[0] < n or self.K.shape[1] != 2 * n
                or not np.all(np.isfinite(self.K))):
            raise PaaError(f"LQR gain must be a finite m x {2 * n} matrix, m the robot's motors ({n - 1} x {2 * n} for"
                           f" joints 2..{n}), got shape {self.K.shape}")
        self.binding = Binding("any", n, None, task, n_motors=self.K.shape[0])

    @classmethod
    def for_model(cls, model: AnalyticModel, task: Task, weights=None) -> "LQRController":
        """(67) at the task's goal; ``weights`` = (q, r) for Q = q I (2n), R = r I (n - 1), default the paper's
        (1e4, 1)."""
        Q, R = lqr_weights(model.n_links, weights, model.n_motors)
        return cls(lqr_gain(model, task, Q, R), task, weights).bind(model, task)

    def law(self, q, qd, t):
        x = np.concatenate(np.broadcast_arrays(np.asarray(q, float), np.asarray(qd, float)), axis=-1)
        tau = np.empty(x.shape[:-1] + (self.K.shape[0],))
        linear_feedback(self.K.reshape(-1), self.goal, np.moveaxis(x, -1, 0), np.moveaxis(tau, -1, 0))
        return tau

    def compiled(self) -> CompiledForm:
        return CompiledForm(lqr_kernel, np.concatenate([self.goal, self.K.reshape(-1)]), balance_gain=self.K)

    def describe(self) -> dict:
        out = {"controller": self.name}
        if self.weights is not None:
            out["lqr_weights"] = list(self.weights)
        return out


@controller("lqr", "LQR (67) alone", lqr=True, device=True, kernels=(lqr_kernel,), passive=None)
def build_lqr(robot, task, gains=None, check=True, lqr_weights=None):
    """The LQR (67) alone, from wherever the robot starts."""
    return LQRController.for_model(robot.analytic, task, lqr_weights)
