"""What the Gymnasium environments share: their episode types, argument checks, and the maps between the
package's states and torques and a learner's observations and actions (extra ``paa_mj[gym]``).

Observation (:func:`observation`)
    ``Box(3n,)`` float32: cos q_i, sin q_i for each angle, then qd [rad/s] (unbounded); 9 for the gymnast.
Action (:func:`action_to_torque`)
    ``Box(m,)`` in [-1, 1] (m motors), scaled by the torque limits: tau = clip(a T, -T, T) [N m]; with
    ``normalize_actions=False`` the actions are the torques themselves, clipped at T.
"""
from __future__ import annotations

import math
import operator

import numpy as np
from numba import njit
from numba.extending import register_jitable

from ..limits import physical_torque_scale

#: The episode types: length [s], half-widths of the initial perturbation of the angles [rad] and speeds [rad/s],
#: terminate_margin, and the torque limit in units of b1 / 1 rad [N m]. Balancing needs far less torque than the
#: kip (the LQR (67), saturated at 0.1 b1, balances every start of the episode; unsaturated it peaks near 0.23 b1),
#: and the smaller limit lets a learner's first, random actions keep the robot near region (68) for about ten steps
#: instead of one.
EPISODES = {"kip": dict(seconds=30.0, noise=0.05, speed_noise=0.0, margin=math.inf, torque_b1=2.0),
            "balance": dict(seconds=10.0, noise=0.05, speed_noise=0.05, margin=0.5, torque_b1=0.1)}
#: Physics steps per environment step in v1: a 10 ms control period on the 1 ms step of the models.
FRAME_SKIP = 10
#: The largest torque limit [N m]: the action space is float32.
MAX_TORQUE_LIMIT = 1e12
#: The most environment steps of one episode.
MAX_EPISODE_STEPS = 1e12


# --- validation of arguments: one line that names the argument -----------------------------------------------

def _real_array(value):
    """``value`` as a float array, or None when it is not real numbers (text, complex, booleans, objects)."""
    try:
        array = np.asarray(value)
    except (TypeError, ValueError):
        return None
    if array.dtype.kind not in "fiu":
        return None
    return array.astype(float)


def _number(name, value, accept, rule, finite=True):
    """``value`` as a float for which ``accept`` holds, else a ValueError naming ``name`` and ``rule``."""
    try:
        if isinstance(value, (bool, np.bool_, str, bytes)):  # float() would read True as 1 and "2" as 2
            raise TypeError
        number = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {value!r}") from None
    if not ((math.isfinite(number) or not finite) and not math.isnan(number) and accept(number)):
        raise ValueError(f"{name} {rule}, got {value!r}")
    return number


def _whole(name, value, low, high):
    """``value`` as an int in [low, high] (a float only when whole), else a ValueError."""
    if isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} must be a whole number, got {value!r}")
    try:
        number = operator.index(value)
    except TypeError:
        number = _number(name, value, lambda v: v == int(v), "must be a whole number")
        number = int(number)
    if not low <= number <= high:
        raise ValueError(f"{name} must be in [{low}, {high}], got {value!r}")
    return number


def _check_x0(x0, rows=None, width=6):
    """``options["x0"]``: ``width`` (2n) finite numbers, or (with ``rows``) one row of them per environment too."""
    x0 = _real_array(x0)
    shapes = [(width,)] if rows is None else [(width,), (rows, width)]
    if x0 is None or x0.shape not in shapes or not np.all(np.isfinite(x0)):
        raise ValueError(f"options['x0'] must be {width} finite numbers" + ("" if rows is None
                                                                              else f" or {rows} rows of {width}"))
    return x0


def _check_options(options, known):
    if options is None:
        return {}
    # an option this environment does not know (a typo of x0) would be ignored in silence
    if not isinstance(options, dict):
        raise ValueError(f"options must be a dict (or None), got {type(options).__name__}")
    unknown = sorted(map(str, set(options) - set(known)))
    if unknown:
        raise ValueError(f"unknown reset option(s) {', '.join(unknown)}: the options are {', '.join(known)}")
    return options


# --- the maps between the package's states and torques and the learner's observations and actions -----------

def torque_limit_for(robot, episode="kip", torque_limit=None):
    """The torque limit [N m] asked for: ``torque_limit``, by default 2 b1 / 1 rad (kip) or 0.1 b1 / 1 rad
    (balance), b1 the robot's first gravity constant (4): a scale checked to be physical."""
    if torque_limit is not None:
        return float(torque_limit)
    return float(physical_torque_scale(EPISODES[episode]["torque_b1"] * robot.analytic.gravity_constants[0], robot,
                                       f"the {episode} episodes' default torque limit"))


def torque_limits_for(robot, episode="kip", torque_limit=None):
    """The torque limits T [N m], (m,), one per motor, of the environments: :func:`torque_limit_for` capped by the model's
    actuator ranges (:attr:`Robot.torque_limits <paa_mj.model.robot.Robot.torque_limits>`)."""
    return robot.capped_torque_limits(torque_limit_for(robot, episode, torque_limit))


def action_to_torque(action, torque_limits, normalized=True):
    """Torques tau [N m], (..., 2), of actions (..., 2): tau = clip(a T, -T, T), or clip(a, -T, T) when not normalised.

    The one definition of the action map: the environments and :class:`~paa_mj.control.policy.SB3Policy` use it.
    """
    action = np.asarray(action, dtype=float)
    if normalized:
        action = action * torque_limits
    return np.clip(action, -torque_limits, torque_limits)


def torque_to_action(tau, torque_limits, normalized=True):
    """The actions, float32 (..., 2), that ask for the torques ``tau`` [N m] (clipped at the limits T)."""
    tau = np.clip(np.asarray(tau, dtype=float), -torque_limits, torque_limits)
    return (tau / torque_limits if normalized else tau).astype(np.float32)


@register_jitable
def _observe_into(qpos, qvel, n, out):
    """[cos q1, sin q1, ..., cos qn, sin qn, qd1, ..., qdn] into ``out`` (3n)."""
    for i in range(n):
        out[2 * i], out[2 * i + 1] = math.cos(qpos[i]), math.sin(qpos[i])
        out[2 * n + i] = qvel[i]


@njit(cache=True)
def _observe_rows(q, qd, out):
    for i in range(q.shape[0]):
        _observe_into(q[i], qd[i], q.shape[1], out[i])


def observation(q, qd):
    """The observations, float32 (..., 3n), of states q, qd (..., n) [rad, rad/s]: for the gymnast (9)
    [cos q1, sin q1, cos q2, sin q2, cos q3, sin q3, qd1, qd2, qd3].

    The one definition of the observation map (the environments compute it with the same compiled code).
    """
    q, qd = np.asarray(q, dtype=float), np.asarray(qd, dtype=float)
    n = q.shape[-1]
    shape = np.broadcast_shapes(q.shape[:-1], qd.shape[:-1])
    # writable C arrays, copies where broadcast (read-only): one compiled version of the map, not one per kind
    q = np.require(np.broadcast_to(q, shape + (n,)).reshape(-1, n), requirements=("C", "W"))
    qd = np.require(np.broadcast_to(qd, shape + (n,)).reshape(-1, n), requirements=("C", "W"))
    out = np.empty((len(q), 3 * n), np.float32)
    _observe_rows(q, qd, out)
    return out.reshape(shape + (3 * n,))


