"""The exact closed loop: (1) integrated by SciPy's DOP853 (rtol 1e-10) with the torque evaluated continuously.

No zero-order hold and no time step: the reference against which MuJoCo's
discretisation is judged. The run is judged by its task as MuJoCo's runs are (the task's book of
success, :func:`~paa_mj.task.book_update`), on the dense solution at every step of the robot's MuJoCo time step. A switching controller switches where its
condition's margin first turns negative, watched on the integrator's dense
output every millisecond (a short visit of the region is not stepped over)
and located by bisection; integration then restarts under the second controller. Stateless
controllers run as they are; a controller with internal state that is not a
:class:`~paa_mj.control.combined.CombinedController` cannot be integrated this way.
"""
from __future__ import annotations

import math

import numpy as np
from numba import types
from tqdm import tqdm

from ...control.base import (KERNEL_TYPE, CompiledForm, KernelAddress, check_binding, controller_name, mode_of,
                            reset_controller, torque_of)
from ...control.combined import CombinedController
from ...errors import PaaError, SimulationDiverged
from ...jit import lazy_njit
from ...limits import check_memory, check_steps, positive_finite
from ...model.robot import Robot
from ...task import BOOK, Task, as_task, book_rows, entered_times
from ..batch import controllers_for
from ..inputs import check_initial_state, check_robot, sample_interval, steps_for
from .rk4 import acceleration_into, rk4_constants, work_size
from ..rollout import describe_controller, trajectory_quantities
from ..compiled.step import MAX_SPEED, NONFINITE_TORQUE, RUNAWAY, STATUS_TEXT
from ..trajectory import Trajectory, seconds_or_none


#: Smallest step of the adaptive integrator [s]; a smooth closed loop of this model takes steps of 1e-5 s or more.
MIN_STEP = 1e-10
#: Finest interval at which the switching condition may be watched [s].
MIN_EVENT_RESOLUTION = 1e-9


class _NonFiniteTorque(Exception):
    """The controller returned NaN or inf where the integration starts."""


_VECTOR = types.float64[::1]


@lazy_njit(types.boolean(KERNEL_TYPE, _VECTOR, types.float64, _VECTOR, _VECTOR, _VECTOR, _VECTOR, _VECTOR, _VECTOR),
      cache=True)
def closed_loop_field(kernel, x, t, params, memory, limits, constants, out, work):
    """f(t, x) = [qd, qdd(q, qd, tau(x, t))] of (1) closed by a compiled law into ``out`` (2n); returns whether the
    torques were finite (non-finite ones are applied as they are, clipped ones at ``limits`` [N m], one per motor,
    otherwise).

    The law is the kernel of a stateless controller (:class:`~paa_mj.control.base.CompiledForm`), called with a
    fresh copy of its initial ``memory`` at every evaluation, as its ``torque`` would be; the accelerations are
    those of :func:`paa_mj.sim.analytic.rk4.acceleration_into` (``constants`` of :func:`~paa_mj.sim.analytic.rk4.rk4_constants`).
    """
    n, motors = x.size // 2, limits.size
    tau = np.empty(motors)
    kernel(x, t, params, memory.copy(), tau)
    finite = True
    for j in range(motors):
        if not math.isfinite(tau[j]):
            finite = False
    if finite:
        for j in range(motors):
            tau[j] = min(max(tau[j], -limits[j]), limits[j])
    for i in range(n):
        out[i] = x[n + i]
    acceleration_into(constants, x[:n], x[n:], tau, out[n:], work)
    return finite


def _clipped(tau, limits):
    """``tau`` clipped at +-``limits``; a non-finite torque stays non-finite (a divergence, as in MuJoCo: clipping
    would turn inf into the limit)."""
    return np.clip(tau, -limits, limits) if np.all(np.isfinite(tau)) else tau


def exact_field(robot: Robot, law, limits=None, on_nonfinite=None):
    """The right-hand side f(t, x) = [qd, qdd(q, qd, tau(x, t))] of (1) closed by one ``law``, as SciPy's
    integrators take it (x = [q, qd], shape (2n,)).

    A law with a compiled form (:class:`~paa_mj.control.base.CompiledForm`) is evaluated with (1) in one
    compiled call (:func:`closed_loop_field`); any other through its ``torque`` and
    :meth:`~paa_mj.model.dynamics.AnalyticModel.state_derivative`. The torques are clipped at +-``limits`` [N m]
    (default: the robot's actuator ranges); ``on_nonfinite(t)`` is called where the law returns NaN or inf.
    """
    check_binding(law, robot, None)  # a compiled law of another robot would read past its arrays
    n = robot.params.n_links
    limits = robot.torque_limits if limits is None else np.asarray(limits, float)
    form = law.compiled() if callable(getattr(law, "compiled", None)) else None
    if isinstance(form, CompiledForm):
        kernel, params, memory = KernelAddress(form.kernel), form.params, form.memory
        constants, work = rk4_constants(robot.analytic, 0.0), np.empty(work_size(n))

        def f(t, x):
            out = np.empty(2 * n)
            if not closed_loop_field(kernel, np.require(x, float, ("C", "W")), float(t), params, memory,
                                     limits, constants, out, work) and on_nonfinite is not None:
                on_nonfinite(t)
            return out
        return f

    am = robot.analytic

    def f(t, x):
        tau = _clipped(torque_of(law, x[None, :n], x[None, n:], t, motors=robot.params.n_motors)[0], limits)
        if not np.all(np.isfinite(tau)) and on_nonfinite is not None:
            on_nonfinite(t)
        return am.state_derivative(x, tau)
    return f


def _check_continuous(law):
    """Refuse a sampled-data law in one line: one that states its ``period`` (each torque held that long) or, in
    ``sampled_data``, what else ties its calls to time steps (a plan solved every period and kept between calls)."""
    sampled = getattr(law, "sampled_data", None)
    period = getattr(law, "period", None)
    if not sampled and isinstance(period, (int, float, np.integer, np.floating)) and period > 0:
        sampled = f"holds each torque for {float(period) * 1e3:g} ms"
    if sampled:
        raise PaaError(f"the analytic engine integrates laws continuous in time, and {controller_name(law)}"
                       f" {sampled} (a sampled-data controller); use --engine cpu")


def _phases(controller):
    """The laws of the run, in order, and the condition that ends the first (None: one law)."""
    if isinstance(controller, CombinedController):
        if not callable(getattr(controller.condition, "margin", None)):
            raise PaaError("the analytic engine needs a switching condition with a margin (an ODE event)")
        for law in (controller, controller.first, controller.second):
            _check_continuous(law)
        return [controller.first, controller.second], controller.condition
    _check_continuous(controller)
    mode_of(controller, (1,))  # a mode that cannot be read, or is not an integer, is refused in one line
    if not isinstance(getattr(controller, "mode", 0), (int, np.integer)):
        raise PaaError(f"the analytic engine cannot integrate {type(controller).__name__}: it keeps a state that"
                       " is not a switching condition; use --engine cpu")
    return [controller], None


def _first_entry(margin, dense, t_start, t_end, resolution):
    """(t, x) where ``margin`` first turns negative on (t_start, t_end] of the dense output, or None.

    The margin is sampled every ``resolution`` seconds (and at the step's end), so that a visit of the
    region shorter than the solver's step is not stepped over; the crossing is then located by bisection
    to 1e-12 s.
    """
    n = max(2, int(np.ceil((t_end - t_start) / resolution)) + 1)
    times = np.linspace(t_start, t_end, n)
    inside = np.flatnonzero(margin(times, dense(times)) < 0)
    inside = inside[inside > 0]
    if not inside.size:
        return None
    lo, hi = times[inside[0] - 1], times[inside[0]]
    while hi - lo > 1e-12:
        mid = 0.5 * (lo + hi)
        if margin(mid, dense(mid)[:, None])[0] < 0:
            hi = mid
        else:
            lo = mid
    return hi, dense(hi)


def simulate_analytic(robot: Robot, controller="vcl", x0=None, t_final: float | None = None, *,
                      task: Task | str | None = None, sample_dt: float = 0.01, rtol: float = 1e-10,
                      atol: float = 1e-10, method: str = "DOP853", torque_limit=None, event_resolution: float = 1e-3,
                      progress: bool = False, partial: bool = False) -> Trajectory:
    """Integrate (1) closed by ``controller`` with continuous-time control.

    Parameters
    ----------
    controller : controller, name or ControllerSpec
    x0 : array_like (2n,), optional
        Initial [q, qd]; default the task's start (hanging at rest, (65) for the gymnast).
    t_final : float, optional
        Duration [s]; default the task's horizon.
    task : Task or str, optional
        What the run aims at and is judged by; default the paper's folded task.
    torque_limit : float or (n - 1,), optional
        Saturation [N m], capped by the model's actuator ranges as in MuJoCo.
    rtol, atol, method
        Tolerances and method ("DOP853", "RK45", "Radau", "LSODA") of SciPy's integrator.
    event_resolution : float
        The switching condition is watched on the integrator's dense output every this many
        seconds [s], so that no visit of the region longer than that is stepped over.
    partial : bool
        After Ctrl-C or SIGTERM, return the run integrated so far, ``meta["interrupted"]`` set; by default the
        interruption is raised again (``KeyboardInterrupt``).
    """
    from scipy.integrate import DOP853, LSODA, RK45, Radau  # here: SciPy's integrate and optimize load slowly

    integrators = {"DOP853": DOP853, "RK45": RK45, "Radau": Radau, "LSODA": LSODA}
    if method not in integrators:
        raise PaaError(f"unknown method {method!r}: use one of {', '.join(integrators)}")
    check_robot(robot)
    task = as_task(task, robot)
    n = robot.params.n_links
    x0 = check_initial_state(task.start if x0 is None else x0, n)[0]
    t_final = task.horizon if t_final is None else t_final
    t_final, sample_dt, rtol, atol = _check_sizes(t_final, sample_dt, rtol, atol, event_resolution, n)
    controller = controllers_for(robot, controller, 1, task)[0]
    check_binding(controller, robot, task)
    limits = _limits(robot, torque_limit)
    reset_controller(controller)
    run = _Integration(robot, task, controller, limits, integrators[method], rtol, atol, event_resolution)
    steps = steps_for(t_final, run.judge_dt)  # a run of t_final ends where the MuJoCo engine's does: the nearest step
    run.integrate(x0, t_final if abs(steps * run.judge_dt - t_final) < 1e-6 * run.judge_dt else steps * run.judge_dt,
                  sample_dt, progress)
    traj = run.trajectory(x0, t_final, sample_dt, method, rtol)  # raises first where the run diverged
    if traj.meta.get("interrupted") and not partial:
        raise KeyboardInterrupt
    return traj


def _check_sizes(t_final, sample_dt, rtol, atol, event_resolution, n_links):
    """The durations and tolerances, checked (one-line errors), and the run's cost against the budgets."""
    t_final = positive_finite("final time", t_final, allow_none=False)
    sample_dt = positive_finite("sample interval", sample_dt, allow_none=False)
    # SciPy takes a NaN or infinite tolerance without a word and then never finishes a step
    rtol = positive_finite("rtol", rtol, allow_none=False)
    atol = positive_finite("atol", atol, allow_none=False)
    event_resolution = positive_finite("event_resolution", event_resolution, allow_none=False)
    if not event_resolution >= MIN_EVENT_RESOLUTION:
        raise PaaError(f"event_resolution {event_resolution:g} s is below {MIN_EVENT_RESOLUTION:g} s: the region would"
                       " be watched at more points than memory holds")
    if not np.isfinite(t_final / 1e-3):  # steps_for would fail to count the steps
        raise PaaError(f"final time {t_final:g} s is too long: it would need about 1e+"
                       f"{int(np.floor(np.log10(t_final) + 3))} solver steps of 1 ms; lower it")
    steps_for(t_final, 1e-3)
    sample_interval(sample_dt, sample_dt, t_final)
    # every sample is 15 floats here and again in the trajectory: refused before np.arange asks for them
    check_memory(t_final / sample_dt * 240.0, "recorded samples", "--t-final or raise --sample-dt")
    check_steps(t_final / 1e-3, f"the exact closed loop over {t_final:g} s (counted in 1 ms steps)", "--t-final",
                cores=1, links=n_links)
    return t_final, sample_dt, rtol, atol


def _limits(robot, torque_limit):
    """The torque limits of the run [N m]: ``torque_limit`` capped by the model's actuator ranges."""
    limits = robot.capped_torque_limits(torque_limit)
    if np.any(~(limits > 0)):
        raise PaaError("torque limits must be > 0")
    return limits


class _Integration:
    """One run of the exact closed loop: its phases (one law, or a swing-up then a balance controller), what
    it recorded, and the task's book of success kept on the dense solution at the instants k dt of the robot's
    MuJoCo time step dt, the instants the MuJoCo engine judges."""

    def __init__(self, robot, task, controller, limits, integrator, rtol, atol, event_resolution):
        self.robot, self.task, self.controller, self.limits = robot, task, controller, limits
        self.integrator, self.rtol, self.atol, self.resolution = integrator, rtol, atol, event_resolution
        self.laws, self.condition = _phases(controller)
        self.n = robot.params.n_links
        self.nonfinite_at = []  # times where the controller returned NaN or inf (the integrator then shrinks its step)
        self.ts, self.xs, self.modes = [], [], []
        self.switch_time, self.failure, self.interrupted, self.phase = None, None, False, 0
        self.book = np.full(len(BOOK), -1, np.int64)
        self.params = task.params
        self.judge_dt = float(robot.model.opt.timestep)
        self.judged = -1  # the last instant k judge_dt judged

    def _field(self, law, start):
        def nonfinite(t):
            if t == start:  # at the start itself no step helps, and SciPy's step floor is 0 at t = 0
                raise _NonFiniteTorque
            self.nonfinite_at.append(t)

        return exact_field(self.robot, law, self.limits, nonfinite)

    def _margin(self, t, x):
        # one margin per state, also for a condition of time alone (a scalar)
        n = self.n
        return np.broadcast_to(np.asarray(self.condition.margin(x[:n].T, x[n:].T, t), dtype=float), x.shape[1:])

    def _judge(self, dense, end):
        """Account for the instants k judge_dt up to ``end`` in the task's book."""
        last = int(np.floor(end / self.judge_dt + 1e-9))
        if last <= self.judged:
            return
        steps = np.arange(self.judged + 1, last + 1)
        states = dense(steps * self.judge_dt).T
        n = self.n
        book_rows(self.params, np.ascontiguousarray(states[:, :n]), np.ascontiguousarray(states[:, n:]), steps,
                  self.book)
        self.judged = last

    def integrate(self, x0, t_final, sample_dt, progress):
        """Integrate phase after phase from ``x0`` to ``t_final`` (or a failure, or Ctrl-C)."""
        t_eval = np.arange(0.0, t_final + 0.5 * sample_dt, sample_dt)
        self.t_eval = t_eval[t_eval <= t_final]
        t0, x = 0.0, x0
        book_rows(self.params, x0[None, :self.n].copy(), x0[None, self.n:].copy(), np.zeros(1, np.int64), self.book)
        self.judged = 0
        if self.condition is not None and self._margin(0.0, x0[:, None])[0] < 0:
            self.switch_time, self.phase = 0.0, 1
        bar = tqdm(total=t_final, unit="s", disable=None if progress else True, leave=False,
                   desc=f"{self.robot.name} solve_ivp", bar_format="{l_bar}{bar}| {n:.1f}/{total:.1f} s")
        self.recorded = -np.inf
        try:
            while True:
                entered = self._phase(self.phase, t0, x, t_final, bar)
                if entered is None or self.failure is not None:
                    break
                t0, x = entered
                self.switch_time, self.phase = t0, 1
        except _NonFiniteTorque:
            self.failure = STATUS_TEXT[NONFINITE_TORQUE]
        except KeyboardInterrupt:
            self.interrupted = True
        bar.close()

    def _phase(self, phase, t0, x, t_final, bar):
        """One law from (t0, x) until the switch (returned as (t, x)), the end or a failure (None)."""
        solver = self.integrator(self._field(self.laws[phase], t0), t0, x, t_final, rtol=self.rtol, atol=self.atol)
        watch = phase == 0 and self.condition is not None
        segment_t, segment_x, entered = [], [], None
        while solver.status == "running":
            t_old = solver.t
            solver.step()
            self.failure = self._failure(solver, t_final)
            if self.failure is not None:
                break
            dense = solver.dense_output()
            if watch:
                entered = _first_entry(self._margin, dense, t_old, solver.t, self.resolution)
            end = solver.t if entered is None else entered[0]
            self._judge(dense, end)
            grid = self.t_eval[(self.t_eval > self.recorded) & (self.t_eval <= end)]
            if grid.size:
                segment_t.append(grid)
                segment_x.append(dense(grid).T)
                self.recorded = grid[-1]
            bar.update(end - bar.n)
            if entered is not None:
                break
        self.ts.append(np.concatenate(segment_t) if segment_t else np.zeros(0))
        self.xs.append(np.concatenate(segment_x) if segment_x else np.zeros((0, 2 * self.n)))
        self.modes.append(np.full(len(self.ts[-1]), phase, np.int8))
        return entered

    def _failure(self, solver, t_final):
        """Why the integration cannot go on after this step, or None."""
        stuck = solver.status == "failed" or (solver.step_size is not None and solver.step_size < MIN_STEP
                                              and solver.t < t_final)
        if stuck and self.nonfinite_at and self.nonfinite_at[-1] - solver.t < 1e-6:
            return STATUS_TEXT[NONFINITE_TORQUE]
        if solver.status == "failed":
            return "the integrator failed (step size below its limit)"
        if stuck:
            # SciPy's own floor is relative to t, none near t = 0: a law that jumps (a wrapped angle at +-pi, a
            # bang-bang rule) would be chased for ever
            return (f"the integrator's step fell below {MIN_STEP:g} s (a torque law that jumps, or a stiff closed"
                    " loop): use --engine cpu")
        if np.any(np.abs(solver.y[self.n:]) > MAX_SPEED):
            return STATUS_TEXT[RUNAWAY]
        return None

    def trajectory(self, x0, t_final, sample_dt, method, rtol) -> Trajectory:
        """The record of the run, judged by the task; raises :class:`SimulationDiverged` after a failure."""
        n = self.n
        t = np.concatenate(self.ts) if self.ts else np.zeros(0)
        X = np.concatenate(self.xs) if self.xs else np.zeros((0, 2 * n))
        mode = np.concatenate(self.modes) if self.modes else np.zeros(0, np.int8)
        if self.failure and not len(t):
            # failed at the start: the start state is what was computed (kept and summarised, as MuJoCo's first
            # sample)
            t, X, mode = np.zeros(1), x0[None].copy(), np.full(1, self.phase, np.int8)
        q, qd = X[:, :n], X[:, n:]
        motors = self.robot.params.n_motors
        tau = np.array([_clipped(torque_of(self.laws[m], q[i][None], qd[i][None], t[i], motors=motors)[0],
                                 self.limits) for i, m in enumerate(mode)]).reshape(-1, motors)
        e_err, V = trajectory_quantities(self.controller, self.robot, self.task, q, qd)
        limits = self.limits
        traj = Trajectory(t, q, qd, tau, e_err, V, mode, self.switch_time, task=self.task,
                          meta={"robot": self.robot.name, "engine": "analytic", "integrator": f"solve_ivp {method}",
                                "dt": None, "sample_dt": sample_dt, "rtol": rtol, "x0": x0.tolist(),
                                "t_final": float(t_final), **describe_controller(self.controller),
                                "torque_limit": None if np.all(np.isinf(limits)) else limits.tolist(),
                                **self.robot.params.actuation_meta()},
                          robot_xml=self.robot.xml)
        failed = bool(self.failure) or not np.all(np.isfinite(X))
        finished = not failed and not self.interrupted
        end = steps_for(t_final, self.judge_dt) if finished else self.judged
        traj.meta["success"] = bool(self.task.succeeded(self.book[None], end, finished, False, self.judge_dt)[0])
        traj.meta["t_region"] = seconds_or_none(entered_times(self.book, self.judge_dt))
        if failed:
            when = float(t[-1]) if len(t) else 0.0
            why = self.failure or "non-finite state"
            traj.meta["status"] = f"diverged at t = {when:.4f} s: {why}"
            raise SimulationDiverged(f"analytic integration {traj.outcome()}", traj)
        traj.meta["status"] = f"interrupted at t = {float(t[-1]) if len(t) else 0.0:.4f} s" if self.interrupted else "ok"
        if self.interrupted:
            traj.meta["interrupted"] = True
        return traj
