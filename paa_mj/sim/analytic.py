"""The exact closed loop: (1) integrated by SciPy's DOP853 (rtol 1e-10) with the torque evaluated continuously.

No zero-order hold and no time step: the reference against which MuJoCo's
discretisation is judged. A switching controller switches where its
condition's margin first turns negative, watched on the integrator's dense
output every millisecond (a short visit of the region is not stepped over)
and located by bisection; integration then restarts under the second controller. Stateless
controllers run as they are; a controller with internal state that is not a
:class:`~paa_mj.control.combined.CombinedController` cannot be integrated this way.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, types
from tqdm import tqdm

from ..control.base import KERNEL_TYPE, CompiledForm, KernelAddress, mode_of, reset_controller, torque_of
from ..control.combined import CombinedController
from ..errors import PaaError, SimulationDiverged
from ..limits import check_memory, check_steps, positive_finite
from ..model.robot import Robot
from ..model.states import start_state
from .engine import MAX_SPEED, NONFINITE_TORQUE, RUNAWAY, STATUS_TEXT
from .batch import check_initial_state, check_robot, controllers_for, sample_interval, steps_for
from .rk4 import acceleration_into, rk4_constants, work_size
from .rollout import describe_controller, trajectory_quantities
from .trajectory import Trajectory


#: Smallest step of the adaptive integrator [s]; a smooth closed loop of this model takes steps of 1e-5 s or more.
MIN_STEP = 1e-10
#: Finest interval at which the switching condition may be watched [s].
MIN_EVENT_RESOLUTION = 1e-9


class _NonFiniteTorque(Exception):
    """The controller returned NaN or inf where the integration starts."""


_VECTOR = types.float64[::1]


@njit(types.boolean(KERNEL_TYPE, _VECTOR, types.float64, _VECTOR, _VECTOR, _VECTOR, _VECTOR, _VECTOR, _VECTOR),
      cache=True)
def closed_loop_field(kernel, x, t, params, memory, limits, constants, out, work):
    """f(t, x) = [qd, qdd(q, qd, tau(x, t))] of (1) closed by a compiled law into ``out`` (2n); returns whether the
    torques were finite (non-finite ones are applied as they are, clipped ones at ``limits`` [N m] otherwise).

    The law is the kernel of a stateless controller (:class:`~paa_mj.control.base.CompiledForm`), called with a
    fresh copy of its initial ``memory`` at every evaluation, as its ``torque`` would be; the accelerations are
    those of :func:`paa_mj.sim.rk4.acceleration_into` (``constants`` of :func:`~paa_mj.sim.rk4.rk4_constants`).
    """
    n = x.size // 2
    tau = np.empty(n - 1)
    kernel(x, t, params, memory.copy(), tau)
    finite = True
    for j in range(n - 1):
        if not math.isfinite(tau[j]):
            finite = False
    if finite:
        for j in range(n - 1):
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
    n = robot.params.n_links
    limits = robot.torque_limits if limits is None else np.asarray(limits, float)
    form = law.compiled() if callable(getattr(law, "compiled", None)) else None
    if isinstance(form, CompiledForm):
        kernel, params, memory = KernelAddress(form.kernel), form.params, form.memory
        constants, work = rk4_constants(robot.analytic, 0.0), np.empty(work_size(n))

        def f(t, x):
            out = np.empty(2 * n)
            if not closed_loop_field(kernel, np.ascontiguousarray(x, dtype=float), float(t), params, memory,
                                     limits, constants, out, work) and on_nonfinite is not None:
                on_nonfinite(t)
            return out
        return f

    am = robot.analytic

    def f(t, x):
        tau = _clipped(torque_of(law, x[None, :n], x[None, n:], t)[0], limits)
        if not np.all(np.isfinite(tau)) and on_nonfinite is not None:
            on_nonfinite(t)
        return am.state_derivative(x, tau)
    return f


def _phases(controller):
    """The laws of the run, in order, and the condition that ends the first (None: one law)."""
    if isinstance(controller, CombinedController):
        if not callable(getattr(controller.condition, "margin", None)):
            raise PaaError("the analytic engine needs a switching condition with a margin (an ODE event)")
        return [controller.first, controller.second], controller.condition
    mode_of(controller, (1,))  # a mode that cannot be read, or is not an integer, is refused in one line
    if not isinstance(getattr(controller, "mode", 0), (int, np.integer)):
        raise PaaError(f"the analytic engine cannot integrate {type(controller).__name__}: it keeps a state that"
                       " is not a switching condition; use --engine mujoco")
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


def simulate_analytic(robot: Robot, controller="vcl", x0=None, t_final: float = 30.0, sample_dt: float = 0.01,
                      rtol: float = 1e-10, atol: float = 1e-10, method: str = "DOP853", torque_limit=None,
                      event_resolution: float = 1e-3, progress: bool = False, goal: str = "folded") -> Trajectory:
    """Integrate (1) closed by ``controller`` with continuous-time control.

    Parameters
    ----------
    controller : controller, name or ControllerSpec
    x0 : array_like (2n,), optional
        Initial [q, qd]; default hanging at rest ((65) for the gymnast).
    torque_limit : float or (n - 1,), optional
        Saturation [N m], capped by the model's actuator ranges as in MuJoCo.
    rtol, atol, method
        Tolerances and method ("DOP853", "RK45", "Radau", "LSODA") of SciPy's integrator.
    event_resolution : float
        The switching condition is watched on the integrator's dense output every this many
        seconds [s], so that no visit of the region longer than that is stepped over.
    goal : {"folded", "stretched"}
        The goal the controllers named here aim at and the run is judged against.
    """
    from scipy.integrate import DOP853, LSODA, RK45, Radau  # here: SciPy's integrate and optimize load slowly

    integrators = {"DOP853": DOP853, "RK45": RK45, "Radau": Radau, "LSODA": LSODA}
    if method not in integrators:
        raise PaaError(f"unknown method {method!r}: use one of {', '.join(integrators)}")
    check_robot(robot)
    n = robot.params.n_links
    x0 = check_initial_state(start_state(n, goal) if x0 is None else x0, n)[0]
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
                cores=1)
    controller = controllers_for(robot, controller, 1, goal)[0]
    try:
        requested = np.broadcast_to(np.inf if torque_limit is None else np.asarray(torque_limit, float), (n - 1,))
    except (TypeError, ValueError):
        raise PaaError(f"torque limit must be one number or one per motor ({n - 1}) [N m], got {torque_limit!r}") \
            from None
    limits = np.minimum(requested, robot.torque_limits)
    if np.any(~(limits > 0)):
        raise PaaError("torque limits must be > 0")
    reset_controller(controller)
    laws, condition = _phases(controller)

    def law_torque(law, q, qd, t):
        return _clipped(torque_of(law, q[None], qd[None], t)[0], limits)

    nonfinite_at = []  # times where the controller returned NaN or inf (the integrator then shrinks its step)

    def field(law, start):
        def nonfinite(t):
            if t == start:  # at the start itself no step helps, and SciPy's step floor is 0 at t = 0
                raise _NonFiniteTorque
            nonfinite_at.append(t)

        return exact_field(robot, law, limits, nonfinite)

    def stuck_on_nonfinite_torque(t):
        return bool(nonfinite_at) and nonfinite_at[-1] - t < 1e-6

    def margin(t, x):
        # one margin per state, also for a condition of time alone (a scalar)
        return np.broadcast_to(np.asarray(condition.margin(x[:n].T, x[n:].T, t), dtype=float), x.shape[1:])

    t_eval = np.arange(0.0, t_final + 0.5 * sample_dt, sample_dt)
    t_eval = t_eval[t_eval <= t_final]
    ts, xs, modes = [], [], []
    t0, x, switch_time, phase = 0.0, x0, None, 0
    if condition is not None and margin(0.0, x0[:, None])[0] < 0:
        switch_time, phase = 0.0, 1
    bar = tqdm(total=t_final, unit="s", disable=None if progress else True, leave=False, desc=f"{robot.name} solve_ivp",
               bar_format="{l_bar}{bar}| {n:.1f}/{total:.1f} s")
    failure, interrupted, recorded = None, False, -np.inf
    try:
        while True:
            solver = integrators[method](field(laws[phase], t0), t0, x, t_final, rtol=rtol, atol=atol)
            watch = phase == 0 and condition is not None
            segment_t, segment_x, entered = [], [], None
            while solver.status == "running":
                t_old = solver.t
                solver.step()
                stuck = solver.status == "failed" or (solver.step_size is not None and solver.step_size < MIN_STEP
                                                      and solver.t < t_final)
                if stuck and stuck_on_nonfinite_torque(solver.t):
                    failure = STATUS_TEXT[NONFINITE_TORQUE]
                    break
                if solver.status == "failed":
                    failure = "the integrator failed (step size below its limit)"
                    break
                if stuck:
                    # SciPy's own floor is relative to t, none near t = 0: a law that jumps (a wrapped angle
                    # at +-pi, a bang-bang rule) would be chased for ever
                    failure = (f"the integrator's step fell below {MIN_STEP:g} s (a torque law that jumps, or"
                               " a stiff closed loop): use --engine mujoco")
                    break
                if np.any(np.abs(solver.y[n:]) > MAX_SPEED):
                    failure = STATUS_TEXT[RUNAWAY]
                    break
                dense = solver.dense_output()
                if watch:
                    entered = _first_entry(margin, dense, t_old, solver.t, event_resolution)
                end = solver.t if entered is None else entered[0]
                grid = t_eval[(t_eval > recorded) & (t_eval <= end)]
                if grid.size:
                    segment_t.append(grid)
                    segment_x.append(dense(grid).T)
                    recorded = grid[-1]
                bar.update(end - bar.n)
                if entered is not None:
                    break
            ts.append(np.concatenate(segment_t) if segment_t else np.zeros(0))
            xs.append(np.concatenate(segment_x) if segment_x else np.zeros((0, 2 * n)))
            modes.append(np.full(len(ts[-1]), phase, np.int8))
            if entered is not None and failure is None:
                t0, x = entered
                switch_time, phase = t0, 1
                continue
            break
    except _NonFiniteTorque:
        failure = STATUS_TEXT[NONFINITE_TORQUE]
    except KeyboardInterrupt:
        interrupted = True
    bar.close()
    t = np.concatenate(ts) if ts else np.zeros(0)
    X = np.concatenate(xs) if xs else np.zeros((0, 2 * n))
    mode = np.concatenate(modes) if modes else np.zeros(0, np.int8)
    if failure and not len(t):
        # failed at the start: the start state is what was computed (kept and summarised, as MuJoCo's first sample)
        t, X, mode = np.zeros(1), x0[None].copy(), np.full(1, phase, np.int8)
    q, qd = X[:, :n], X[:, n:]
    tau = np.array([law_torque(laws[m], q[i], qd[i], t[i]) for i, m in enumerate(mode)]).reshape(-1, n - 1)
    e_err, V = trajectory_quantities(controller, robot, q, qd, goal)
    traj = Trajectory(t, q, qd, tau, e_err, V, mode, switch_time,
                      meta={"robot": robot.name, "engine": "analytic", "integrator": f"solve_ivp {method}",
                            "dt": None, "sample_dt": sample_dt, "rtol": rtol, "x0": x0.tolist(), "t_final": float(t_final),
                            **describe_controller(controller),
                            "torque_limit": None if np.all(np.isinf(limits)) else limits.tolist(),
                            **({"goal": goal} if goal != "folded" else {})},
                      robot_xml=robot.xml)
    if failure or not np.all(np.isfinite(X)):
        when = float(t[-1]) if len(t) else 0.0
        traj.meta["status"] = f"diverged at t = {when:.4f} s: {failure or 'non-finite state'}"
        raise SimulationDiverged(f"analytic integration failed at t = {when:.4f} s: {failure or 'non-finite state'}",
                                 traj)
    traj.meta["status"] = f"interrupted at t = {float(t[-1]) if len(t) else 0.0:.4f} s" if interrupted else "ok"
    if interrupted:
        traj.meta["interrupted"] = True
    return traj
