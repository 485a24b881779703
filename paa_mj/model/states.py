"""The named states of the paper's gymnast, and angles wrapped to (-pi, pi].

- (65): hanging straight down at rest, q = (-pi, 0, 0), qd = 0, where every kip starts;
- (8): the folded up-down-down equilibrium (UDD), q = (0, -pi, 0);
- (11): q_ar = [-pi, 0], the goal of the actuated coordinates;
- the down-up-up point (DUU), q = (-pi, -pi, 0), the other limit of Theorem 1.

The goals of the whole family, and what a run aims at, are :mod:`paa_mj.task`'s.
:func:`wrap` runs on scalars or arrays and inside numba kernels (one definition, as in
:mod:`paa_mj.model.equations`).
"""
from __future__ import annotations

import math

import numpy as np
from numba.extending import register_jitable

X0_HANGING = np.array([-np.pi, 0.0, 0.0, 0.0, 0.0, 0.0])
Q_UDD = np.array([0.0, -np.pi, 0.0])
Q_DUU = np.array([-np.pi, -np.pi, 0.0])
Q_AR = np.array([-np.pi, 0.0])
STATE_NAMES = ("q1", "q2", "q3", "d1", "d2", "d3")
#: Initial joint speeds above this [rad/s] (16 turns a second) describe no gymnast or robot of this model:
#: kips stay below about 10 rad/s, and an integrator's cost grows with the speed.
MAX_INITIAL_SPEED = 100.0
#: Initial angles beyond this [rad] (1600 turns) are refused: the same posture is given by a wrapped angle,
#: and far out, wrapping loses the digits that tell postures apart.
MAX_INITIAL_ANGLE = 1e4

PI = math.pi
TWO_PI = 2.0 * math.pi


@register_jitable
def wrap(a):
    """Angles wrapped to (-pi, pi] [rad]."""
    return PI - (PI - a) % TWO_PI


def wrap_angle(a):
    """Wrap angles to (-pi, pi] (NumPy)."""
    return wrap(np.asarray(a, dtype=float))
