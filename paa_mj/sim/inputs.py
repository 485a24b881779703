"""What a rollout is given, checked: initial states, durations, sampling intervals, per-rollout values.

Each function returns the value in the form the engine takes, or raises one line naming what was wrong
(:class:`~paa_mj.errors.PaaError`).
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import PaaError
from ..limits import positive_finite
from ..model.robot import Robot
from ..model.states import MAX_INITIAL_ANGLE, MAX_INITIAL_SPEED


def per_rollout(value, n, width, name, default):
    """``value`` as an (n, width) float array: None, a scalar, one value per component (width,), one per
    rollout (n,), or (n, width). With width > 1, a vector of ``width`` values is per component."""
    if value is None:
        return np.full((n, width), default, dtype=float)
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0:
        arr = np.full((n, width), float(arr))
    elif arr.ndim == 1 and width > 1 and arr.size == width:
        arr = np.broadcast_to(arr, (n, width))
    elif arr.ndim == 1 and arr.size == n:
        arr = np.repeat(arr[:, None], width, axis=1)
    if arr.shape != (n, width):
        raise PaaError(f"{name} must have {width} value(s) per rollout, got shape {np.shape(value)} for {n} rollouts")
    if np.any(np.isnan(arr)):
        raise PaaError(f"{name} must not be NaN")
    return np.ascontiguousarray(arr)


def _state_names(n_links):
    return " ".join([f"q{i + 1}" for i in range(n_links)] + [f"d{i + 1}" for i in range(n_links)])


def _as_floats(x0, what, n_links):
    """A float copy of ``x0``: the run's own, writable, whatever it was given (a task's read-only start, the user's
    array, which a run must not share)."""
    try:
        return np.array(x0, dtype=float)
    except (TypeError, ValueError):
        raise PaaError(f"{what} must be numbers ({_state_names(n_links)}), got {x0!r:.60}") from None


def check_initial_states(x0, n_links=3) -> np.ndarray:
    """x0 as a finite (N, 2n) array for a chain of ``n_links`` links, or a one-line error."""
    x0 = np.atleast_2d(_as_floats(x0, "initial states", n_links))
    width = 2 * n_links
    if x0.ndim != 2 or x0.shape[1] != width or len(x0) == 0:
        raise PaaError(f"initial states must be an (N, {width}) array of {_state_names(n_links)}, got shape"
                       f" {x0.shape}")
    if not np.all(np.isfinite(x0)):
        raise PaaError("initial states must be finite")
    _check_initial_magnitudes(x0)
    return x0


def check_initial_state(x0, n_links=3) -> np.ndarray:
    """One initial state as a finite (1, 2n) array for a chain of ``n_links`` links, or a one-line error."""
    x0 = _as_floats(x0, "initial state", n_links).reshape(-1)
    if x0.size != 2 * n_links:
        raise PaaError(f"initial state needs {2 * n_links} numbers ({_state_names(n_links)}), got {x0.size}")
    if not np.all(np.isfinite(x0)):
        raise PaaError(f"initial state must be finite, got {x0.tolist()}")
    _check_initial_magnitudes(x0[None])
    return x0[None]


def _check_initial_magnitudes(x0):
    n = x0.shape[1] // 2
    farthest = float(np.max(np.abs(x0[:, :n])))
    if farthest > MAX_INITIAL_ANGLE:
        raise PaaError(f"initial angle {farthest:g} rad is beyond {MAX_INITIAL_ANGLE:g} rad: give it wrapped to"
                       " (-pi, pi]")
    fastest = float(np.max(np.abs(x0[:, n:])))
    if fastest > MAX_INITIAL_SPEED:
        raise PaaError(f"initial joint speed {fastest:g} rad/s is above {MAX_INITIAL_SPEED:g} rad/s, faster than any"
                       " gymnast or robot of this model turns")


def steps_for(t_final, dt):
    """The number of steps of a run of ``t_final`` seconds at ``dt`` (the nearest), checked against the time
    budget."""
    t_final = positive_finite("final time", t_final, allow_none=False)
    if not t_final / dt < 1e15:  # past this no run could finish: say so before counting the steps
        raise PaaError(f"final time {t_final:g} s is too long: it would need about {t_final / dt:.3g} physics steps"
                       f" of {dt:g} s; lower --t-final")
    n_steps = int(round(t_final / dt))
    if n_steps < 1:
        raise PaaError(f"final time {t_final:g} s is shorter than one time step ({dt:g} s)")
    return n_steps


def check_whole_steps(t_final, dt):
    """A final time the user asks for must be a whole number of time steps: a run ending elsewhere would be judged
    at another time than the one asked (the engines take the nearest step)."""
    n_steps = steps_for(t_final, dt)
    if abs(t_final / dt - n_steps) > 1e-9 * n_steps:
        # 12 digits: the times offered are whole numbers of steps as written (6 would round 0.3000625 to 0.300063)
        below = math.floor(t_final / dt)
        raise PaaError(f"final time {t_final:.12g} s is not a whole number of time steps (dt = {dt:g} s): give"
                       f" {below * dt:.12g} or {(below + 1) * dt:.12g}")


def sample_interval(sample_dt, dt, t_final):
    """Steps between two recorded samples: the interval must not exceed the run, and must be a whole number of
    time steps (an interval shorter than one step records every step)."""
    t_final = positive_finite("final time", t_final, allow_none=False)
    sample_dt = positive_finite("sample interval", sample_dt, allow_none=False)
    if sample_dt > t_final:
        raise PaaError(f"sample interval {sample_dt:g} s is longer than the run ({t_final:g} s): lower --sample-dt")
    steps = sample_dt / dt
    if steps < 1:  # finer than the time step: every step is recorded (the trajectory's sample_dt says so)
        return 1
    if abs(steps - round(steps)) > 1e-9 * steps:
        raise PaaError(f"sample interval {sample_dt:g} s is not a whole number of time steps (dt = {dt:g} s):"
                       " give a multiple of the time step")
    return int(round(steps))


def check_robot(robot):
    """A :class:`~paa_mj.model.robot.Robot` of :func:`~paa_mj.model.load_robot`, or a one-line error."""
    if not isinstance(robot, Robot):
        raise PaaError(f"controllers are built for a robot of load_robot(), got {type(robot).__name__}")


