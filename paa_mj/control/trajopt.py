"""A kip by optimal control: direct collocation of (1) with CasADi and IPOPT.

The trajectory from (65) to UDD (8) is transcribed by Hermite-Simpson
collocation on N intervals: knot states x_k and torques u_k, midpoint states
and torques, and at each interval

.. math::

    x_m &= \\tfrac12 (x_k + x_{k+1}) + \\tfrac{h}{8} (f_k - f_{k+1}) \\\\
    x_{k+1} &= x_k + \\tfrac{h}{6} (f_k + 4 f_m + f_{k+1}), \\qquad h = T / N,

with f the right-hand side of (1) written by the same formulas as the rest of
the package (:mod:`paa_mj.model.equations`, evaluated on CasADi symbols), and
:math:`|\\tau_j| \\le` bound_j at every knot and midpoint. Two objectives:

- ``min-time``: minimise T (plus 1e-7 of the effort, which picks one of the
  many time-optimal torque profiles);
- ``min-effort``: minimise the integral of :math:`|\\tau|^2` dt (Simpson's rule) for a
  given duration T.

Solutions are cached on disk (``$PAA_MJ_CACHE`` or ``~/.cache/paa_mj``), keyed
by the robot, the bounds, the objective, the duration and the grid, so a
trajectory is solved once per machine.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import PaaError
from ..model import equations as eq
from ..model.dynamics import AnalyticModel
from ..progress import finish, progress
from ..provenance import cache_key, cache_root
from ..task import Task

OBJECTIVES = ("min-time", "min-effort")
#: Collocation intervals by default.
INTERVALS = 100
#: The longest kip planned [s].
MAX_DURATION = 120.0
#: CPU-seconds IPOPT may take for one kip by default (its ``max_cpu_time``): a chain of many links would otherwise
#: run on to its iteration cap, many minutes.
BUDGET_CPU_S = 600.0
#: Bounds on the time of a min-time kip [s].
TIME_RANGE = (0.2, 20.0)
CACHE_VERSION = 2  # 2: the time range bounds T itself (version 1 held T >= 1 s)


def dynamics_function(am: AnalyticModel):
    """(1) as a CasADi function f(x, u) -> x_dot, x = [q, qd], u the m motors' torques ([tau2, tau3] for the gymnast):
    the model's own formulas written for CasADi (:meth:`~paa_mj.model.dynamics.AnalyticModel.symbolic_acceleration`)."""
    ca = eq.casadi_module()
    n = am.n_links
    x, u = ca.SX.sym("x", 2 * n), ca.SX.sym("u", am.n_motors)
    return ca.Function("f", [x, u], [ca.vertcat(x[n:], am.symbolic_acceleration(ca, x, u))])


@dataclass(frozen=True)
class Kip:
    """A solved kip: knots, midpoints and torques of the Hermite-Simpson transcription.

    Attributes
    ----------
    duration : float
        T [s].
    x, u : ndarray (N + 1, 2n), (N + 1, m)
        States and torques at the knots t_k = k T / N.
    x_mid, u_mid : ndarray (N, 2n), (N, m)
        At the interval midpoints.
    objective : str
    cost : float
        The objective's value (T [s] or the integral of :math:`|\\tau|^2` [N^2 m^2 s]).
    bound : ndarray (m,)
        The torque bounds of the solve [N m].
    """

    duration: float
    x: np.ndarray
    u: np.ndarray
    x_mid: np.ndarray
    u_mid: np.ndarray
    objective: str
    cost: float
    bound: np.ndarray

    @property
    def intervals(self) -> int:
        return len(self.x_mid)

    @property
    def knot_times(self):
        return np.linspace(0.0, self.duration, self.intervals + 1)

    def effort(self) -> float:
        """The integral of :math:`|\\tau|^2` dt by Simpson's rule [N^2 m^2 s]."""
        h = self.duration / self.intervals
        sq = np.sum(self.u**2, axis=1)
        return float(np.sum(h / 6 * (sq[:-1] + 4 * np.sum(self.u_mid**2, axis=1) + sq[1:])))

    def sample(self, times, am: AnalyticModel):
        """The reference (x, u) at ``times`` [s], by the interpolants of the transcription.

        States: cubic Hermite on each interval (from the knots and (1) there); torques:
        the quadratic through the knots and the midpoint. Clamped to [0, T].
        """
        times = np.clip(np.asarray(times, float), 0.0, self.duration)
        h = self.duration / self.intervals
        k = np.minimum((times / h).astype(int), self.intervals - 1)
        s = (times - k * h) / h
        f = am.state_derivative(self.x, self.u)
        h00, h10, h01, h11 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2
        x = (h00[:, None] * self.x[k] + h10[:, None] * h * f[k] + h01[:, None] * self.x[k + 1]
             + h11[:, None] * h * f[k + 1])
        u = (2 * (s - 0.5) * (s - 1))[:, None] * self.u[k] + (-4 * s * (s - 1))[:, None] * self.u_mid[k] \
            + (2 * s * (s - 0.5))[:, None] * self.u[k + 1]
        return x, u

    def defects(self, am: AnalyticModel) -> float:
        """The largest violation of the collocation equations, evaluated with NumPy's (1) [rad, rad/s]."""
        h = self.duration / self.intervals
        f = am.state_derivative
        fk, fk1, fm = f(self.x[:-1], self.u[:-1]), f(self.x[1:], self.u[1:]), f(self.x_mid, self.u_mid)
        d_mid = self.x_mid - (0.5 * (self.x[:-1] + self.x[1:]) + h / 8 * (fk - fk1))
        d_step = self.x[1:] - (self.x[:-1] + h / 6 * (fk + 4 * fm + fk1))
        return float(max(np.max(np.abs(d_mid)), np.max(np.abs(d_step))))

    def plan(self) -> dict:
        """What was planned, as JSON: objective, duration T [s], torque bounds [N m], intervals N and cost."""
        return {"objective": self.objective, "duration": float(self.duration), "torque_bounds": self.bound.tolist(),
                "intervals": self.intervals, "cost": float(self.cost)}

    def arrays(self) -> dict:
        return {"duration": self.duration, "x": self.x, "u": self.u, "x_mid": self.x_mid, "u_mid": self.u_mid,
                "objective": self.objective, "cost": self.cost, "bound": self.bound}


def cache_dir() -> Path:
    return cache_root() / "trajopt"


def _key(am, bound, objective, duration, intervals, x0, xN, start=None):
    # a solve started from a kip is another problem to the cache: IPOPT may find another local optimum from there
    return cache_key(v=CACHE_VERSION, robot=am.key(), bound=np.asarray(bound), objective=objective, duration=duration,
                     intervals=intervals, x0=np.asarray(x0), xN=np.asarray(xN),
                     **({} if start is None else {"start": start.arrays()}))


def solve_kip(am: AnalyticModel, bound, objective="min-time", duration=None, intervals=INTERVALS, x0=None,
              xN=None, use_cache=True, max_iter=3000, task: Task | None = None, start: Kip | None = None,
              budget_cpu_s: float = BUDGET_CPU_S) -> Kip:
    """Solve (or load from the cache) the kip from ``x0`` to ``xN`` (default: from the task's start to its goal at
    rest; for the gymnast's folded task from (65) to UDD).

    Parameters
    ----------
    am : AnalyticModel
    bound : float or (m,)
        Torque bounds [N m], > 0.
    objective : "min-time" or "min-effort"
    duration : float
        T [s] of a min-effort kip (required there); the initial guess of a min-time one.
    intervals : int
        Collocation intervals N.
    task : Task, optional
        The default start and end (its start, its goal at rest); default the folded task.
    start : Kip, optional
        A solved kip of a neighbouring problem (the same intervals and links: the robot the model of a believing
        controller is a perturbation of) that IPOPT starts from instead of the straight line from ``x0`` to
        ``xN``: a few times fewer iterations, and the local optimum nearest that plan. Without it, or of
        another shape, the straight line.
    budget_cpu_s : float
        CPU-seconds IPOPT may take (its ``max_cpu_time``); a solve that spends them is refused in one line that
        names the budget. A kip kept in the cache costs none.

    Raises
    ------
    PaaError
        Bad input, or IPOPT did not converge (one line with IPOPT's status and what to try).
    """
    from ..io import write_npz

    if not isinstance(am, AnalyticModel):
        raise PaaError(f"solve_kip needs the robot's AnalyticModel (robot.analytic), got {type(am).__name__}")
    if objective not in OBJECTIVES:
        raise PaaError(f"unknown objective {objective!r}: use {' or '.join(OBJECTIVES)}")
    links = am.n_links
    bound = _real(bound, "torque bounds of the kip")
    if bound.shape not in ((), (1,), (links - 1,)):
        raise PaaError(f"torque bounds of the kip are one number or {'two (T2, T3)' if links == 3 else links - 1}"
                       f" [N m], got shape {bound.shape}")
    bound = np.broadcast_to(bound, (links - 1,)).copy()
    if duration is not None:
        duration = float(_real(duration, "the kip duration").reshape(-1)[0]) if np.size(duration) == 1 else None
        if duration is None:
            raise PaaError("the kip duration is one number [s]")
    if not (isinstance(max_iter, (int, np.integer)) and not isinstance(max_iter, bool) and max_iter >= 0):
        raise PaaError(f"max_iter must be a whole number >= 0 (IPOPT's iterations), got {max_iter!r}")
    budget_cpu_s = float(_real(budget_cpu_s, "the kip's budget").reshape(-1)[0]) if np.size(budget_cpu_s) == 1 \
        else np.nan
    if not (np.isfinite(budget_cpu_s) and budget_cpu_s > 0):
        raise PaaError("the kip's budget is one number of CPU-seconds > 0")
    if not np.all(np.isfinite(bound) & (bound > 0)):
        raise PaaError(f"torque bounds of the kip must be finite and > 0, got {bound.tolist()}")
    if objective == "min-effort" and not (duration is not None and np.isfinite(duration) and duration > 0):
        raise PaaError("a min-effort kip needs a duration > 0 [s]")
    if duration is not None and not (np.isfinite(duration) and 0 < duration <= MAX_DURATION):
        raise PaaError(f"a kip duration must be in (0, {MAX_DURATION:g}] s (the paper's kip takes about 20 s, an"
                       f" optimised one 2 to 3 s), got {duration:g}; longer plans would need their TVLQR's Riccati"
                       " solution stored over the whole duration")
    if not (isinstance(intervals, (int, np.integer)) and 4 <= intervals <= 2000):
        raise PaaError(f"collocation intervals must be an integer in [4, 2000], got {intervals}")
    task = Task.named("folded", am) if task is None else task
    x0 = np.array(task.start) if x0 is None else _real(x0, "the kip's initial state x0")
    xN = np.concatenate([task.goal, np.zeros(links)]) if xN is None else \
        _real(xN, "the kip's final state xN")
    for name, state in (("x0", x0), ("xN", xN)):
        if state.shape != (2 * links,) or not np.all(np.isfinite(state)):
            raise PaaError(f"the kip's {name} must be {2 * links} finite numbers (q and qd), got shape {state.shape}"
                           + ("" if state.shape != (2 * links,) else f" {state.tolist()}"))
    if start is not None and (start.intervals != intervals or start.x.shape[1] != 2 * links):
        start = None
    key = _key(am, bound, objective, duration, intervals, x0, xN, start)
    path = cache_dir() / f"{key}.npz"
    if use_cache and path.is_file():
        kept = _load_kept(path, am, bound, objective, duration, intervals, x0, xN)
        if kept is not None:
            return kept
    kip = _solve(am, bound, objective, duration, intervals, x0, xN, max_iter, start, budget_cpu_s)
    if use_cache:
        try:
            write_npz(path, **kip.arrays())
        except PaaError:
            pass  # an unwritable cache costs a solve next time, nothing else
    return kip


def _load_kept(path, am, bound, objective, duration, intervals, x0, xN):
    """A cached kip, if it is the one asked for: shapes, settings and end points as asked, and (1) met at its
    collocation points; None otherwise (a damaged or foreign entry is solved again)."""
    try:
        with np.load(path, allow_pickle=False) as z:
            kip = Kip(float(z["duration"]), np.array(z["x"]), np.array(z["u"]), np.array(z["x_mid"]),
                      np.array(z["u_mid"]), str(z["objective"]), float(z["cost"]), np.array(z["bound"]))
    except Exception:
        return None
    n, nx, nu = intervals, 2 * am.n_links, am.n_motors
    shapes_fit = (kip.x.shape, kip.u.shape, kip.x_mid.shape, kip.u_mid.shape) == ((n + 1, nx), (n + 1, nu), (n, nx),
                                                                                    (n, nu))
    if not (shapes_fit and kip.objective == objective and np.array_equal(kip.bound, bound)
            and (objective == "min-time" or kip.duration == duration)):
        return None
    if not (np.allclose(kip.x[0], x0, atol=1e-6) and np.allclose(kip.x[-1], xN, atol=1e-6)
            and np.all(np.abs(kip.u) <= bound * (1 + 1e-6) + 1e-9) and kip.defects(am) < 1e-5):
        return None
    return kip


def _real(value, what) -> np.ndarray:
    """``value`` as a float array, or a one-line error when it is not real numbers."""
    try:
        array = np.asarray(value)
        if array.dtype.kind not in "fiu":
            raise TypeError
        return array.astype(float)
    except (TypeError, ValueError):
        raise PaaError(f"{what} must be real numbers, got {value!r}") from None


def _check_interior(duration, bound):
    """A minimum time at a bound of :data:`TIME_RANGE` is that bound's, not the robot's: refuse it."""
    low, high = TIME_RANGE
    if duration <= low * (1 + 1e-6):
        raise PaaError(f"the min-time kip reached the shortest time allowed ({low:g} s) with torque bounds"
                       f" {bound.round(3).tolist()} N m: the plan is limited by that bound, not by the robot")
    if duration >= high * (1 - 1e-6):
        raise PaaError(f"no kip within {high:g} s under torque bounds {bound.round(3).tolist()} N m: give higher"
                       " bounds")


def _solve(am, bound, objective, duration, intervals, x0, xN, max_iter, start=None, budget_cpu_s=BUDGET_CPU_S) -> Kip:
    ca = eq.casadi_module()
    f = dynamics_function(am)
    N = intervals
    opti = ca.Opti()
    nx, nu = 2 * am.n_links, am.n_motors
    X, Xm = opti.variable(nx, N + 1), opti.variable(nx, N)
    U, Um = opti.variable(nu, N + 1), opti.variable(nu, N)
    T = opti.variable() if objective == "min-time" else float(duration)
    h = T / N
    effort = 0
    for k in range(N):
        fk, fk1, fm = f(X[:, k], U[:, k]), f(X[:, k + 1], U[:, k + 1]), f(Xm[:, k], Um[:, k])
        opti.subject_to(Xm[:, k] == 0.5 * (X[:, k] + X[:, k + 1]) + h / 8 * (fk - fk1))
        opti.subject_to(X[:, k + 1] == X[:, k] + h / 6 * (fk + 4 * fm + fk1))
        effort += h / 6 * (ca.sumsqr(U[:, k]) + 4 * ca.sumsqr(Um[:, k]) + ca.sumsqr(U[:, k + 1]))
    opti.subject_to(X[:, 0] == x0)
    opti.subject_to(X[:, N] == xN)
    for j in range(nu):
        opti.subject_to(opti.bounded(-bound[j], U[j, :], bound[j]))
        opti.subject_to(opti.bounded(-bound[j], Um[j, :], bound[j]))
    if objective == "min-time":
        # Opti.bounded(lower, expr, upper): the expression in the middle (a bound written
        # bounded(*TIME_RANGE, T) constrains T >= (0.2 <= 20.0) = 1 instead).
        opti.subject_to(opti.bounded(TIME_RANGE[0], T, TIME_RANGE[1]))
        opti.set_initial(T, float(np.clip(duration or 3.0, *TIME_RANGE)))
        opti.minimize(T + 1e-7 * effort)
    else:
        opti.minimize(effort)
    if start is None:
        s = np.linspace(0.0, 1.0, N + 1)
        guess = x0[:, None] + (xN - x0)[:, None] * s
        opti.set_initial(X, guess)
        opti.set_initial(Xm, 0.5 * (guess[:, :-1] + guess[:, 1:]))
    else:
        for variable, values in ((X, start.x), (Xm, start.x_mid), (U, start.u), (Um, start.u_mid)):
            opti.set_initial(variable, values.T)
        if objective == "min-time":
            opti.set_initial(T, float(np.clip(start.duration, *TIME_RANGE)))
    opti.solver("ipopt", {"print_time": False}, {"print_level": 0, "sb": "yes", "max_iter": max_iter, "tol": 1e-9,
                                                  "max_cpu_time": budget_cpu_s})
    # a solve of a long chain takes minutes: its iterations are its progress, out of at most max_iter; a solve that
    # converges sooner finishes its bar at the iterations it took
    bar = progress(desc=f"planning the {objective} kip (IPOPT, {am.n_links} links, at most {max_iter} iterations"
                        f" and {budget_cpu_s:g} CPU-s)",
                   unit="iteration", total=max_iter)
    opti.callback(lambda _: bar.update(1))
    try:
        sol = opti.solve()
        finish(bar)
    except RuntimeError:
        status = opti.debug.stats().get("return_status", "failed")
        if status == "NonIpopt_Exception_Thrown":  # this NLP has no Python callbacks: only Ctrl-C/SIGTERM throws
            raise KeyboardInterrupt from None
        if status == "Maximum_CpuTime_Exceeded":
            raise PaaError(f"the {objective} kip was not found within its budget of {budget_cpu_s:g} CPU-s (IPOPT's"
                           " max_cpu_time): give it more (--plan-budget, or the controller's option budget) or fewer"
                           " collocation intervals") from None
        raise PaaError(f"the {objective} kip did not converge (IPOPT: {status}) with torque bounds"
                       f" {bound.round(3).tolist()} N m" + (f" and duration {duration:g} s" if objective == "min-effort"
                                                             else "") + "; try higher bounds, a longer duration or"
                       " more intervals") from None
    finally:
        bar.close()
    duration_found = float(sol.value(T)) if objective == "min-time" else float(duration)
    if objective == "min-time":
        _check_interior(duration_found, bound)
    def values(variable, rows):  # CasADi returns a vector, not a matrix, for a single row
        return np.array(sol.value(variable)).reshape(rows, -1).T

    return Kip(duration_found, values(X, nx), values(U, nu), values(Xm, nx), values(Um, nu), objective, float(sol.value(T if objective == "min-time" else effort)),
               bound)
