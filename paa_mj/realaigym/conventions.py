"""Their conventions: their clock, their angles (q1 from hanging down), their start, and what their scores count as
up (the tip's height rule, or the goal's pose where the goal does not hold the tip at its highest)."""
from __future__ import annotations

import math

import numpy as np

from ..model.states import wrap
from . import scores

#: Their time step [s] (``sim_parameters.py`` of the three leaderboards).
DT = 0.002


def their_times(t_final, dt=DT, t0=0.0):
    """Their clock: t accumulated by ``t += dt`` while ``t < t_final`` (the run's length in steps follows from it)."""
    times, t = [t0], t0
    while t < t_final:
        t += dt
        times.append(t)
    return np.array(times)


def their_angles(X):
    """paa_mj's states (K, 2n) in their angles: q1 from hanging down (q1 + pi)."""
    X = np.array(X, float)
    X[:, 0] += np.pi
    return X


def hanging(n):
    """Their start [0, 0, 0, 0]: hanging at rest, in paa_mj's angles."""
    x0 = np.zeros(2 * n)
    x0[0] = -np.pi
    return x0


def their_goal(robot, task):
    """The task's goal state (2n) in their angles."""
    return their_angles(np.concatenate([task.goal, np.zeros(robot.params.n_links)])[None, :])[0]


def _goal_height(robot, task):
    return float(scores.tip_height(their_goal(robot, task)[None, :], robot.params.l)[0])


def up_threshold(robot, task):
    """Their "up" threshold [m], 0.9 of the tip's height at the goal, where the goal holds the tip at its highest
    (every link up, their acrobot's goal); None for any other goal, whose tip may be low (the gymnast's folded tip
    is below its highest), so that a height threshold would count a hanging-down chain as up."""
    height = _goal_height(robot, task)
    return 0.9 * height if math.isclose(height, float(np.sum(robot.params.l)), rel_tol=1e-9) else None


def up_rows(robot, task, X):
    """Rows of states X (K, 2n) in their angles counted as up by the swing-up time (v2) and the time up (v3): their tip
    rule where :func:`up_threshold` gives one; otherwise the goal's pose, every angle within the task's switch
    angle of the goal (the angles of region (68))."""
    threshold = up_threshold(robot, task)
    if threshold is not None:
        return scores.tip_height(X, robot.params.l) > threshold
    n = robot.params.n_links
    return np.all(np.abs(wrap(np.asarray(X, float)[:, :n] - their_goal(robot, task)[:n])) < task.switch_region.angle,
                  axis=1)
