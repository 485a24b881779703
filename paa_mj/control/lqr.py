"""The LQR balance controller (67) at UDD.

.. math::

    \\tau = -K x, \\qquad x = (q_1,\\ q_2 + \\pi,\\ q_3,\\ \\dot q_1,\\ \\dot q_2,\\ \\dot q_3)

(angles wrapped to :math:`(-\\pi, \\pi]`)
with K from the linearisation of (1) at UDD and the paper's weights
Q = 1e4 I6, R = I2 (:func:`paa_mj.theory.linear.lqr_gain`).
"""
from __future__ import annotations

import numpy as np
from numba.extending import register_jitable

from ..errors import PaaError
from ..model.dynamics import AnalyticModel
from ..model.states import udd_error_components
from ..theory.linear import lqr_gain
from .base import CompiledForm, Controller, kernel


@register_jitable
def linear_feedback(k, q1, q2, q3, d1, d2, d3):
    """tau = -K x of (67) with K flattened row by row into ``k`` (12 numbers)."""
    x1, x2, x3 = udd_error_components(q1, q2, q3)
    t2 = -(k[0] * x1 + k[1] * x2 + k[2] * x3 + k[3] * d1 + k[4] * d2 + k[5] * d3)
    t3 = -(k[6] * x1 + k[7] * x2 + k[8] * x3 + k[9] * d1 + k[10] * d2 + k[11] * d3)
    return t2, t3


@kernel
def lqr_kernel(q1, q2, q3, d1, d2, d3, t, params, memory, tau):
    """Compiled (67); ``params`` = K flattened; always in balance mode."""
    tau[0], tau[1] = linear_feedback(params, q1, q2, q3, d1, d2, d3)
    return 1


class LQRController(Controller):
    """LQR balance controller (67): tau = -K x.

    Parameters
    ----------
    K : array_like, shape (2, 6)
        State-feedback gain, normally :func:`paa_mj.theory.linear.lqr_gain`.
    """

    name = "lqr"
    mode = 1

    def __init__(self, K):
        self.K = np.asarray(K, float)
        if self.K.shape != (2, 6) or not np.all(np.isfinite(self.K)):
            raise PaaError(f"LQR gain must be a finite 2 x 6 matrix, got shape {self.K.shape}")

    @classmethod
    def for_model(cls, model: AnalyticModel) -> "LQRController":
        return cls(lqr_gain(model))

    def torque(self, q, qd, t=0.0):
        q, qd = np.asarray(q, float), np.asarray(qd, float)
        t2, t3 = linear_feedback(self.K.reshape(-1), q[..., 0], q[..., 1], q[..., 2], qd[..., 0], qd[..., 1], qd[..., 2])
        return np.stack(np.broadcast_arrays(t2, t3), -1)

    def compiled(self) -> CompiledForm:
        return CompiledForm(lqr_kernel, self.K.reshape(-1), balance_gain=self.K)

    def describe(self) -> dict:
        return {"controller": self.name}
