"""The passive robot: zero torque (for energy tests and as a baseline)."""
from __future__ import annotations

import numpy as np

from .base import CompiledForm, Controller, kernel
from .record import controller


@kernel
def passive_kernel(x, t, params, memory, tau):
    tau[:] = 0.0
    return 0


class PassiveController(Controller):
    """tau = 0."""

    name = "passive"

    def law(self, q, qd, t):
        shape = np.shape(q)
        return np.zeros(shape[:-1] + (shape[-1] - 1,))

    def compiled(self) -> CompiledForm:
        return CompiledForm(passive_kernel, np.zeros(1))


@controller("passive", "zero torque", device=True, kernels=(passive_kernel,), passive=None)
def build_passive(robot, task, gains=None, check=True):
    """Zero torque."""
    return PassiveController().bind(robot, task)
