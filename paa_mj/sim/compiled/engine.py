"""The rollout engine: MuJoCo stepped from compiled code, with the controller in the same loop.

Every rollout of the package, single or batched, runs through :func:`run`, for any chain of the
family: its arrays are sized from the model (n joints, n - 1 motors) and its task (the goal q*,
region (68) around it, success) is the :class:`~paa_mj.task.Task` of the plan, data, not constants
of the step. A step is :mod:`paa_mj.sim.compiled.step`'s; the records it reads are :mod:`paa_mj.sim.compiled.records`'.

A controller with a compiled form (:class:`~paa_mj.control.base.CompiledForm`)
runs with ``mj_step`` called from numba (:mod:`paa_mj.sim.compiled.mujoco_lib`), so nothing
of Python happens between steps; rollouts are spread over threads that take one
rollout at a time. Any other controller runs with the same per-step code, its
``torque`` called on the whole batch between steps. Both give the same numbers
for the same torques. Noise comes from :mod:`paa_mj.sim.noise`. Before anything
runs, every controller is checked against the plan's robot and task
(:func:`~paa_mj.control.base.check_binding`).
"""
from __future__ import annotations

import os
import threading
from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait
from dataclasses import dataclass, field

import mujoco
import numpy as np
from numba import typeof

from ...control.base import CompiledForm, SwitchedForm, check_binding, kernel, mode_of, reset_controller, torque_of
from ...errors import PaaError
from ...mujoco_log import mujoco_log_off
from ...progress import progress as progress_bar
from ...task import Task
from .mujoco_lib import COMPILED_PHYSICS
from .records import Run, Settings, State, new_samples, new_state, physics_of
from .retirement import RETIRE_FRACTION, certificate_size, retirement_certificate
from .step import (DIVERGED, FINISHED, MAX_SPEED, RETIRED, RUNNING, STATUS_TEXT, STOPPED, advance_compiled,
                   check_state, evaluate_once, measure, python_step, start_rollout)

__all__ = ["COMPILED_PHYSICS", "RETIRE_FRACTION", "certificate_size", "retirement_certificate", "run", "evaluate",
           "pack", "Plan", "Outcome", "DIVERGED", "FINISHED", "MAX_SPEED", "RETIRED", "RUNNING", "STATUS_TEXT",
           "STOPPED", "check_state"]

#: Steps a compiled rollout runs between two looks from Python (progress, Ctrl-C).
SEGMENT = 4096


@kernel
def _never(x, t, params, memory, tau):
    return 0


@dataclass(frozen=True, eq=False)
class Packed:
    """A compiled controller as the engine calls it: three kernels, one parameter vector, one initial memory."""

    first: object
    second: object
    condition: object
    params: np.ndarray
    memory: np.ndarray


def pack(form) -> Packed:
    """The engine's layout of a :class:`CompiledForm` or :class:`SwitchedForm`.

    ``params`` = [n1, n2, s1, s2, first's params (n1), second's (n2), the condition's]
    and ``memory`` = [switched?, first's memory (s1), second's memory (s2)].
    """
    if isinstance(form, SwitchedForm):
        first, second, condition, cond_params = form.first, form.second, form.condition, form.condition_params
    else:
        first, second, condition, cond_params = form, CompiledForm(_never, np.zeros(1)), _never, np.zeros(0)
    params = np.concatenate([[first.params.size, second.params.size, first.memory.size, second.memory.size],
                             first.params, second.params, np.asarray(cond_params, float)])
    memory = np.concatenate([[0.0], first.memory, second.memory])
    return Packed(first.kernel, second.kernel, condition, np.ascontiguousarray(params), memory)


def evaluate(form, q, qd, t=0.0, memory=None):
    """Torques (N, n - 1) and modes of a compiled form at states (N, n), (N, n), each from the same memory.

    ``memory`` (default: the initial one) is the packed memory of :func:`pack`, [switched?, the first's, the
    second's]; given shorter, its first numbers (``[1.0]``: switched) and the initial rest, which holds the laws'
    scratch (the chain's law and Spong's keep their matrices there)."""
    packed = pack(form)
    q, qd = np.atleast_2d(np.asarray(q, float)), np.atleast_2d(np.asarray(qd, float))
    tau, modes = np.empty((len(q), q.shape[1] - 1)), np.empty(len(q), np.int64)
    out = np.empty(q.shape[1] - 1)
    start = packed.memory
    if memory is not None:
        given = np.asarray(memory, float).reshape(-1)
        if given.size > start.size:
            raise PaaError(f"memory of {given.size} numbers given; this controller keeps {start.size}")
        start = np.concatenate([given, start[given.size:]])
    for i in range(len(q)):
        mem = start.copy()
        modes[i] = evaluate_once(packed.first, packed.second, packed.condition, np.concatenate([q[i], qd[i]]),
                                 float(t), packed.params, mem, out)
        tau[i] = out
    return tau, modes


# --- the Python side: plans, threads -----------------------------------------------------------------

@dataclass
class Plan:
    """What to run: N rollouts of one robot and task, one time step and length, on one or more plant models.

    Attributes
    ----------
    robot : paa_mj.model.robot.Robot
        The nominal robot, which every controller must be built for.
    task : Task
        What every rollout aims at and is judged by.
    models : list of mujoco.MjModel
        The distinct plants (same sizes, time step and integrator).
    model_index : ndarray (N,) of int
        Which plant each rollout runs on.
    x0 : ndarray (N, 2n)
        Initial states [q, qd] (n joints of the models).
    settings : Settings
        Each rollout's disturbances, torque limits, retirement certificate and pushes
        (:class:`~paa_mj.sim.compiled.records.Settings`).
    run : Run
        Time step, steps, sampling interval (0: record nothing), retirement and seed
        (:class:`~paa_mj.sim.compiled.records.Run`).
    """

    robot: object
    task: Task
    models: list
    model_index: np.ndarray
    x0: np.ndarray
    settings: Settings
    run: Run

    def __post_init__(self):
        # contiguous, as advance_compiled's signature takes them (no copy where they are already)
        self.x0 = np.ascontiguousarray(self.x0, dtype=float)
        self.settings = Settings(*(np.ascontiguousarray(a) for a in self.settings))

    def __len__(self):
        return len(self.x0)

    @property
    def n_links(self) -> int:
        return int(self.models[0].nq)

    @property
    def n_motors(self) -> int:
        """The motors (MuJoCo's actuators, in the order of the robot's driven joints)."""
        return int(self.models[0].nu)

    @property
    def dt(self) -> float:
        return self.run.dt

    @property
    def n_steps(self) -> int:
        return self.run.n_steps


@dataclass
class Outcome:
    """The engine's raw result: each rollout's :class:`~paa_mj.sim.compiled.records.State`, and the samples if recorded."""

    state: State
    samples: dict | None
    interrupted: bool = False
    meta: dict = field(default_factory=dict)


class RunArrays:
    """The mutable records of one run: each rollout's state and its samples."""

    def __init__(self, plan: Plan, memory_size: int):
        n, links, run = len(plan), plan.n_links, plan.run
        max_delay = int(np.max(plan.settings.rollouts["delay"], initial=0))
        self.state = new_state(n, links, memory_size, max_delay, plan.n_motors)
        self.samples = new_samples(n, links, run.n_steps // run.every + 2 if run.every else 0, plan.n_motors)

    def start(self, plan, r, physics, memory0):
        start_rollout(r, physics, plan.x0, self.state, memory0)

    def outcome(self, plan: Plan, interrupted: bool) -> Outcome:
        """The run's :class:`Outcome` (:func:`stopped_outcome`), with the samples where the plan records."""
        samples = None
        if plan.run.every:
            samples = {**self.samples._asdict(), "count": self.state.rollouts["samples"].copy()}
        return stopped_outcome(self.state, samples, interrupted)


def stopped_outcome(state, samples, interrupted: bool, meta=None) -> Outcome:
    """A run's :class:`Outcome`: a rollout still running at its end is marked stopped, and the run interrupted."""
    running = state.rollouts["status"] == RUNNING
    state.rollouts["status"][running] = STOPPED
    return Outcome(state, samples, interrupted=interrupted or bool(running.any()), meta=dict(meta or {}))


def check_count(plan: Plan, controllers):
    """One controller per rollout of ``plan``, or a one-line error."""
    if len(controllers) != len(plan):
        raise PaaError(f"need one controller per rollout ({len(plan)}), got {len(controllers)}")


def packed_controllers(plan: Plan, controllers):
    """Each distinct controller (by identity) checked against the plan's robot and task and packed once.

    Returns
    -------
    forms : dict
        :class:`Packed` (None for a controller with no compiled form) by ``id`` of the controller.
    keys : list
        Each rollout's key into ``forms``.
    """
    check_count(plan, controllers)
    forms, keys = {}, []
    for controller in controllers:
        key = id(controller)
        if key not in forms:
            check_binding(controller, plan.robot, plan.task)
            compiled = getattr(controller, "compiled", None)
            form = compiled() if callable(compiled) else None
            forms[key] = None if form is None else pack(form)
        keys.append(key)
    return forms, keys


def memory_size(forms: dict) -> int:
    """The controllers' memory every rollout's records hold: the largest packed one's, at least 1."""
    return max([f.memory.size for f in forms.values() if f is not None] + [1])


def run(plan: Plan, controllers, nthread=None, progress=False, desc="rollouts") -> Outcome:
    """Run every rollout of ``plan``; ``controllers`` holds one controller per rollout (repeats allowed).

    Compiled controllers run on ``nthread`` threads (default: all cores), one
    rollout at a time each; the others run together, ``torque`` on the batch
    between steps. Ctrl-C (or SIGTERM through :mod:`paa_mj.cli`) stops at the next
    segment and returns what finished, with ``interrupted`` set.
    """
    n = len(plan)
    forms, keys = packed_controllers(plan, controllers)
    compiled_rows, python_groups = [], {}
    for r, key in enumerate(keys):
        if forms[key] is not None:
            compiled_rows.append(r)
        else:
            python_groups.setdefault(key, []).append(r)
    arrays = RunArrays(plan, memory_size(forms))
    interrupted = False
    # Counted in simulated seconds, so that one long rollout shows its progress too.
    bar = _SimulatedTime(progress_bar(total=round(n * plan.n_steps * plan.dt, 6), unit="s simulated", desc=desc,
                                      enabled=progress), arrays, plan)
    try:
        with mujoco_log_off():
            if compiled_rows:
                interrupted = _run_compiled(plan, controllers, forms, compiled_rows, arrays, nthread, bar)
            for rows in python_groups.values():
                if interrupted:
                    break
                interrupted = _run_python(plan, controllers[rows[0]], rows, arrays, bar)
    finally:
        bar.close()
    return arrays.outcome(plan, interrupted)


class _SimulatedTime:
    """A progress bar fed with the simulated time of every rollout (finished ones count in full)."""

    def __init__(self, bar, arrays, plan):
        self.bar, self.arrays, self.plan, self.reported = bar, arrays, plan, 0.0

    def refresh(self):
        rollouts = self.arrays.state.rollouts
        steps = np.where(rollouts["status"] == RUNNING, rollouts["step"], self.plan.n_steps)
        done = round(float(np.sum(steps)) * self.plan.dt, 6)
        if done > self.reported:
            self.bar.update(done - self.reported)
            self.reported = done

    def close(self):
        self.refresh()
        self.bar.close()


def _run_compiled(plan, controllers, forms, rows, arrays, nthread, bar):
    """Compiled rollouts, one at a time per thread; returns True if interrupted."""
    nthread = max(1, min(nthread or os.cpu_count() or 1, len(rows)))
    queue = iter(rows)
    lock, stop = threading.Lock(), threading.Event()
    records = (plan.run, plan.settings, arrays.state, arrays.samples)

    def run_one(r, physics_of_model):
        model = plan.models[plan.model_index[r]]
        physics = physics_of_model.get(id(model))
        if physics is None:
            physics = physics_of_model[id(model)] = physics_of(model, mujoco.MjData(model))
        form = forms[id(controllers[r])]
        arrays.start(plan, r, physics, form.memory)
        while not stop.is_set():
            step_to = min(arrays.state.rollouts[r]["step"] + SEGMENT, plan.n_steps)
            status = advance_compiled(form.first, form.second, form.condition, r, step_to, form.params, physics,
                                      *records)
            if nthread == 1:
                bar.refresh()
            if status != RUNNING:
                return

    def work():
        datas = {}
        while not stop.is_set():
            with lock:
                r = next(queue, None)
            if r is None:
                return
            run_one(r, datas)

    if nthread == 1:  # in this thread, so Ctrl-C lands between two segments
        try:
            work()
        except KeyboardInterrupt:
            return True
        return False
    with ThreadPoolExecutor(nthread) as pool:
        futures = {pool.submit(work) for _ in range(nthread)}
        try:
            while futures:
                finished, futures = wait(futures, timeout=0.2, return_when=FIRST_COMPLETED)
                for future in finished:
                    future.result()
                bar.refresh()
        except KeyboardInterrupt:
            stop.set()
            wait(futures)
            return True
    return False


def _run_python(plan, controller, rows, arrays, bar):
    """Rollouts of a controller without a compiled form, stepped together; returns True if interrupted.

    The controller's ``torque`` is called once per step on the batch of measured states. Everything
    else of a step runs in one call of :func:`python_step` per rollout, its arguments bound once: the
    Python between two physics steps is what a hand-written ``mj_step`` loop would have, and little more.
    """
    rows = [int(r) for r in rows]
    physics = [physics_of(plan.models[plan.model_index[r]], mujoco.MjData(plan.models[plan.model_index[r]]))
               for r in rows]
    for r, phys in zip(rows, physics):
        arrays.start(plan, r, phys, np.zeros(1))
    reset_controller(controller)
    links = plan.n_links
    seen = np.zeros((len(rows), 2 * links))
    seen_q, seen_qd = seen[:, :links], seen[:, links:]
    dt, status = plan.dt, arrays.state.rollouts["status"]
    bound = [(r, physics[k], plan.run, plan.settings, arrays.state, arrays.samples, seen[k])
             for k, r in enumerate(rows)]
    # python_step as compiled for exactly these arguments (step, mode, torques, the bound ones): called
    # without numba's look at the type of every argument, which would cost as much as the rest of the call
    torques = np.zeros((len(rows), plan.n_motors))
    steppers = [python_step.compile(tuple(typeof(a) for a in (0, 0, torques[0], *args))) for args in bound]
    active = list(range(len(rows)))
    batch = (len(rows),)
    try:
        for k, r in enumerate(rows):
            measure(r, 0, physics[k], plan.run, plan.settings, seen[k])
        for step in range(plan.n_steps + 1):
            # copied into the engine's own array: the controller may reuse or change its output later
            torques[:] = torque_of(controller, seen_q.copy(), seen_qd.copy(), step * dt, copy=False,
                                   motors=plan.n_motors)
            modes = mode_of(controller, batch, plain=True)  # one int for every rollout, or one per rollout
            ended = False
            for k in active:
                if steppers[k](step, modes if type(modes) is int else int(modes[k]), torques[k], *bound[k]):
                    ended = True
            if step % SEGMENT == 0:
                bar.refresh()
            if ended:
                active = [k for k in active if status[rows[k]] == RUNNING]
                if not active:
                    break
    except KeyboardInterrupt:
        return True
    return False
