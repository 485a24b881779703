"""The switch (68) as a compiled condition, and a candidate reading of the paper's switching code.

Region (68) itself, success and the balance tolerance are the task's (:mod:`paa_mj.task`): the
condition here only asks the task's compiled terms whether the state is inside.
"""
from __future__ import annotations

import math

import numpy as np
from numba.extending import register_jitable

from ..model.states import wrap
from ..task import SWITCH_ANGLE, SWITCH_SPEED, state_terms
from .base import kernel


@kernel
def region_condition(x, t, params, memory, tau):
    """Compiled condition: 1 inside region (68) of the task whose :attr:`~paa_mj.task.Task.params` are ``params``,
    x = [q, qd]."""
    n = x.size // 2
    return 1 if state_terms(params, x[:n], x[n:])[0] else 0


# --- a candidate reading of the paper's switch, for the report only ------------------------------------

#: The six limits of (68) in the order [angle, angle, angle, speed, speed, speed], applied by this reading
#: to the state ordered [q1, qd1, q2, qd2, q3, qd3].
_READING_LIMITS = (SWITCH_ANGLE, SWITCH_ANGLE, SWITCH_ANGLE, SWITCH_SPEED, SWITCH_SPEED, SWITCH_SPEED)


#: What each ratio of :func:`reading_ratios` measures, in its order.
READING_RATIOS = ("|q1| / (pi/6)", "|qd1| / (pi/6)", "(q2 + pi) / (pi/6)", "|qd2| / 0.5", "q3 / 0.5", "|qd3| / 0.5")


@register_jitable
def reading_ratios(q1, q2, q3, d1, d2, d3):
    """The six ratios of a candidate reading of the paper's Matlab switch (:data:`READING_RATIOS`): all below 1
    inside.

    Angles of x reduced into [0, 2 pi) (Matlab's ``mod(x, 2*pi)``) instead of (-pi, pi],
    and the limits [pi/6, pi/6, pi/6, 0.5, 0.5, 0.5] applied to [q1, qd1, q2 + pi, qd2, q3, qd3]:
    so qd1 is held to pi/6, q3 to 0.5, and every angle error must be >= 0.
    """
    two_pi = 2.0 * math.pi
    return (np.abs(q1 % two_pi) / _READING_LIMITS[0], np.abs(d1) / _READING_LIMITS[1],
            np.abs((q2 + math.pi) % two_pi) / _READING_LIMITS[2], np.abs(d2) / _READING_LIMITS[3],
            np.abs(q3 % two_pi) / _READING_LIMITS[4], np.abs(d3) / _READING_LIMITS[5])


@register_jitable
def reading_margin(q1, q2, q3, d1, d2, d3):
    """The margin of the candidate reading of :func:`reading_ratios` (negative inside): the largest ratio less 1."""
    v0, v1, v2, v3, v4, v5 = reading_ratios(q1, q2, q3, d1, d2, d3)
    return np.maximum(np.maximum(np.maximum(v0, v1), np.maximum(v2, v3)), np.maximum(v4, v5)) - 1.0


@kernel
def reading_condition(x, t, params, memory, tau):
    """Compiled: 1 inside the candidate reading's region (the gymnast's state x = [q, qd], 6 numbers)."""
    return 1 if reading_margin(x[0], x[1], x[2], x[3], x[4], x[5]) < 0.0 else 0


# --- the certified set as the switch: the LQR's cost-to-go below a level ----------------------------------

@register_jitable
def level_value(params, x):
    """V(x) = e^T S e - rho, e = [wrap(q - q*), qd]: negative exactly inside the set x^T S x < rho of
    :mod:`paa_mj.theory.roa`; ``params`` = [q* (n), S (2n x 2n, row by row), rho]."""
    n = x.size // 2
    width = 2 * n
    total = 0.0
    for i in range(width):
        ei = wrap(x[i] - params[i]) if i < n else x[i]
        row = 0.0
        for j in range(width):
            ej = wrap(x[j] - params[j]) if j < n else x[j]
            row += params[n + width * i + j] * ej
        total += ei * row
    return total - params[n + width * width]


@kernel
def level_condition(x, t, params, memory, tau):
    """Compiled condition: 1 where the LQR's cost-to-go x^T S x is below rho (:func:`level_value`)."""
    return 1 if level_value(params, x) < 0.0 else 0
