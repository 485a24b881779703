"""The switching region (68) and the tolerances that judge a balance, around any goal of the family.

Region (68): with x = [q1, q2 + pi, q3, d1, d2, d3] the error from UDD (angles
wrapped to (-pi, pi]), every :math:`|x_i| < \\pi/6` and every :math:`|x_{i+3}| < 0.5` rad/s
(for a chain of n links and a goal q*, x = [wrap(q - q*), qd] and the same bounds). The
paper switches from swing-up (40) to the LQR (67) the first time the state is
inside. A run is *balanced* when its final state is within :data:`BALANCE_TOL`
of UDD in every coordinate; it is a *success* (:data:`SUCCESS_DEFINITION`, the
same in every study) when its true state stays inside region (68) over the last
:data:`SUCCESS_WINDOW` seconds without divergence.
"""
from __future__ import annotations

import math

import numpy as np
from numba.extending import register_jitable

from ..model.states import Q_UDD, goal_error, wrap
from .base import kernel

#: Region (68): each angle error within pi/6 [rad] and each speed within 0.5 [rad/s].
SWITCH_ANGLE = math.pi / 6
SWITCH_SPEED = 0.5
#: A final state within this distance of UDD (each coordinate, rad and rad/s) counts as balanced.
BALANCE_TOL = 1e-3
#: The last seconds of a run over which a success must stay inside region (68) [s].
SUCCESS_WINDOW = 1.0
#: What success means, in every study and every column (:func:`succeeded`).
SUCCESS_DEFINITION = (
    "balanced at the goal at the end: no divergence, and the true state (whatever the controller reports or"
    f" measures) inside region (68) around the goal (UDD for the paper's task), every angle error < pi/6 rad and"
    f" every speed < {SWITCH_SPEED:g} rad/s,"
    f" throughout the last {SUCCESS_WINDOW:g} s of the run (or stopped early as balanced for good)")


def succeeded(finished, retired, last_exit_step, end_step, dt):
    """The one success test of the package (:data:`SUCCESS_DEFINITION`), over arrays of rollouts.

    Parameters
    ----------
    finished, retired : ndarray of bool
        Ran to the final time; stopped early by the retirement rule (balanced for good).
    last_exit_step : ndarray of int
        The last step at which the true state was outside region (68) (-1: never).
    end_step : ndarray of int
        The step at which the run ended.
    dt : float
        Time step [s].
    """
    window = np.minimum(int(round(SUCCESS_WINDOW / dt)), end_step)
    return np.asarray(retired | (finished & (last_exit_step < end_step - window)), dtype=bool)


@register_jitable
def goal_terms(qpos, qvel, n, goal):
    """The error x = [wrap(q - q*), qd] of one state from the goal q*, as the compiled code needs it.

    Returns (inside region (68), the largest absolute angle error [rad], the largest absolute speed [rad/s],
    the sum of squared angle errors, the sum of squared speeds). The engine, the Gymnasium environments and :func:`region_condition` all judge
    region (68) here; its margin is max(angles / (pi/6), speeds / 0.5) - 1 (:func:`switch_margin`).
    """
    inside = True
    angle_max, speed_max, angles, speeds = 0.0, 0.0, 0.0, 0.0
    for i in range(n):
        x, d = wrap(qpos[i] - goal[i]), qvel[i]
        inside = inside and abs(x) < SWITCH_ANGLE and abs(d) < SWITCH_SPEED
        angle_max, speed_max = max(angle_max, abs(x)), max(speed_max, abs(d))
        angles += x * x
        speeds += d * d
    return inside, angle_max, speed_max, angles, speeds


@kernel
def region_condition(x, t, params, memory, tau):
    """Compiled condition: 1 inside region (68) around the goal q* = ``params`` (n angles), x = [q, qd]."""
    n = params.size
    return 1 if goal_terms(x[:n], x[n:], n, params)[0] else 0


def in_switch_region(q, qd, goal=Q_UDD):
    """Region (68) around ``goal`` (default UDD) for NumPy batches: shape (...,) of bool."""
    x = goal_error(q, qd, goal)
    n = x.shape[-1] // 2
    return np.all(np.abs(x[..., :n]) < SWITCH_ANGLE, axis=-1) & np.all(np.abs(x[..., n:]) < SWITCH_SPEED, axis=-1)


def switch_margin(q, qd, goal=Q_UDD):
    """A continuous function that is negative exactly inside region (68) around ``goal`` (an ODE event)."""
    x = goal_error(q, qd, goal)
    n = x.shape[-1] // 2
    return np.maximum(np.max(np.abs(x[..., :n]), axis=-1) / SWITCH_ANGLE,
                      np.max(np.abs(x[..., n:]), axis=-1) / SWITCH_SPEED) - 1.0


def distance_from_udd(q, qd, goal=Q_UDD):
    """:math:`\\max_i |x_i|` with x the error from UDD, or from ``goal`` (angles wrapped) [rad, rad/s]; shape (...,)."""
    return np.max(np.abs(goal_error(q, qd, goal)), axis=-1)


# --- a candidate reading of the paper's switch, for the report only ------------------------------------

#: The six limits of (68) in the order [angle, angle, angle, speed, speed, speed], applied by this reading
#: to the state ordered [q1, qd1, q2, qd2, q3, qd3].
_READING_LIMITS = (SWITCH_ANGLE, SWITCH_ANGLE, SWITCH_ANGLE, SWITCH_SPEED, SWITCH_SPEED, SWITCH_SPEED)


@register_jitable
def reading_margin(q1, q2, q3, d1, d2, d3):
    """The margin of a candidate reading of the paper's Matlab switch (negative inside).

    Angles of x reduced into [0, 2 pi) (Matlab's ``mod(x, 2*pi)``) instead of (-pi, pi],
    and the limits [pi/6, pi/6, pi/6, 0.5, 0.5, 0.5] applied to [q1, qd1, q2 + pi, qd2, q3, qd3]:
    so qd1 is held to pi/6, q3 to 0.5, and every angle error must be >= 0.
    """
    two_pi = 2.0 * math.pi
    v0 = np.abs(q1 % two_pi) / _READING_LIMITS[0]
    v1 = np.abs(d1) / _READING_LIMITS[1]
    v2 = np.abs((q2 + math.pi) % two_pi) / _READING_LIMITS[2]
    v3 = np.abs(d2) / _READING_LIMITS[3]
    v4 = np.abs(q3 % two_pi) / _READING_LIMITS[4]
    v5 = np.abs(d3) / _READING_LIMITS[5]
    return np.maximum(np.maximum(np.maximum(v0, v1), np.maximum(v2, v3)), np.maximum(v4, v5)) - 1.0


@kernel
def reading_condition(x, t, params, memory, tau):
    """Compiled: 1 inside the candidate reading's region (the gymnast's state x = [q, qd], 6 numbers)."""
    return 1 if reading_margin(x[0], x[1], x[2], x[3], x[4], x[5]) < 0.0 else 0
