"""The passive robot: zero torque (for energy tests and as a baseline)."""
from __future__ import annotations

import numpy as np

from .base import CompiledForm, Controller, kernel


@kernel
def passive_kernel(q1, q2, q3, d1, d2, d3, t, params, memory, tau):
    tau[0] = 0.0
    tau[1] = 0.0
    return 0


class PassiveController(Controller):
    """tau = 0."""

    name = "passive"

    def torque(self, q, qd, t=0.0):
        return np.zeros(np.shape(q)[:-1] + (2,))

    def compiled(self) -> CompiledForm:
        return CompiledForm(passive_kernel, np.zeros(1))
