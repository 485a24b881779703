"""The rollout engine on MuJoCo Warp: N rollouts as N worlds of one device, the controller on the device too.

``engine="warp"`` of :func:`~paa_mj.sim.batch.simulate_batch` (``--engine warp`` of the studies) runs a
:class:`~paa_mj.sim.compiled.engine.Plan` here instead of :func:`paa_mj.sim.compiled.engine.run`, and returns the same
:class:`~paa_mj.sim.compiled.engine.Outcome`, so that every outcome, summary and file of a study is computed as before.
Each step of every world, on the device (a GPU, or Warp's CPU device), is :mod:`paa_mj.sim.compiled.step`'s: the
kernels hold no equation of their own, they unpack the device arrays and call the translations to Warp
(:mod:`paa_mj.sim.warp.translate`) of the very functions the CPU engine compiles:

1. ``control`` measures the state (:func:`~paa_mj.sim.compiled.step.measure_into`: the same counter-based noise draws),
   evaluates the controller (its compiled form, :func:`~paa_mj.sim.compiled.step.call_controller` with its two laws and
   the switch), turns its torque into ``ctrl`` (:func:`~paa_mj.sim.compiled.step.command_into`: delay line, torque
   noise, saturation), keeps the rollout's records (:func:`~paa_mj.sim.compiled.step.account`: switch, the task's book of
   success, peak and last torques, smoothness, peak speed, the last good state) and stops a rollout that asked
   for a non-finite torque, retired or finished (:func:`~paa_mj.sim.compiled.step.verdict`), as
   :func:`paa_mj.sim.compiled.step.actuate` does; then the pushes (:func:`~paa_mj.sim.compiled.step.apply_pushes`);
2. ``mujoco_warp.step`` advances every world (the robot's integrator and time step; no room for constraint rows,
   :func:`device_worlds`, so the acceleration is the smooth one as in MuJoCo for ``nefc = 0``);
3. ``after`` adds the step's effort and work (:func:`~paa_mj.sim.compiled.step.add_effort_work`) and stops a world whose
   state is not finite or runs away (:func:`~paa_mj.sim.compiled.step.state_status`), back at its last good state, as
   :func:`paa_mj.sim.compiled.step.finish_step` does.

The records are one row a rollout, float64 and int32 (:data:`COUNTS`, :data:`SUMS`); the controller runs in
float64 too. Only MuJoCo Warp's own arrays are float32: the state is read from them after each step and
``ctrl`` and the pushes written to them, in the kernels and nowhere else.

Every :data:`SEGMENT` steps Python looks at the worlds: where at most :data:`PACK_WHEN` of them still run, they
are packed into fewer worlds (:meth:`_Worlds.take`; a world's step reads only its own rows, so nothing it computes
changes) and the others' records are kept. On a GPU the steps are captured in a CUDA graph and replayed; on the
CPU device each kernel is launched from Python (about 2 ms a step of Euler, 10 ms of RK4 on this package's CI
machine, whatever the number of worlds: a correctness check, not a fast path). MuJoCo Warp computes in
float32: a rollout agrees with the CPU engine's float64 to about 1e-6 over 200 steps, and the closed loop stays
within float32 rounding of it until the dynamics amplify the difference (``tests/test_warp.py`` states what it
checks).

What runs here: the controllers whose records declare that their compiled laws translate (:data:`DEVICE_LAWS`;
among the package's: ``vcl``, ``vc`` and their
``-only`` and ``-roa`` forms on every chain and goal (the paper's closed forms for the gymnast at its folded goal,
the chain's law elsewhere, its scratch in the controller's memory), ``lqr``, ``passive``, switched by region (68),
the ROA level or time; ``spong`` on the acrobot; ``fantoni`` on the pendubot; ``trajopt`` and ``trajopt-effort``,
their TVLQR then the LQR),
the nominal plant for every rollout (per-rollout torque limits, disturbances
(:class:`~paa_mj.sim.batch.Disturbances`: measurement and torque noise, the same draws as the CPU engine's, delay,
pushes) and controller parameters allowed), no recorded trajectories: anything else is refused in one line before
any work.
"""
# No ``from __future__ import annotations``: the kernels' annotations are Warp's array types, made at run time
# where the kernels are defined (:func:`_array_types`), and read by Warp as objects.
import numpy as np

from ...control import catalog
from ...control.base import controller_name
from ...errors import PaaError
from ...progress import progress as progress_bar
from ..compiled import engine
from ..compiled.records import new_state
from ..compiled.step import RUNNING, account, add_effort_work, apply_pushes, call_controller, command_into, \
    measure_into, state_status, verdict
from .device import device_name, load_warp

__all__ = ["DEVICE_LAWS", "device_controllers", "device_law", "device_data", "device_model", "device_worlds", "run"]

#: Steps between two looks from Python (progress, Ctrl-C, every rollout ended).
SEGMENT = 256
#: Steps captured in one CUDA graph.
GRAPH_STEPS = 64


def _device_laws():
    """The compiled kernels whose translation to Warp is tested: those of every controller whose record says it has
    a device law (:class:`~paa_mj.control.record.ControllerRecord`), by kernel, with the names of the controllers
    they serve; and the engine's "never" condition of a controller with one law."""
    from ...control.registry import RECORDS

    laws = {engine._never: ("never",)}
    for name, record in RECORDS.items():
        if record.device:
            for k in record.kernels:
                laws[k] = laws.get(k, ()) + (name,)
    return laws


#: What ``--engine warp`` runs: the controllers whose records say their laws have a device form (module docstring).
DEVICE_LAWS = catalog.DEVICE_CONTROLLERS
_REFUSAL = ("controller {name} has no law on the device (the warp engine runs {laws}); use {instead}")


def device_controllers(plan: engine.Plan, controllers):
    """Each rollout's packed compiled form, checked to have a device law and to share its kernels with the others:
    (the kernels (first, second, condition), params (N, P), memory (N, S)); one-line refusals otherwise."""
    forms, keys = engine.packed_controllers(plan, controllers)
    kernels = None
    for key in dict.fromkeys(keys):
        triple = device_law(forms[key], controller_name(controllers[keys.index(key)]))
        if kernels is not None and triple != kernels:
            raise PaaError("the warp engine runs one controller law for every rollout of a batch (gains and models"
                           " may differ): split the batch, or use --engine cpu")
        kernels = triple
    # a row per distinct controller, zero-padded, then each rollout's row of these tables
    position = {key: k for k, key in enumerate(dict.fromkeys(keys))}
    packed = [forms[key] for key in position]
    params = np.zeros((len(packed), max(p.params.size for p in packed)))
    memory = np.zeros((len(packed), max(p.memory.size for p in packed)))
    for k, p in enumerate(packed):
        params[k, :p.params.size] = p.params
        memory[k, :p.memory.size] = p.memory
    which = np.fromiter((position[key] for key in keys), dtype=np.int64, count=len(keys))
    return kernels, params[which], memory[which]


def device_law(packed, name, instead="--engine cpu"):
    """The kernels (first, second, condition) of a packed compiled controller (None: it has no compiled form), or a
    one-line refusal naming the controller ``name`` where one of them has no device form (and the engine to use
    ``instead``)."""
    laws = _device_laws()
    triple = None if packed is None else (packed.first, packed.second, packed.condition)
    if triple is None or any(k not in laws for k in triple):
        raise PaaError(_REFUSAL.format(name=name, laws=", ".join(DEVICE_LAWS), instead=instead))
    return triple


def _check_plan(plan: engine.Plan):
    if len(plan.models) != 1:
        raise PaaError("the warp engine runs the nominal plant for every rollout (no plant model error yet): use"
                       " --engine cpu")
    if plan.run.every:
        raise PaaError("the warp engine records no trajectories (record=False, or use --engine cpu)")
    if plan.n_steps >= 2**31 - 1:
        raise PaaError(f"the warp engine counts steps in 32 bits: {plan.n_steps} steps are too many")


def device_model(model):
    """A copy of a plant's MjModel for MuJoCo Warp: MuJoCo's energy (not read by the engines) left off."""
    import mujoco

    copy = model.__copy__()
    copy.opt.enableflags &= ~int(mujoco.mjtEnableBit.mjENBL_ENERGY)
    return copy


def device_data(mjw, copy, n_worlds):
    """MuJoCo Warp's data of ``n_worlds`` worlds of ``copy`` (:func:`device_model`'s). A plant that makes no
    constraint row (:func:`~paa_mj.model.mjcf_read.makes_no_constraints`: every robot the package reads) gets no
    room for contacts or constraint rows, so that MuJoCo Warp copies the smooth acceleration as MuJoCo does for
    ``nefc = 0`` instead of running its solver over empty rows, and 1024 x 1024 worlds fit in the device's memory.
    """
    from ...model.mjcf_read import makes_no_constraints

    sizes = {"nconmax": 0, "njmax": 0} if makes_no_constraints(copy) else {}
    return mjw.make_data(copy, nworld=n_worlds, **sizes)


def device_worlds(mjw, model, n_worlds):
    """A plant's MjModel as MuJoCo Warp's model and data of ``n_worlds`` worlds: ``(model, data)``
    (:func:`device_model`, :func:`device_data`)."""
    copy = device_model(model)
    return mjw.put_model(copy), device_data(mjw, copy, n_worlds)


#: MuJoCo Warp's per-world arrays that carry a world from one step to the next (the rest each step recomputes).
CARRIED = ("qpos", "qvel", "act", "ctrl", "qfrc_applied", "qacc_warmstart", "time")


_KERNELS = {}

#: The columns of the device's per-rollout counts (int32) and sums (float64): the fields of
#: :data:`~paa_mj.sim.compiled.records.ROLLOUT` the kernels keep.
COUNTS = ("step", "status", "switch", "mode")
SUMS = ("effort", "work", "smooth", "speed")
_STEP, _STATUS, _SWITCH, _MODE = range(4)
_EFFORT, _WORK, _SMOOTH, _SPEED = range(4)


def _device_functions(wp, triple, n_links):
    """The step's functions on the device, translated from :mod:`paa_mj.sim.compiled.step` (float64, a state of 2
    ``n_links``): the law (``triple`` of compiled kernels, switched by :func:`~paa_mj.sim.compiled.step.call_controller`),
    then measure, command, account, verdict, pushes, effort and state, in the order the kernels call them."""
    from .translate import device_function

    def translated(fn, bind=None):
        return device_function(wp, fn, bind=bind, real=wp.float64, state_size=2 * n_links)

    first, second, condition = (translated(k) for k in triple)
    law = translated(call_controller, {"first": first, "second": second, "condition": condition})
    return (law,) + tuple(translated(fn) for fn in (measure_into, command_into, account, verdict, apply_pushes,
                                                    add_effort_work, state_status))


def _kernels(wp, triple, n_links):
    """The two step kernels for a controller law (``triple`` of compiled kernels) and a chain of ``n_links``:
    ``control`` before ``mujoco_warp.step``, ``after`` it (module docstring)."""
    key = (id(wp), triple, n_links)
    if key not in _KERNELS:
        functions = _device_functions(wp, triple, n_links)
        _KERNELS[key] = (_control_kernel(wp, *functions[:6]), _after_kernel(wp, *functions[6:]))
    return _KERNELS[key]


def _array_types(wp):
    """Warp's array types of the kernels' arguments: float32 2-d (MuJoCo Warp's), float64 2-d, float64 3-d, float64
    1-d and int32 2-d."""
    return (wp.array2d(dtype=wp.float32), wp.array2d(dtype=wp.float64), wp.array3d(dtype=wp.float64),
            wp.array(dtype=wp.float64), wp.array2d(dtype=wp.int32))


def _control_kernel(wp, law, measure, command, account, verdict, push):
    """The kernel of a step up to the physics: :mod:`paa_mj.sim.compiled.step`'s functions on the float64 state ``q``,
    ``qd`` as :func:`~paa_mj.sim.compiled.step.actuate` calls them; ``ctrl`` and the pushes written to MuJoCo Warp's float32
    arrays."""
    F32, F64, F64_3, V64, I32 = _array_types(wp)

    @wp.kernel(module="unique", enable_backward=False)
    def control(qpos: F32, qvel: F32, ctrl: F32, qfrc: F32, q: F64, qd: F64, seen: F64, tau: F64, u: F64,
                force: F64, params: F64, memory: F64, limits: F64, noise: F64, delays: wp.array(dtype=wp.int32),
                ids: wp.array(dtype=wp.int64), delay_line: F64_3, pushes: F64_3, push_end: V64, task: V64,
                cert: F64, level: V64, counts: I32, sums: F64, books: I32, peak: F64, last_tau: F64,
                last_state: F64, n_steps: wp.int32, dt: wp.float64, retire: wp.bool, seed: wp.int64):
        r = wp.tid()
        n = qpos.shape[1]
        nu = ctrl.shape[1]
        if counts[r, _STATUS] != RUNNING:  # stopped: no torque (its state is put back after the physics)
            for j in range(nu):
                ctrl[r, j] = wp.float32(0.0)
            return
        step = counts[r, _STEP]
        t = wp.float64(step) * dt
        measure(q[r], qd[r], noise[r, 0], noise[r, 1], seed, ids[r], step, seen[r])
        mode = law(seen[r], t, params[r], memory[r], tau[r])
        finite = command(step, tau[r], u[r], delays[r], delay_line[r], noise[r, 2], seed, ids[r], n, limits[r])
        for j in range(nu):
            ctrl[r, j] = wp.float32(u[r, j])
        counts[r, _MODE] = mode
        switch, smooth, speed = account(step, mode, dt, task, q[r], qd[r], u[r], books[r], peak[r], last_tau[r],
                                        last_state[r], counts[r, _SWITCH], sums[r, _SMOOTH], sums[r, _SPEED])
        counts[r, _SWITCH] = switch
        sums[r, _SMOOTH] = smooth
        sums[r, _SPEED] = speed
        status = verdict(step, n_steps, finite, retire, mode, level[r], t, push_end[r], cert[r], q[r], qd[r], task)
        if status != RUNNING:
            counts[r, _STATUS] = status
            return
        if pushes.shape[1] > 0:
            push(r, t, pushes, force[r])
            for i in range(n):
                qfrc[r, i] = wp.float32(force[r, i])

    return control


def _after_kernel(wp, effort_work, state_status):
    """The kernel of a step after the physics: MuJoCo Warp's float32 state read into the float64 ``q``, ``qd``,
    then :func:`~paa_mj.sim.compiled.step.add_effort_work` and :func:`~paa_mj.sim.compiled.step.state_status` as
    :func:`~paa_mj.sim.compiled.step.finish_step` calls them; a stopped world back at its last good state, where the CPU
    engine leaves it."""
    F32, F64, F64_3, V64, I32 = _array_types(wp)

    @wp.kernel(module="unique", enable_backward=False)
    def after(qpos: F32, qvel: F32, q: F64, qd: F64, u: F64, counts: I32, sums: F64, last_state: F64, joints: V64,
              dt: wp.float64):
        r = wp.tid()
        n = qpos.shape[1]
        if counts[r, _STATUS] == RUNNING:
            for i in range(n):
                q[r, i] = wp.float64(qpos[r, i])
                qd[r, i] = wp.float64(qvel[r, i])
            effort, work = effort_work(u[r], qd[r], joints, dt, sums[r, _EFFORT], sums[r, _WORK])
            sums[r, _EFFORT] = effort
            sums[r, _WORK] = work
            status = state_status(q[r], qd[r])
            if status == RUNNING:
                counts[r, _STEP] = counts[r, _STEP] + 1
                return
            counts[r, _STATUS] = status
        for i in range(n):
            qpos[r, i] = wp.float32(last_state[r, i])
            qvel[r, i] = wp.float32(last_state[r, n + i])

    return after


class _Worlds:
    """The device arrays of one run: MuJoCo Warp's model and data (float32), the controllers' parameters and the
    records, float64 and int32 (:data:`COUNTS`, :data:`SUMS`), in the layouts :mod:`paa_mj.sim.compiled.step`'s functions
    read on the CPU (one row a rollout)."""

    #: The arrays of one row a rollout (all but the task, which every rollout shares).
    ROWS = ("q", "qd", "seen", "tau", "u", "force", "params", "memory", "limits", "noise", "delays", "ids",
            "delay_line", "pushes", "push_end", "cert", "level", "counts", "sums", "books", "peak", "last_tau",
            "last_state")

    def __init__(self, wp, mjw, plan, params, memory, device):
        n, links = len(plan), plan.n_links
        self.wp, self.mjw, self.plant = wp, mjw, device_model(plan.models[0])
        self.rows = np.arange(n)  # the rollouts these worlds run, in order
        self.model, self.data = mjw.put_model(self.plant), device_data(mjw, self.plant, n)
        self.data.qpos.assign(plan.x0[:, :links].astype(np.float32))
        self.data.qvel.assign(plan.x0[:, links:].astype(np.float32))
        settings, rollouts = plan.settings, plan.settings.rollouts

        def put(array, dtype=wp.float64):
            return wp.array(np.ascontiguousarray(array), dtype=dtype, device=device)

        def zeros(*shape):
            return wp.zeros(shape, dtype=wp.float64, device=device)

        # the state in float64: the start itself (a start at the goal is at the goal, not at its float32 rounding),
        # then MuJoCo Warp's after each step; measured; the law's torque; the command; the pushes' forces
        self.q, self.qd, self.seen = put(plan.x0[:, :links]), put(plan.x0[:, links:]), zeros(n, 2 * links)
        motors = plan.n_motors
        self.tau, self.u, self.force = zeros(n, motors), zeros(n, motors), zeros(n, links)
        self.params, self.memory, self.limits = put(params), put(memory), put(settings.limits)
        self.noise = put(np.stack([rollouts["noise_q"], rollouts["noise_qd"], rollouts["torque_noise"]], 1))
        self.delays = put(rollouts["delay"].astype(np.int32), wp.int32)
        self.ids = put(rollouts["id"].astype(np.int64), wp.int64)
        self.delay_line = zeros(n, int(np.max(rollouts["delay"], initial=0)) + 1, motors)
        self.pushes, self.push_end = put(settings.pushes), put(rollouts["push_end"])
        self.task, self.cert, self.level = put(plan.run.task), put(settings.cert), put(rollouts["retire_level"])
        self.joints = put(plan.run.joints)
        counts = np.zeros((n, len(COUNTS)), np.int32)
        counts[:, COUNTS.index("switch")] = -1  # no switch yet
        self.counts = put(counts, wp.int32)
        self.sums = zeros(n, len(SUMS))
        self.books = put(np.full((n, 3), -1, np.int32), wp.int32)
        self.peak, self.last_tau, self.last_state = zeros(n, motors), zeros(n, motors), put(plan.x0)

    def store(self, state):
        """These worlds' records read back into their rows of the run's :class:`~paa_mj.sim.compiled.records.State`."""
        rows, memory_size = self.rows, self.memory.shape[1]
        counts, sums = self.counts.numpy(), self.sums.numpy()
        for k, field in enumerate(COUNTS):
            state.rollouts[field][rows] = counts[:, k]
        for k, field in enumerate(SUMS):
            state.rollouts[field][rows] = sums[:, k]
        state.book[rows] = self.books.numpy()
        state.peak[rows] = self.peak.numpy()
        state.last_tau[rows] = self.last_tau.numpy()
        state.last_state[rows] = self.last_state.numpy()
        state.memory[rows, :memory_size] = self.memory.numpy()

    def take(self, keep):
        """New worlds of the rows ``keep`` (indices into these worlds), each where it was: the state MuJoCo Warp
        carries from a step (:data:`CARRIED`) and every array of one row a rollout. A world's step depends on its
        own rows alone, so it goes on exactly as it would have among the others."""
        wp = self.wp
        taken = object.__new__(_Worlds)
        taken.wp, taken.mjw, taken.plant, taken.task, taken.joints = wp, self.mjw, self.plant, self.task, self.joints
        taken.rows = self.rows[keep]
        taken.model, taken.data = self.model, device_data(self.mjw, self.plant, len(keep))
        for name in CARRIED:
            old = getattr(self.data, name, None)
            if old is not None and old.size:
                getattr(taken.data, name).assign(old.numpy()[keep])
        for name in self.ROWS:
            old = getattr(self, name)
            setattr(taken, name, wp.array(np.ascontiguousarray(old.numpy()[keep]), dtype=old.dtype,
                                          device=old.device))
        return taken


def run(plan: engine.Plan, controllers, *, device=None, progress=False, desc="rollouts") -> engine.Outcome:
    """Run every rollout of ``plan`` on MuJoCo Warp (module docstring); the same :class:`~paa_mj.sim.compiled.engine.Outcome`
    as :func:`paa_mj.sim.compiled.engine.run`. ``device``: a Warp device name (default: :func:`device_name`'s)."""
    engine.check_count(plan, controllers)
    _check_plan(plan)
    triple, params, memory = device_controllers(plan, controllers)
    wp, mjw = load_warp()
    device = device_name(wp, device)
    state = new_state(len(plan), plan.n_links, memory.shape[1], 0, plan.n_motors)
    with wp.ScopedDevice(device):
        _check_room(wp, mjw, plan, params, memory, device)
        kernels = _kernels(wp, triple, plan.n_links)
        worlds = _Worlds(wp, mjw, plan, params, memory, device)
        interrupted = _advance(plan, worlds, kernels, state, progress, desc)
    return engine.stopped_outcome(state, None, interrupted, meta={"engine": "warp", "device": device})


def _device_bytes(wp, obj) -> int:
    """Bytes of the Warp arrays in ``obj`` and the dataclasses it holds (MuJoCo Warp's data)."""
    import dataclasses

    if isinstance(obj, wp.array):
        return obj.capacity
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return sum(_device_bytes(wp, getattr(obj, f.name)) for f in dataclasses.fields(obj))
    return 0


def world_bytes(wp, mjw, model, device) -> float:
    """The device memory of one more world of MuJoCo Warp's data of ``model`` [bytes]: that of two worlds less
    that of one, measured on ``device``."""
    copy = device_model(model)
    with wp.ScopedDevice(device):
        one, two = (_device_bytes(wp, device_data(mjw, copy, k)) for k in (1, 2))
    return float(two - one)


def _check_room(wp, mjw, plan, params, memory, device):
    """Refuse, in one line, worlds that would not fit in the device's free memory: MuJoCo Warp's data of a world
    (measured as that of two worlds less one) and this engine's rows, half as much again for the moment a packing
    holds both sets of worlds."""
    from ...limits import check_memory

    settings, links = plan.settings, plan.n_links
    engine_rows = 8 * (params.shape[1] + memory.shape[1] + settings.cert[0].size + settings.pushes[0].size
                       + 16 * links + 32)
    check_memory(1.5 * len(plan) * (world_bytes(wp, mjw, plan.models[0], device) + engine_rows),
                 f"{device} memory for {len(plan)} worlds",
                 "the worlds of one run (--chunk) or their number (--grid, --trials)",
                 budget=wp.get_device(device).free_memory, where="the device's free memory")


#: Worlds are packed when at most this fraction of them still runs (and at least :data:`PACK_MIN` are there).
PACK_WHEN = 0.5
PACK_MIN = 1024


class _Steps:
    """The step of every world (``control``, ``mujoco_warp.step``, ``after``), recorded once for a set of worlds:
    its launches with their arguments packed, and on a GPU a CUDA graph of :data:`GRAPH_STEPS` of them."""

    def __init__(self, plan, worlds, kernels):
        wp, mjw, w, d = worlds.wp, worlds.mjw, worlds, worlds.data
        control, after = kernels
        dt, n = float(plan.dt), len(w.rows)
        control_inputs = [d.qpos, d.qvel, d.ctrl, d.qfrc_applied, w.q, w.qd, w.seen, w.tau, w.u, w.force, w.params,
                          w.memory, w.limits, w.noise, w.delays, w.ids, w.delay_line, w.pushes, w.push_end, w.task,
                          w.cert, w.level, w.counts, w.sums, w.books, w.peak, w.last_tau, w.last_state,
                          int(plan.n_steps), dt, bool(plan.run.retire), int(plan.run.seed)]
        after_inputs = [d.qpos, d.qvel, w.q, w.qd, w.u, w.counts, w.sums, w.last_state, w.joints, dt]
        control_cmd = wp.launch(control, dim=n, inputs=control_inputs, record_cmd=True)
        after_cmd = wp.launch(after, dim=n, inputs=after_inputs, record_cmd=True)

        def one_step():
            control_cmd.launch()
            mjw.step(w.model, d)
            after_cmd.launch()

        self.wp, self.one_step, self.graph, self.first = wp, one_step, None, 0
        if wp.get_device().is_cuda:
            one_step()  # compiles every kernel before the capture (a capture records, it runs nothing)
            self.first = 1
            try:
                with wp.ScopedCapture() as capture:
                    for _ in range(GRAPH_STEPS):
                        one_step()
                self.graph = capture.graph
            except Exception:  # noqa: BLE001 - capture unsupported here: plain launches, the same numbers
                self.graph = None

    def advance(self, steps: int) -> int:
        """At least ``steps`` steps of every world (whole graphs on a GPU); the steps taken."""
        if self.graph is None:
            for _ in range(steps):
                self.one_step()
            return steps
        launches = -(-steps // GRAPH_STEPS)
        for _ in range(launches):
            self.wp.capture_launch(self.graph)
        return launches * GRAPH_STEPS  # extra steps of stopped worlds change nothing


def _advance(plan, worlds, kernels, state, progress, desc):
    """Step every world to the end (or until all stopped), packing the worlds still running into fewer as the
    others stop (a stopped world's step costs a running one's); each world's records into ``state`` as it leaves
    and at the end. Returns True if interrupted (Ctrl-C)."""
    n, dt = len(plan), float(plan.dt)
    total = plan.n_steps + 1  # controller evaluations: steps 0..n_steps
    bar = progress_bar(total=round(n * total * dt, 6), unit="s simulated", desc=desc, enabled=progress)
    steps = _Steps(plan, worlds, kernels)
    done, reported = steps.first, 0.0
    try:
        while done < total:
            done += steps.advance(min(SEGMENT, total - done))
            counts = worlds.counts.numpy()
            running = counts[:, COUNTS.index("status")] == RUNNING
            ran = np.where(running, counts[:, COUNTS.index("step")], plan.n_steps)
            packed_away = n - len(worlds.rows)  # stopped worlds no longer on the device, each counted whole
            now = round(float(np.sum(ran) + packed_away * plan.n_steps) * dt, 6)
            # the clock of the worlds still running, and how many: a stopped world counts whole in the total
            bar.set_description_str(f"{desc} (t = {min(done, total - 1) * dt:.1f} s, {int(running.sum())} running)")
            if now > reported:
                bar.update(now - reported)
                reported = now
            if not running.any():
                break
            if done < total and len(running) >= PACK_MIN and running.sum() <= PACK_WHEN * len(running):
                worlds.store(state)
                worlds = worlds.take(np.flatnonzero(running))
                steps = _Steps(plan, worlds, kernels)
                done += steps.first
    except KeyboardInterrupt:
        return True
    finally:
        worlds.store(state)
        bar.close()
    return False
