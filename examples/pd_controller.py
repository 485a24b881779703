"""A controller of your own: a class in a file, built as ``ClassName(robot)``.

``torque(q, qd, t)`` maps batches of states (..., 3) [rad, rad/s] to torques (..., 2)
[N m]; ``reset()`` and ``mode`` are optional. Nothing of the package needs to change.
"""
import numpy as np


class HoldStraight:
    """A PD law on the motors that holds the body straight below the bar (q2 = q3 = 0)."""

    def __init__(self, robot):
        self.gain = 0.05 * robot.analytic.b1  # [N m/rad], scaled with the robot

    def torque(self, q, qd, t):
        q, qd = np.asarray(q), np.asarray(qd)
        return -self.gain * (q[..., 1:] + 0.5 * qd[..., 1:])
