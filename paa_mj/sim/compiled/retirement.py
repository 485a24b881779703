"""Retirement: a rollout whose balance can no longer fail stops early.

Linearised at the goal and sampled with zero-order hold at the time step, the closed loop of the
plant and the controller's balance gain K is x_{k+1} = Phi x_k (x = [wrap(q - q*), qd], 2n
coordinates). Writing x = sum_m c_m v_m over the eigenvectors of Phi (all eigenvalues inside the unit
circle), every future :math:`|x_i|` is at most :math:`\\sum_m |c_m| |v_{m,i}|` (the *modal bound*,
tight when one mode dominates). A rollout retires when that bound is below
:data:`RETIRE_FRACTION` x the task's settled tolerance in every coordinate (the least of its balance
tolerance and its success region's half-widths, :meth:`~paa_mj.task.Task.settled_tol`): it would stay balanced,
and a success, to the end, and its peak torques can no longer grow (:math:`|K x|` only shrinks there).
Retirement is off where the bound does not hold: with noise, delay, pushes still to come, or an
unstable sampled loop.
"""
from __future__ import annotations

import math
import warnings

import numpy as np
from numba import njit

from ...control.base import balance_gain_of
from ...model.states import wrap
from ...theory.linear import sampled_balance, sampled_closed_loop

#: A rollout retires when its modal bound is below this fraction of the task's settled tolerance.
RETIRE_FRACTION = 0.9


def certificate_size(n_links: int) -> int:
    """Width of a certificate: Re and Im of V^-1 and the moduli of V, (2n x 2n) each."""
    return 3 * (2 * n_links) ** 2


def retirement_certificate(plant, K, dt, task):
    """(certificate, level) of the retirement rule for ``plant`` under tau = -K x, or (zeros, 0) if none.

    The certificate holds Re V^-1, Im V^-1 and the moduli of V (row by row) for the
    eigenvectors V of the closed loop Phi = Ad - Bd K of the plant linearised at
    the task's goal and sampled with zero-order hold at ``dt``; ``level`` =
    :data:`RETIRE_FRACTION` x the task's :meth:`~paa_mj.task.Task.settled_tol`.
    """
    none = np.zeros(certificate_size(plant.n_links)), 0.0
    if K is None:
        return none
    phi = sampled_closed_loop(plant, K, dt, task)
    if not np.all(np.isfinite(phi)):
        return none
    eigenvalues, vectors = np.linalg.eig(phi)
    if np.max(np.abs(eigenvalues)) >= 1.0 or np.linalg.cond(vectors) > 1e8:
        return none
    inverse = np.linalg.inv(vectors)
    cert = np.concatenate([inverse.real.reshape(-1), inverse.imag.reshape(-1), np.abs(vectors).reshape(-1)])
    return cert, RETIRE_FRACTION * task.settled_tol()


@njit(cache=True)
def modal_bound(cert, qpos, qvel, goal):
    """:math:`\\max_i \\sum_m |c_m| |v_{m,i}|` with :math:`c = V^{-1} x`, x the error from the goal: a bound on every
    future :math:`|x_i|` of the sampled linear loop."""
    n = qpos.size
    size = 2 * n
    x = np.empty(size)
    for i in range(n):
        x[i] = wrap(qpos[i] - goal[i])
        x[n + i] = qvel[i]
    square = size * size
    amplitude = np.empty(size)
    for m in range(size):
        re, im = 0.0, 0.0
        for j in range(size):
            re += cert[size * m + j] * x[j]
            im += cert[square + size * m + j] * x[j]
        amplitude[m] = math.sqrt(re * re + im * im)
    bound = 0.0
    for i in range(size):
        total = 0.0
        for m in range(size):
            total += amplitude[m] * cert[2 * square + size * i + m]
        bound = max(bound, total)
    return bound


class SamplingWarning(UserWarning):
    """A controller's balance gain is unstable when held over the simulation's time step; the run goes on.
    ``detail``: which robot, goal and step, and the spectral radius, in words (a summary of many quotes it)."""

    def __init__(self, message, detail=""):
        super().__init__(message)
        self.detail = detail


_WARNED: set = set()


def sampling_advice(balance: dict) -> str:
    """What to do about a balance unstable when sampled (:func:`~paa_mj.theory.linear.sampled_balance`), briefly."""
    if balance["stable_dt"] is None:
        return "at no time step down to 1/256 of this one: weigh the torques more (--lqr-weights Q R)"
    return (f"stable from dt = {balance['stable_dt'] * 1e3:g} ms: a step that short (the model's timestep, or"
            " simulate's --dt) or --lqr-weights Q R")


def warn_unstable_sampling(pairs, dt, task, robot_name="the robot"):
    """A :class:`SamplingWarning` for each (plant, controller) of ``pairs`` (the plant's analytic model) whose
    balance gain is unstable when held over ``dt`` [s] on that plant, once per plant, goal, step and gain: such a
    run cannot balance, whatever its swing-up does."""
    for plant, controller in pairs:
        K = balance_gain_of(controller)
        if K is None:
            continue
        key = (plant.key(), task.name, float(dt), np.asarray(K, float).tobytes())
        if key in _WARNED:
            continue
        _WARNED.add(key)
        balance = sampled_balance(plant, K, dt, task)
        if balance["radius"] >= 1.0:
            detail = (f"{robot_name} at the {task.name} goal is unstable when sampled at dt = {dt * 1e3:g} ms"
                      f" (spectral radius {balance['radius']:.6g} >= 1)")
            warnings.warn(SamplingWarning(f"the balance LQR (67) of {detail}, so no run of it can balance; it is"
                                          f" {sampling_advice(balance)}", detail), stacklevel=3)
