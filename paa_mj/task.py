"""The task: where a run starts, the goal it aims at, and what counts as reaching it.

A :class:`Task` is one frozen object that every layer of the package is handed (controllers, engines,
environments, studies, outputs), made in one place from a goal's name and a robot
(:meth:`Task.named`); nothing else turns a goal's name into angles (:func:`goal_angles`).

Goals of a chain of n links (relative angles, q1 from the upward vertical):

- ``folded``: the paper's up-down-down equilibrium (8), q* = (0, -pi, 0, ..., 0): link 1 up, the others
  hanging down (for two links the up-down point of Lemma 1);
- ``stretched``: every link up, q* = 0 (the classic acrobot swing-up).

With x = [wrap(q - q*), qd] the error from the goal (angles wrapped to (-pi, pi]):

- the *switch region* (68): every :math:`|x_i| <` pi/6 rad and every :math:`|x_{n+i}| <` 0.5 rad/s; the
  paper's controller hands over from (40) to the LQR (67) the first time the state is inside;
- *success*: no divergence, and the true state inside the *success region* (by default the same box)
  at every physics step of the last ``success_window`` seconds of the run (1 s), or the run stopped early
  as balanced for good;
- *balanced*: the final state within ``balance_tol`` (1e-3 rad, rad/s) of the goal in every coordinate.

Runs start from ``start``: hanging at rest, (65) for the gymnast (the stretched goal's start has link 1
0.1 rad off straight down, since hanging at rest is an equilibrium of (40) aiming there), and last
``horizon`` seconds unless told otherwise.

Compiled code reads a task as :attr:`Task.params` (:data:`PARAMS`), through :func:`state_terms`, and keeps
the bookkeeping of success in a *book* of three steps (:data:`BOOK`), updated by :func:`book_update` and
judged by :func:`book_succeeded`: the MuJoCo engine, the analytic engine and both Gymnasium environments call
these, so that success means one thing everywhere.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from numba import njit
from numba.extending import register_jitable

from .errors import PaaError
from .model.params import MAX_LINKS
from .model.states import wrap

#: The goals of the family: the paper's folded posture and the fully stretched one.
GOALS = ("folded", "stretched")
#: Region (68): each angle error within pi/6 [rad] and each speed within 0.5 [rad/s].
SWITCH_ANGLE = math.pi / 6
SWITCH_SPEED = 0.5
#: A final state within this distance of the goal (each coordinate, rad and rad/s) counts as balanced.
BALANCE_TOL = 1e-3
#: The last seconds of a run over which a success must stay inside the success region [s].
SUCCESS_WINDOW = 1.0
#: How long a run lasts unless told otherwise [s].
HORIZON = 30.0
#: The stretched goal's runs start with link 1 this far from straight down [rad]: hanging at rest is an
#: equilibrium of (40) aiming at the stretched goal (e = 0, qd = 0, G = 0), so a swing-up from there never starts.
STRETCHED_START_OFFSET = 0.1

#: Layout of :attr:`Task.params`: the switch region's half-widths [rad, rad/s], the success region's, the
#: balance tolerance, then the goal angles q* (n) [rad].
PARAMS = ("switch_angle", "switch_speed", "success_angle", "success_speed", "balance_tol")
P_SWITCH_ANGLE, P_SWITCH_SPEED, P_SUCCESS_ANGLE, P_SUCCESS_SPEED, P_BALANCE_TOL = range(len(PARAMS))
P_GOAL = len(PARAMS)
#: A book of success: the step of the first entry into the switch region, the last step outside the success
#: region and the last step farther than the balance tolerance from the goal (-1: never).
BOOK = ("entered", "last_exit", "last_far")
B_ENTERED, B_LAST_EXIT, B_LAST_FAR = range(len(BOOK))


def goal_angles(name: str, n_links: int) -> np.ndarray:
    """q* of the goal ``name`` for a chain of ``n_links`` links [rad] (module docstring): the one place a goal's
    name becomes angles."""
    if name not in GOALS:
        raise PaaError(f"unknown goal {name!r}: use one of {', '.join(GOALS)}")
    angles = np.zeros(n_links)
    if name == "folded":
        angles[1] = -np.pi
    return angles


def _start_state(name: str, n_links: int) -> np.ndarray:
    x = np.zeros(2 * n_links)
    x[0] = -np.pi
    if name == "stretched":
        x[0] += STRETCHED_START_OFFSET
    return x


def _links_of(robot) -> int:
    """The number of links of a Robot, an AnalyticModel, a RobotParams or a plain count."""
    for holder in (robot, getattr(robot, "params", None)):
        n = getattr(holder, "n_links", None)
        if isinstance(n, (int, np.integer)):
            return _chain_links(int(n))
    if isinstance(robot, (int, np.integer)) and not isinstance(robot, bool):
        return _chain_links(int(robot))
    raise PaaError(f"a task is made for a robot (or its number of links), got {type(robot).__name__}")


def _chain_links(n: int) -> int:
    if not 2 <= n <= MAX_LINKS:
        raise PaaError(f"a task is made for a chain of 2 to {MAX_LINKS} links, got {n} links")
    return n


@dataclass(frozen=True)
class Region:
    """A box around the goal in error coordinates: every :math:`|x_i| <` ``angle`` [rad], every speed
    :math:`|\\dot q_i| <` ``speed`` [rad/s]."""

    angle: float = SWITCH_ANGLE
    speed: float = SWITCH_SPEED

    def __post_init__(self):
        for name in ("angle", "speed"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)) or \
                    not (math.isfinite(value) and value > 0):
                raise PaaError(f"a region's {name} half-width must be a positive finite number, got {value!r}")
            object.__setattr__(self, name, float(value))

    def describe(self) -> str:
        return f"every angle error < {_angle_text(self.angle)} rad and every speed < {self.speed:g} rad/s"


def _angle_text(angle):
    return "pi/6" if angle == SWITCH_ANGLE else f"{angle:g}"


@dataclass(frozen=True, eq=False)
class Task:
    """What a run aims at and how it is judged (module docstring); made by :meth:`named`.

    Attributes
    ----------
    name : {"folded", "stretched"}
        The goal's name.
    n_links : int
        The robot's links n.
    start : ndarray (2n,)
        Where runs start unless told otherwise, [q, qd] [rad, rad/s].
    switch_region : Region
        Region (68) around the goal.
    success_region : Region
        Where a success must stay over the last ``success_window`` seconds.
    success_window : float
        [s].
    balance_tol : float
        A final state this close to the goal in every coordinate is *balanced* [rad, rad/s].
    horizon : float
        How long a run lasts unless told otherwise [s].
    goal : ndarray (n,)
        q* [rad], from :func:`goal_angles`.
    """

    name: str
    n_links: int
    start: np.ndarray | None = None
    switch_region: Region = Region()
    success_region: Region = Region()
    success_window: float = SUCCESS_WINDOW
    balance_tol: float = BALANCE_TOL
    horizon: float = HORIZON
    goal: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        if not isinstance(self.name, str) or self.name not in GOALS:
            raise PaaError(f"unknown goal {self.name!r}: use one of {', '.join(GOALS)}")
        n = _links_of(self.n_links)
        object.__setattr__(self, "n_links", n)
        object.__setattr__(self, "goal", goal_angles(self.name, n))
        self.goal.setflags(write=False)
        start = _start_state(self.name, n) if self.start is None else np.array(self.start, dtype=float).reshape(-1)
        if start.shape != (2 * n,) or not np.all(np.isfinite(start)):
            raise PaaError(f"a task's start needs {2 * n} finite numbers (q1..q{n}, d1..d{n}), got {start.tolist()}")
        start.setflags(write=False)
        object.__setattr__(self, "start", start)
        for name in ("switch_region", "success_region"):
            if not isinstance(getattr(self, name), Region):
                raise PaaError(f"a task's {name} must be a Region, got {type(getattr(self, name)).__name__}")
        for name in ("success_window", "balance_tol", "horizon"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)) or \
                    not (math.isfinite(value) and value > 0):
                raise PaaError(f"a task's {name} must be a positive finite number, got {value!r}")
            object.__setattr__(self, name, float(value))

    @classmethod
    def named(cls, name: str, robot, **changes) -> "Task":
        """The task of the goal ``name`` for ``robot`` (a Robot, AnalyticModel, RobotParams or number of links),
        with the package's defaults, or ``changes`` to them (``start``, ``horizon``, ...)."""
        return cls(name, _links_of(robot), **changes)

    def with_(self, **changes) -> "Task":
        """This task with some fields changed (``start``, ``horizon``, regions, tolerances)."""
        return replace(self, **changes)

    # --- identity ---------------------------------------------------------------------------------------

    def aim(self) -> tuple:
        """What a controller is built for: the goal and the region where it hands over (68). Tasks that differ
        only in their start, horizon or how success is judged have the same aim."""
        return self.name, self.n_links, self.switch_region.angle, self.switch_region.speed

    def key(self) -> tuple:
        """Every field, as one hashable tuple."""
        return self.aim() + (tuple(self.start.tolist()), self.success_region.angle, self.success_region.speed,
                             self.success_window, self.balance_tol, self.horizon)

    def __eq__(self, other):
        return isinstance(other, Task) and self.key() == other.key()

    def __hash__(self):
        return hash(self.key())

    def __repr__(self):
        return f"Task({self.name!r}, n_links={self.n_links})" if self == Task(self.name, self.n_links) else \
            f"Task({self.name!r}, n_links={self.n_links}, {self.describe()['task']})"

    # --- what a summary says ----------------------------------------------------------------------------

    @property
    def success_definition(self) -> str:
        """What success means, in words."""
        region = self.success_region
        where = "region (68) around the goal" if region == self.switch_region else "the success region"
        return (f"balanced at the goal at the end: no divergence, and the true state (whatever the controller"
                f" reports or measures) inside {where} ({self._goal_words()}), {region.describe()},"
                f" throughout the last {self.success_window:g} s of the run, or all of it when shorter (or stopped early"
                f" as balanced for good)")

    def _goal_words(self):
        if self.name == "folded":
            return "UDD for the paper's gymnast" if self.n_links == 3 else "link 1 up, the others down"
        return "every link up"

    def describe(self) -> dict:
        """The task as every summary states it: its goal, the definition of success, and the whole task."""
        return {"goal": self.name, "success_definition": self.success_definition,
                "task": {"goal": self.name, "goal_angles": self.goal.tolist(), "start": self.start.tolist(),
                         "switch_region": {"angle": self.switch_region.angle, "speed": self.switch_region.speed},
                         "success_region": {"angle": self.success_region.angle,
                                            "speed": self.success_region.speed},
                         "success_window": self.success_window, "balance_tol": self.balance_tol,
                         "horizon": self.horizon}}

    @classmethod
    def from_description(cls, described, n_links) -> "Task":
        """The task a summary's ``task`` entry (:meth:`describe`) states; a goal's name alone gives its defaults."""
        if isinstance(described, str) or described is None:
            return cls.named(described or "folded", n_links)
        try:
            return cls(described["goal"], n_links, start=described["start"],
                       switch_region=Region(**described["switch_region"]),
                       success_region=Region(**described["success_region"]),
                       success_window=described["success_window"], balance_tol=described["balance_tol"],
                       horizon=described["horizon"])
        except (KeyError, TypeError) as err:
            raise PaaError(f"not a task's description: {type(err).__name__}: {err}") from None

    # --- the error from the goal, in NumPy --------------------------------------------------------------

    @property
    def params(self) -> np.ndarray:
        """The task for compiled code (:data:`PARAMS`, then q*)."""
        return np.concatenate([[self.switch_region.angle, self.switch_region.speed, self.success_region.angle,
                                self.success_region.speed, self.balance_tol], self.goal])

    def check_width(self, q, what="states"):
        """``q``'s last axis is the task's n angles, or a one-line error."""
        width = np.shape(q)[-1] if np.ndim(q) else None
        if width != self.n_links:
            raise PaaError(f"{what} of {width} angles given to the {self.name} task of a {self.n_links}-link robot")

    def error(self, q, qd):
        """x = [wrap(q - q*), qd], shape (..., 2n): (67)'s x for the gymnast's folded goal."""
        q, qd = np.asarray(q, float), np.asarray(qd, float)
        self.check_width(q)
        angles = wrap(q - self.goal)
        return np.concatenate(np.broadcast_arrays(angles, qd), axis=-1)

    def _margin(self, q, qd, region: Region):
        x = self.error(q, qd)
        n = self.n_links
        return np.maximum(np.max(np.abs(x[..., :n]), axis=-1) / region.angle,
                          np.max(np.abs(x[..., n:]), axis=-1) / region.speed) - 1.0

    def switch_margin(self, q, qd):
        """A continuous function that is negative exactly inside region (68) (an ODE event)."""
        return self._margin(q, qd, self.switch_region)

    def _inside(self, q, qd, region: Region):
        x = self.error(q, qd)
        n = self.n_links
        return np.all(np.abs(x[..., :n]) < region.angle, axis=-1) & np.all(np.abs(x[..., n:]) < region.speed,
                                                                            axis=-1)

    def in_switch_region(self, q, qd):
        """Inside region (68): shape (...,) of bool."""
        return self._inside(q, qd, self.switch_region)

    def in_success_region(self, q, qd):
        """Inside the success region: shape (...,) of bool."""
        return self._inside(q, qd, self.success_region)

    def distance(self, q, qd):
        """:math:`\\max_i |x_i|`, the largest error from the goal [rad, rad/s]; shape (...,)."""
        return np.max(np.abs(self.error(q, qd)), axis=-1)

    def balanced(self, q, qd):
        """Within ``balance_tol`` of the goal in every coordinate; shape (...,) of bool."""
        return self.distance(q, qd) < self.balance_tol

    def settled_tol(self) -> float:
        """The largest error [rad, rad/s] that, held in every coordinate, is both balanced and inside the success
        region: a run that provably stays below it is judged a success (its stopping early, retirement, uses it)."""
        return min(self.balance_tol, self.success_region.angle, self.success_region.speed)

    def goal_energy(self, model) -> float:
        """E_r = P(q*): the energy at rest at the goal [J] ((9) at the gymnast's UDD), for an AnalyticModel."""
        return float(model.potential(self.goal))

    def window_steps(self, dt: float) -> int:
        """The success window in steps of ``dt`` [s]."""
        return int(round(self.success_window / dt))

    def succeeded(self, books, end_step, finished, retired, dt):
        """Success (:attr:`success_definition`) of runs from their books (N, 3) (:func:`book_succeeded`).

        Parameters
        ----------
        books : ndarray (N, 3) of int
        end_step : ndarray (N,) of int
            The step at which each run ended (for one stopped early as balanced for good, would have ended).
        finished, retired : ndarray (N,) of bool
            Ran to its end without divergence; stopped early as balanced for good.
        dt : float
            The step of the books [s].
        """
        books = np.ascontiguousarray(np.atleast_2d(books), dtype=np.int64)
        n = len(books)
        out = np.empty(n, bool)
        _succeeded_rows(books, np.broadcast_to(np.asarray(end_step, np.int64), (n,)).copy(),
                        np.broadcast_to(np.asarray(finished, bool), (n,)).copy(),
                        np.broadcast_to(np.asarray(retired, bool), (n,)).copy(), self.window_steps(dt), out)
        return out


# --- compiled: the one definition of the regions and of success -------------------------------------------

@register_jitable
def state_terms(params, qpos, qvel):
    """The state's error x = [wrap(q - q*), qd] from the goal, as compiled code needs it.

    Returns (inside the switch region (68), inside the success region, the largest absolute angle error [rad],
    the largest absolute speed [rad/s], the sum of squared angle errors, the sum of squared speeds).
    """
    n = qpos.size
    inside_switch, inside_success = True, True
    angle_max, speed_max, angles, speeds = 0.0, 0.0, 0.0, 0.0
    for i in range(n):
        x, d = wrap(qpos[i] - params[P_GOAL + i]), qvel[i]
        inside_switch = inside_switch and abs(x) < params[P_SWITCH_ANGLE] and abs(d) < params[P_SWITCH_SPEED]
        inside_success = inside_success and abs(x) < params[P_SUCCESS_ANGLE] and abs(d) < params[P_SUCCESS_SPEED]
        angle_max, speed_max = max(angle_max, abs(x)), max(speed_max, abs(d))
        angles += x * x
        speeds += d * d
    return inside_switch, inside_success, angle_max, speed_max, angles, speeds


@register_jitable
def switch_margin_of(params, angle_max, speed_max):
    """max(angles / half-width, speeds / half-width) - 1 of region (68): negative exactly inside."""
    return max(angle_max / params[P_SWITCH_ANGLE], speed_max / params[P_SWITCH_SPEED]) - 1.0


def entered_times(books, dt):
    """The first entry into the switch region of each book (..., len(BOOK)) judged every ``dt`` [s], NaN if never."""
    entered = np.asarray(books)[..., B_ENTERED]
    return np.where(entered >= 0, entered * dt, np.nan)


@register_jitable
def book_start(book):
    """A fresh book: nothing seen yet."""
    for k in range(book.size):
        book[k] = -1


@register_jitable
def book_update(params, qpos, qvel, step, book):
    """Account for the true state at ``step`` in ``book`` (:data:`BOOK`); returns :func:`state_terms`."""
    terms = state_terms(params, qpos, qvel)
    inside_switch, inside_success, angle_max, speed_max = terms[0], terms[1], terms[2], terms[3]
    if book[B_ENTERED] < 0 and inside_switch:
        book[B_ENTERED] = step
    if not inside_success:
        book[B_LAST_EXIT] = step
    if max(angle_max, speed_max) >= params[P_BALANCE_TOL]:
        book[B_LAST_FAR] = step
    return terms


@register_jitable
def book_succeeded(book, end_step, finished, retired, window):
    """The one success test: ran to its end without divergence, or stopped early as balanced for good (inside the
    settled tolerance, :meth:`Task.settled_tol`, to its end), and stayed inside the success region over the last
    ``window`` steps (the whole run when shorter) of the run, which ends at ``end_step``: for a run stopped early,
    the step at which it would have ended."""
    return (finished or retired) and book[B_LAST_EXIT] < end_step - min(window, end_step)


@njit(cache=True)
def _succeeded_rows(books, end_step, finished, retired, window, out):
    for r in range(books.shape[0]):
        out[r] = book_succeeded(books[r], end_step[r], finished[r], retired[r], window)


@njit(cache=True)
def book_rows(params, q, qd, steps, book):
    """:func:`book_update` over states q, qd (K, n) at ``steps`` (K,), in order (the analytic engine's samples)."""
    for k in range(q.shape[0]):
        book_update(params, q[k], qd[k], steps[k], book)


def as_task(task, robot) -> Task:
    """``task`` for ``robot``: a :class:`Task` (checked against the robot's links), a goal's name
    (:meth:`Task.named`), or None for the paper's folded goal. The one conversion at the public entry points."""
    if task is None:
        task = "folded"
    if isinstance(task, str):
        return Task.named(task, robot)
    if not isinstance(task, Task):
        raise PaaError(f"a task is a paa_mj.task.Task or a goal's name ({', '.join(GOALS)}), got"
                       f" {type(task).__name__}")
    links = _links_of(robot)
    if task.n_links != links:
        raise PaaError(f"the {task.name} task is for a {task.n_links}-link robot, not for this one of {links} links")
    return task
