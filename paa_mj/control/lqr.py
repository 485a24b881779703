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
from ..model.states import Q_UDD, goal_angles, wrap
from ..theory.linear import lqr_gain
from .base import CompiledForm, Controller, kernel


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


def lqr_weights(n_links, weights=None):
    """Q (2n x 2n) and R (n - 1 x n - 1) of (67) from ``weights`` = (q, r) > 0, finite (Q = q I, R = r I), or the
    paper's (None: Q = 1e4 I, R = I); a one-line error otherwise."""
    if weights is None:
        return None, None
    try:
        q, r = (float(w) for w in weights)
    except (TypeError, ValueError):
        raise PaaError(f"the LQR weights are two numbers q, r (Q = q I, R = r I), got {weights!r}") from None
    if not (np.isfinite(q) and np.isfinite(r) and q > 0 and r > 0):
        raise PaaError(f"the LQR weights q, r must be positive and finite, got {q:g}, {r:g}")
    return q * np.eye(2 * n_links), r * np.eye(n_links - 1)


class LQRController(Controller):
    """LQR balance controller (67): tau = -K x, x the error from the goal.

    Parameters
    ----------
    K : array_like, shape (n - 1, 2n)
        State-feedback gain, normally :func:`paa_mj.theory.linear.lqr_gain` ((2, 6) for the gymnast).
    goal : array_like (n,), optional
        The goal angles q* [rad]; default UDD (8).
    """

    name = "lqr"
    mode = 1

    def __init__(self, K, goal=Q_UDD, weights=None):
        #: The (q, r) the gain was computed with (Q = q I, R = r I), recorded in the run's metadata; None: the
        #: paper's, or a gain given as it is.
        self.weights = None if weights is None else tuple(float(w) for w in weights)
        self.K = np.asarray(K, float)
        self.goal = np.array(goal, dtype=float).reshape(-1)
        n = self.goal.size
        if self.K.shape != (n - 1, 2 * n) or not np.all(np.isfinite(self.K)):
            raise PaaError(f"LQR gain must be a finite {n - 1} x {2 * n} matrix, got shape {self.K.shape}")

    @classmethod
    def for_model(cls, model: AnalyticModel, goal="folded", weights=None) -> "LQRController":
        """(67) at the goal; ``weights`` = (q, r) for Q = q I (2n), R = r I (n - 1), default the paper's (1e4, 1)."""
        Q, R = lqr_weights(model.n_links, weights)
        return cls(lqr_gain(model, Q, R, goal=goal), goal_angles(goal, model.n_links), weights)

    def torque(self, q, qd, t=0.0):
        x = np.concatenate(np.broadcast_arrays(np.asarray(q, float), np.asarray(qd, float)), axis=-1)
        tau = np.empty(x.shape[:-1] + (self.goal.size - 1,))
        linear_feedback(self.K.reshape(-1), self.goal, np.moveaxis(x, -1, 0), np.moveaxis(tau, -1, 0))
        return tau

    def compiled(self) -> CompiledForm:
        return CompiledForm(lqr_kernel, np.concatenate([self.goal, self.K.reshape(-1)]), balance_gain=self.K)

    def describe(self) -> dict:
        out = {"controller": self.name}
        if self.weights is not None:
            out["lqr_weights"] = list(self.weights)
        return out
