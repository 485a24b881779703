"""Drake (RobotLocomotion), the peer ``paa-mj peers`` compares paa_mj with: how to get it, its version, and the map
between its acrobot's coordinates and paa_mj's (theta1 = q1 + pi, theta2 = q2).
"""
from __future__ import annotations

import numpy as np

from ..errors import PaaError

#: The one line that says how to get Drake.
INSTALL_HINT = 'paa-mj peers needs Drake: pip install "paa_mj[peers]"'


def require_drake():
    """Import pydrake, or a one-line :class:`PaaError` that says how to install it."""
    try:
        import pydrake  # noqa: F401
        from pydrake.examples import AcrobotPlant  # noqa: F401
    except ImportError:
        raise PaaError(INSTALL_HINT) from None


def drake_version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("drake")
    except PackageNotFoundError:
        return "unknown"


def theta_from_x(x):
    """Drake's acrobot state (theta1, theta2, theta1dot, theta2dot) from paa_mj's (q1, q2, qd1, qd2)."""
    x = np.array(x, float)
    x[..., 0] += np.pi
    return x


def x_from_theta(theta):
    """paa_mj's (q1, q2, qd1, qd2) from Drake's acrobot state."""
    x = np.array(theta, float)
    x[..., 0] -= np.pi
    return x
