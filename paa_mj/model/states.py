"""The named states of the gymnast and its family, the goals, and the error from a goal, with angles wrapped.

- (65): hanging straight down at rest, q = (-pi, 0, 0), qd = 0, where every kip starts;
- (8): the folded up-down-down equilibrium (UDD), q = (0, -pi, 0), the goal;
- (11): q_ar = [-pi, 0], the goal of the actuated coordinates;
- the down-up-up point (DUU), q = (-pi, -pi, 0), the other limit of Theorem 1.

For a chain of n links (:data:`GOALS`): the *folded* goal is the paper's, link 1 up and
the others hanging down, q* = (0, -pi, 0, ..., 0) (for two links the up-down point of
Lemma 1); the *stretched* goal is every link up, q* = 0 (the classic acrobot swing-up).
Every run starts hanging at rest, q = (-pi, 0, ..., 0).

:func:`wrap`, :func:`udd_error_components` and :func:`goal_error_into` run on scalars
or arrays and inside numba kernels (one definition, as in
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


#: The goals of the family: the paper's folded posture and the fully stretched one.
GOALS = ("folded", "stretched")


def goal_angles(goal: str, n_links: int) -> np.ndarray:
    """q* of a goal for a chain of ``n_links`` links [rad] (module docstring)."""
    if goal not in GOALS:
        from ..errors import PaaError

        raise PaaError(f"unknown goal {goal!r}: use one of {', '.join(GOALS)}")
    angles = np.zeros(n_links)
    if goal == "folded":
        angles[1] = -np.pi
    return angles


#: The stretched goal's runs start with link 1 this far from straight down [rad]: hanging at rest is an
#: equilibrium of (40) aiming at the stretched goal (e = 0, qd = 0, G = 0), so a swing-up from there never starts.
STRETCHED_START_OFFSET = 0.1


def start_state(n_links: int, goal: str = "folded") -> np.ndarray:
    """Where a run of the task starts by default: hanging at rest ((65) for the gymnast); for the stretched goal,
    link 1 :data:`STRETCHED_START_OFFSET` rad off straight down, at rest."""
    x = hanging_state(n_links)
    if goal == "stretched":
        x[0] += STRETCHED_START_OFFSET
    return x


def hanging_state(n_links: int) -> np.ndarray:
    """Hanging straight down at rest, (65) for the gymnast: q = (-pi, 0, ..., 0), qd = 0."""
    x = np.zeros(2 * n_links)
    x[0] = -np.pi
    return x


@register_jitable
def goal_error_into(q, goal, out):
    """out[i] = q[i] - q*[i] wrapped to (-pi, pi], for i < n (the angle part of the error from the goal)."""
    for i in range(goal.size):
        out[i] = wrap(q[i] - goal[i])


def goal_error(q, qd, goal):
    """State error from the goal, [wrap(q - q*), qd], shape (..., 2n); (67)'s x for the gymnast's folded goal."""
    q, qd = np.asarray(q, float), np.asarray(qd, float)
    angles = wrap(q - np.asarray(goal, float))
    return np.concatenate(np.broadcast_arrays(angles, qd), axis=-1)


@register_jitable
def udd_error_components(q1, q2, q3):
    """The angle part of x = [q1, q2 + pi, q3, d1, d2, d3] of (67), each wrapped to (-pi, pi]."""
    return wrap(q1), wrap(q2 + PI), wrap(q3)


def wrap_angle(a):
    """Wrap angles to (-pi, pi] (NumPy)."""
    return wrap(np.asarray(a, dtype=float))


def udd_error(q, qd):
    """State error from UDD, x = [q1, q2 + pi, q3, d1, d2, d3], angles wrapped to (-pi, pi]; shape (..., 6)."""
    q, qd = np.asarray(q, float), np.asarray(qd, float)
    x1, x2, x3 = udd_error_components(q[..., 0], q[..., 1], q[..., 2])
    return np.concatenate([np.stack(np.broadcast_arrays(x1, x2, x3), -1), qd], axis=-1)
