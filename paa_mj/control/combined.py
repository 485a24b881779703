"""Switching between two controllers: a swing-up, a balance controller, and the condition between them.

A :class:`CombinedController` runs ``first`` until ``condition`` first holds,
then ``second`` for good (one-way, as the paper's switch (68)); each element of
a batch switches on its own. Conditions are small objects with a NumPy test
(``holds``), a continuous ``margin`` that is negative exactly where they hold
(the analytic engine finds the switch as an ODE event) and a compiled form:

- :class:`RegionCondition`: the state is inside region (68);
- :class:`LevelCondition`: the LQR's cost-to-go x^T S x is below a level rho, the inner estimate of its region of
  attraction (:mod:`paa_mj.theory.roa`), as Spong's controller in Drake switches;
- :class:`TimeCondition`: t >= a given time (the end of a stored trajectory).

When both controllers and the condition are compiled, so is the combination
(:class:`~paa_mj.control.base.SwitchedForm`): the engine calls the two kernels
and the condition through function pointers, compiled once for all.
"""
from __future__ import annotations

import numpy as np

from ..errors import PaaError
from ..task import Task
from .base import CompiledForm, Controller, SwitchedForm, kernel, reset_controller, torque_of
from .lqr import LQRController, lqr_weights as weights_of
from .region import level_condition, reading_condition, reading_margin, region_condition

SWING_UP, BALANCE = 0, 1


class RegionCondition:
    """The paper's switching rule: the state is inside the task's region (68) around its goal.

    Parameters
    ----------
    task : Task
    """

    name = "region (68)"

    def __init__(self, task: Task):
        self.task = task

    def holds(self, q, qd, t):
        return self.task.in_switch_region(q, qd)

    def margin(self, q, qd, t):
        return self.task.switch_margin(q, qd)

    def compiled(self):
        return region_condition, self.task.params


class ReadingCondition:
    """A candidate reading of the paper's switching code (:func:`~paa_mj.control.region.reading_margin`).

    Not the paper's text: the report computes where it would switch, as a candidate explanation of
    the paper's switch time.
    """

    name = "candidate reading of (68)"

    def holds(self, q, qd, t):
        return self.margin(q, qd, t) < 0

    def margin(self, q, qd, t):
        q, qd = np.asarray(q, float), np.asarray(qd, float)
        return reading_margin(q[..., 0], q[..., 1], q[..., 2], qd[..., 0], qd[..., 1], qd[..., 2])

    def compiled(self):
        return reading_condition, np.zeros(0)


class LevelCondition:
    """Switch where the LQR (67)'s cost-to-go :math:`x^T S x < \\rho` (x the error from the task's goal): the
    set of :func:`paa_mj.theory.roa.region_of_attraction`, instead of region (68).

    Parameters
    ----------
    task : Task
    S : ndarray (2n, 2n)
    rho : float
    """

    name = "cost-to-go level (region of attraction)"

    def __init__(self, task: Task, S, rho):
        self.task, self.S, self.rho = task, np.asarray(S, float), float(rho)
        self.params = np.concatenate([task.goal, self.S.reshape(-1), [self.rho]])

    def margin(self, q, qd, t):
        x = self.task.error(q, qd)
        return np.einsum("...i,ij,...j->...", x, self.S, x) - self.rho

    def holds(self, q, qd, t):
        return self.margin(q, qd, t) < 0

    def compiled(self):
        return level_condition, self.params


@kernel
def time_condition(x, t, params, memory, tau):
    """Compiled condition: 1 once t >= params[0]."""
    return 1 if t >= params[0] else 0


class TimeCondition:
    """t >= ``t_switch`` [s]: hand over when a stored trajectory ends."""

    name = "time"

    def __init__(self, t_switch):
        self.t_switch = float(t_switch)

    def holds(self, q, qd, t):
        return np.broadcast_to(np.asarray(t) >= self.t_switch, np.shape(q)[:-1])

    def margin(self, q, qd, t):
        return self.t_switch - t

    def compiled(self):
        return time_condition, np.array([self.t_switch])


class CombinedController(Controller):
    """``first`` until ``condition`` first holds, then ``second`` for good.

    Parameters
    ----------
    first, second : controllers
        The swing-up and the balance controller (any objects with ``torque``).
    condition : RegionCondition, TimeCondition or an object with ``holds(q, qd, t)``
    name : str

    Attributes
    ----------
    mode : int8 or ndarray of int8
        0 while ``first`` acts, 1 once ``second`` has taken over (per batch element).
    """

    def __init__(self, first, second, condition, name="combined"):
        self.first, self.second, self.condition, self.name = first, second, condition, name
        self.mode = np.int8(SWING_UP)
        self.binding = getattr(first, "binding", None)

    def reset(self):
        self.mode = np.int8(SWING_UP)
        reset_controller(self.first)
        reset_controller(self.second)

    def update_mode(self, q, qd, t):
        """Apply the switching rule and return the mode(s)."""
        holds = np.asarray(self.condition.holds(q, qd, t))
        self.mode = np.where(holds, np.int8(BALANCE), self.mode).astype(np.int8)
        return self.mode

    def law(self, q, qd, t):
        mode = self.update_mode(q, qd, t)
        if np.all(mode == BALANCE):
            return torque_of(self.second, q, qd, t)
        if np.all(mode == SWING_UP):
            return torque_of(self.first, q, qd, t)
        return np.where(mode[..., None] == BALANCE, torque_of(self.second, q, qd, t), torque_of(self.first, q, qd, t))

    def compiled(self) -> SwitchedForm | None:
        """Compiled when both controllers are compiled, without switches of their own, and so is the condition."""
        first, second = (getattr(part, "compiled", lambda: None)() for part in (self.first, self.second))
        condition = getattr(self.condition, "compiled", lambda: None)()
        if not (isinstance(first, CompiledForm) and isinstance(second, CompiledForm)) or condition is None:
            return None
        return SwitchedForm(first, second, *condition)

    def describe(self) -> dict:
        out = {"controller": self.name}
        for part in (self.first, self.second):
            details = part.describe() if hasattr(part, "describe") else {}
            out.update({k: v for k, v in details.items() if k != "controller"})
        out["switch"] = getattr(self.condition, "name", type(self.condition).__name__)
        if isinstance(self.condition, LevelCondition):
            out["switch_level"] = self.condition.rho
        return out


#: Where a switched controller hands over to (67) (option ``switch``): region (68), or the inner estimate
#: x^T S x <= rho of the LQR's region of attraction with the robot's torque limits (:mod:`paa_mj.theory.roa`).
SWITCHES = ("region", "roa")


def hand_over(robot, task: Task, lqr_weights=None, switch=None, limit=None):
    """The condition on which a swing-up hands over to the LQR (67) on ``robot`` (a
    :class:`~paa_mj.model.robot.Robot`): region (68) of ``task`` (``switch`` None or ``"region"``), or the LQR's
    region of attraction with the torque limits the run applies (``switch="roa"``, ``limit`` capping the model's)."""
    if switch in (None, "region"):
        if limit is not None:
            raise PaaError("the option limit applies to the hand-over on the LQR's region of attraction (switch="
                           "\"roa\"), not to region (68)")
        return RegionCondition(task)
    if switch != "roa":
        raise PaaError(f"the option switch is one of {', '.join(SWITCHES)}, got {switch!r}")
    from ..theory.linear import lqr_weight_matrices
    from ..theory.roa import switch_level

    n, motors = robot.params.n_links, robot.params.n_motors
    Q, R = lqr_weight_matrices(n, *weights_of(n, lqr_weights, motors), n_motors=motors)
    S, rho = switch_level(robot.analytic, task, Q, R, u_max=robot.capped_torque_limits(limit, "the option limit"),
                          dt=float(robot.model.opt.timestep))
    return LevelCondition(task, S, rho)


def switched(robot, task: Task, swing, name, lqr_weights=None, switch=None, limit=None):
    """``swing`` until region (68) of the task (or the LQR's region of attraction with the torque limits the run
    applies, ``switch="roa"``, ``limit`` capping the model's), then the LQR (67) at its goal (weights
    ``lqr_weights``) on ``robot``."""
    return CombinedController(swing, LQRController.for_model(robot.analytic, task, lqr_weights),
                              hand_over(robot, task, lqr_weights, switch, limit), name=name)
