"""The rollout engine on MuJoCo Warp: N rollouts as N worlds of one device, the controller on the device too.

``engine="warp"`` of :func:`~paa_mj.sim.batch.simulate_batch` (``--engine warp`` of the studies) runs a
:class:`~paa_mj.sim.engine.Plan` here instead of :func:`paa_mj.sim.engine.run`, and returns the same
:class:`~paa_mj.sim.engine.Outcome`, so that every outcome, summary and file of a study is computed as before.
Each step of every world, on the device (a GPU, or Warp's CPU device):

1. a kernel evaluates the controller on the true state (its compiled form, :func:`~paa_mj.sim.step.call_controller`
   with its two laws and the switch, translated from the same Python the CPU engine compiles:
   :mod:`paa_mj.sim.translate`), saturates the torques at the rollout's limits into ``ctrl`` and keeps the
   rollout's records as :func:`paa_mj.sim.step.actuate` does (switch, the task's book of success, peak and last
   torques, smoothness, peak speed, the last good state), and stops a rollout that finished, retired
   (:func:`~paa_mj.sim.retirement.modal_bound`, translated too) or asked for a non-finite torque;
2. ``mujoco_warp.step`` advances every world (the robot's integrator and time step);
3. a kernel adds the step's effort and work and stops a world whose state is not finite or runs away, back at
   its last good state, as :func:`paa_mj.sim.step.finish_step` does.

On a GPU the steps are captured once in a CUDA graph and replayed; on the CPU device each kernel is launched
from Python (about 2 ms a step of Euler, 10 ms of RK4 on this package's CI machine, whatever the number of
worlds: a correctness check, not a fast path). MuJoCo Warp computes in float32: a rollout agrees with the CPU
engine's float64 to about 1e-6 over 200 steps, and the closed loop stays within float32 rounding of it until
the dynamics amplify the difference (``tests/test_warp.py`` states what it checks).

What runs here: the controllers whose compiled laws translate (:data:`DEVICE_LAWS`: ``vcl``, ``vc``,
``vcl-only`` and ``vc-only`` in the paper's closed forms (the gymnast at its folded goal), ``lqr``,
``passive``, switched by region (68), the ROA level or time), the nominal plant for every rollout (per-rollout
torque limits, disturbances (:class:`~paa_mj.sim.batch.Disturbances`: measurement and torque noise, the same
draws as the CPU engine's, delay, pushes) and controller parameters allowed), no recorded trajectories: anything
else is refused in one line before any work.
"""
from __future__ import annotations

import numpy as np

from ..control.base import check_binding, controller_name
from ..errors import PaaError
from ..progress import progress as progress_bar
from ..task import P_GOAL
from . import engine
from .records import new_state
from .step import FINISHED, MAX_SPEED, NONFINITE_STATE, NONFINITE_TORQUE, RETIRED, RUNAWAY, RUNNING, \
    STOPPED, call_controller
from .warp_device import device_name, load_warp

__all__ = ["DEVICE_LAWS", "device_controllers", "run"]

#: Steps between two looks from Python (progress, Ctrl-C, every rollout ended).
SEGMENT = 256
#: Steps captured in one CUDA graph.
GRAPH_STEPS = 64


def _device_laws():
    """The compiled kernels whose translation to Warp is tested, by the name of the controller they serve."""
    from ..control.combined import time_condition
    from ..control.energy import conventional_kernel, vcl_kernel
    from ..control.lqr import lqr_kernel
    from ..control.passive import passive_kernel
    from ..control.region import level_condition, region_condition

    return {vcl_kernel: "(40)", conventional_kernel: "(12)", lqr_kernel: "LQR (67)", passive_kernel: "passive",
            region_condition: "region (68)", level_condition: "ROA level", time_condition: "time",
            engine._never: "never"}


#: What ``--engine warp`` runs: the controllers whose laws have a device form (module docstring).
DEVICE_LAWS = ("vcl", "vc", "vcl-only", "vc-only", "lqr", "passive")
_REFUSAL = ("controller {name} has no law on the device (the warp engine runs vcl, vc, vcl-only and vc-only on the"
            " gymnast at its folded goal, lqr and passive on any robot); use --engine mujoco")


def device_controllers(plan: engine.Plan, controllers):
    """Each rollout's packed compiled form, checked to have a device law and to share its kernels with the others:
    (the kernels (first, second, condition), params (N, P), memory (N, S)); one-line refusals otherwise."""
    laws = _device_laws()
    packed, kernels = {}, None
    for controller in controllers:
        key = id(controller)
        if key in packed:
            continue
        check_binding(controller, plan.robot, plan.task)
        compiled = getattr(controller, "compiled", None)
        form = compiled() if callable(compiled) else None
        if form is None:
            raise PaaError(_REFUSAL.format(name=controller_name(controller)))
        p = engine.pack(form)
        triple = (p.first, p.second, p.condition)
        if any(k not in laws for k in triple):
            raise PaaError(_REFUSAL.format(name=controller_name(controller)))
        if kernels is not None and triple != kernels:
            raise PaaError("the warp engine runs one controller law for every rollout of a batch (gains and models"
                           " may differ): split the batch, or use --engine mujoco")
        kernels = triple
        packed[key] = p
    rows = [packed[id(c)] for c in controllers]
    width = max(p.params.size for p in rows)
    memory = max(p.memory.size for p in rows)
    params = np.zeros((len(rows), width))
    mem = np.zeros((len(rows), memory))
    for r, p in enumerate(rows):
        params[r, :p.params.size] = p.params
        mem[r, :p.memory.size] = p.memory
    return kernels, params, mem


def _check_plan(plan: engine.Plan):
    if len(plan.models) != 1:
        raise PaaError("the warp engine runs the nominal plant for every rollout (no plant model error yet): use"
                       " --engine mujoco")
    if plan.run.every:
        raise PaaError("the warp engine records no trajectories (record=False, or use --engine mujoco)")
    if plan.n_steps >= 2**31 - 1:
        raise PaaError(f"the warp engine counts steps in 32 bits: {plan.n_steps} steps are too many")


def device_model(model):
    """A copy of a plant's MjModel for MuJoCo Warp: MuJoCo's energy (not read by the engine) left off."""
    import mujoco

    copy = model.__copy__()
    copy.opt.enableflags &= ~int(mujoco.mjtEnableBit.mjENBL_ENERGY)
    return copy


_KERNELS = {}


def _kernels(wp, triple, n_links):
    """The two step kernels for a controller law (``triple`` of compiled kernels) and a chain of ``n_links``."""
    key = (id(wp), triple, n_links)
    if key in _KERNELS:
        return _KERNELS[key]
    from ..task import book_update
    from .noise import gaussian as noise_gaussian
    from .retirement import modal_bound
    from .step import apply_pushes
    from .translate import device_function

    size = 2 * n_links
    first, second, condition = (device_function(wp, k, state_size=size) for k in triple)
    law = device_function(wp, call_controller, bind={"first": first, "second": second, "condition": condition},
                          state_size=size)
    book = device_function(wp, book_update, state_size=size)
    bound = device_function(wp, modal_bound, state_size=size)
    gaussian = device_function(wp, noise_gaussian, real=wp.float64, state_size=size)
    push = device_function(wp, apply_pushes, state_size=size)

    @wp.kernel(module="unique", enable_backward=False)
    def control(qpos: wp.array2d(dtype=wp.float32), qvel: wp.array2d(dtype=wp.float32),
                ctrl: wp.array2d(dtype=wp.float32), qfrc: wp.array2d(dtype=wp.float32),
                params: wp.array2d(dtype=wp.float32), memory: wp.array2d(dtype=wp.float32),
                seen: wp.array2d(dtype=wp.float32), tau: wp.array2d(dtype=wp.float32),
                limits: wp.array2d(dtype=wp.float32), noise: wp.array2d(dtype=wp.float64),
                delays: wp.array(dtype=wp.int32), ids: wp.array(dtype=wp.int64),
                delay_line: wp.array3d(dtype=wp.float32), pushes: wp.array3d(dtype=wp.float32),
                push_end: wp.array(dtype=wp.float64), task: wp.array(dtype=wp.float32),
                cert: wp.array2d(dtype=wp.float32), level: wp.array(dtype=wp.float32),
                counts: wp.array2d(dtype=wp.int32), sums: wp.array2d(dtype=wp.float64),
                books: wp.array2d(dtype=wp.int32), peak: wp.array2d(dtype=wp.float32),
                last_tau: wp.array2d(dtype=wp.float32), last_state: wp.array2d(dtype=wp.float32),
                n_steps: wp.int32, dt: wp.float64, retire: wp.int32, seed: wp.int64):
        r = wp.tid()
        n = qpos.shape[1]
        nu = ctrl.shape[1]
        if counts[r, 1] != 0:  # status: not running
            for j in range(nu):
                ctrl[r, j] = wp.float32(0.0)
            return
        step = counts[r, 0]
        # measure: the state the controller sees, with the rollout's measurement noise
        for i in range(n):
            seen[r, i] = qpos[r, i]
            seen[r, n + i] = qvel[r, i]
        nq = noise[r, 0]
        nqd = noise[r, 1]
        if nq > wp.float64(0.0) or nqd > wp.float64(0.0):
            for i in range(n):
                seen[r, i] = wp.float32(wp.float64(seen[r, i]) + nq * gaussian(seed, ids[r], step, i))
                seen[r, n + i] = wp.float32(wp.float64(seen[r, n + i]) + nqd * gaussian(seed, ids[r], step, n + i))
        t = wp.float32(wp.float64(step) * dt)
        mode = law(seen[r], t, params[r], memory[r], tau[r])
        # _command: a non-finite torque -> all zero (and the rollout stops after its records); delay line; torque
        # noise; saturation
        finite = int(1)
        for j in range(nu):
            ctrl[r, j] = tau[r, j]
            if not wp.isfinite(tau[r, j]):
                finite = 0
        if finite == 0:
            for j in range(nu):
                ctrl[r, j] = wp.float32(0.0)
        delay = delays[r]
        if delay > 0:
            slot = step % (delay + 1)
            for j in range(nu):
                delay_line[r, slot, j] = ctrl[r, j]
                if step < delay:
                    ctrl[r, j] = wp.float32(0.0)
                else:
                    ctrl[r, j] = delay_line[r, (step - delay) % (delay + 1), j]
        if noise[r, 2] > wp.float64(0.0):
            for j in range(nu):
                ctrl[r, j] = wp.float32(wp.float64(ctrl[r, j]) + noise[r, 2] * gaussian(seed, ids[r], step, 2 * n + j))
        for j in range(nu):
            ctrl[r, j] = wp.min(wp.max(ctrl[r, j], -limits[r, j]), limits[r, j])
        # actuate: the records of step
        counts[r, 3] = mode
        if mode == 1 and counts[r, 2] < 0:
            counts[r, 2] = step
        book(task, qpos[r], qvel[r], step, books[r])
        smooth = wp.float64(0.0)
        for j in range(nu):
            peak[r, j] = wp.max(peak[r, j], wp.abs(ctrl[r, j]))
            change = wp.float64(ctrl[r, j]) - wp.float64(last_tau[r, j])
            smooth += change * change
        speed = sums[r, 3]
        for i in range(n):
            speed = wp.max(speed, wp.float64(wp.abs(qvel[r, i])))
            last_state[r, i] = qpos[r, i]
            last_state[r, n + i] = qvel[r, i]
        sums[r, 3] = speed
        if step > 0:
            sums[r, 2] = sums[r, 2] + smooth / (dt * dt)
        for j in range(nu):
            last_tau[r, j] = ctrl[r, j]
        if finite == 0:
            counts[r, 1] = NONFINITE_TORQUE
            return
        if retire != 0 and mode == 1 and level[r] > wp.float32(0.0) and wp.float64(step) * dt > push_end[r]:
            if bound(cert[r], qpos[r], qvel[r], task[P_GOAL:P_GOAL + n]) <= level[r]:
                counts[r, 1] = RETIRED
                return
        if step == n_steps:
            counts[r, 1] = FINISHED
            return
        if pushes.shape[1] > 0:
            push(r, wp.float32(wp.float64(step) * dt), pushes, qfrc[r])

    @wp.kernel(module="unique", enable_backward=False)
    def after(qpos: wp.array2d(dtype=wp.float32), qvel: wp.array2d(dtype=wp.float32), ctrl: wp.array2d(dtype=wp.float32),
              counts: wp.array2d(dtype=wp.int32), sums: wp.array2d(dtype=wp.float64), last_state: wp.array2d(dtype=wp.float32),
              dt: wp.float64):
        r = wp.tid()
        n = qpos.shape[1]
        nu = ctrl.shape[1]
        if counts[r, 1] != 0:
            # stopped (now or before): back at its last good state, where the CPU engine leaves it
            for i in range(n):
                qpos[r, i] = last_state[r, i]
                qvel[r, i] = last_state[r, n + i]
            return
        effort = wp.float64(0.0)
        power = wp.float64(0.0)
        for j in range(nu):
            c = wp.float64(ctrl[r, j])
            effort += c * c
            power += c * wp.float64(qvel[r, j + 1])
        sums[r, 0] = sums[r, 0] + effort * dt
        sums[r, 1] = sums[r, 1] + wp.abs(power) * dt
        status = int(0)
        for i in range(n):
            if not (wp.isfinite(qpos[r, i]) and wp.isfinite(qvel[r, i])):
                status = NONFINITE_STATE
        if status == 0:
            for i in range(n):
                if wp.abs(qvel[r, i]) > wp.float32(MAX_SPEED):
                    status = RUNAWAY
        if status != 0:
            counts[r, 1] = status
            for i in range(n):
                qpos[r, i] = last_state[r, i]
                qvel[r, i] = last_state[r, n + i]
            return
        counts[r, 0] = counts[r, 0] + 1

    _KERNELS[key] = (control, after)
    return control, after


class _Worlds:
    """The device arrays of one run: MuJoCo Warp's model and data, the controllers' parameters and the records."""

    def __init__(self, wp, mjw, plan, params, memory, device):
        n, links = len(plan), plan.n_links
        f32 = wp.float32
        model = device_model(plan.models[0])
        self.model = mjw.put_model(model)
        self.data = mjw.make_data(model, nworld=n)
        self.data.qpos.assign(plan.x0[:, :links].astype(np.float32))
        self.data.qvel.assign(plan.x0[:, links:].astype(np.float32))
        settings = plan.settings

        def put(array, dtype=f32):
            return wp.array(np.ascontiguousarray(array), dtype=dtype, device=device)

        self.params = put(params)
        self.memory = put(memory)
        self.seen = wp.zeros((n, 2 * links), dtype=f32, device=device)
        self.tau = wp.zeros((n, links - 1), dtype=f32, device=device)
        self.limits = put(settings.limits)
        rollouts = settings.rollouts
        self.noise = put(np.stack([rollouts["noise_q"], rollouts["noise_qd"], rollouts["torque_noise"]], 1),
                         wp.float64)
        self.delays = put(rollouts["delay"].astype(np.int32), wp.int32)
        self.ids = put(rollouts["id"].astype(np.int64), wp.int64)
        self.delay_line = wp.zeros((n, int(np.max(rollouts["delay"], initial=0)) + 1, links - 1), dtype=f32,
                                   device=device)
        self.pushes = put(settings.pushes.astype(np.float32))
        self.push_end = put(rollouts["push_end"], wp.float64)
        self.task = put(plan.run.task)
        self.cert = put(settings.cert)
        self.level = put(settings.rollouts["retire_level"])
        counts = np.zeros((n, 4), np.int32)
        counts[:, 2] = -1  # no switch yet
        self.counts = put(counts, wp.int32)
        self.sums = wp.zeros((n, 4), dtype=wp.float64, device=device)
        self.books = put(np.full((n, 3), -1, np.int32), wp.int32)
        self.peak = wp.zeros((n, links - 1), dtype=f32, device=device)
        self.last_tau = wp.zeros((n, links - 1), dtype=f32, device=device)
        self.last_state = put(plan.x0)

    def state(self, plan, memory_size):
        """The engine's :class:`~paa_mj.sim.records.State` of the run, read back."""
        n, links = len(plan), plan.n_links
        state = new_state(n, links, memory_size, 0)
        counts, sums = self.counts.numpy(), self.sums.numpy()
        rollouts = state.rollouts
        rollouts["step"], rollouts["status"], rollouts["switch"], rollouts["mode"] = counts.T.astype(np.int64)
        rollouts["effort"], rollouts["work"], rollouts["smooth"], rollouts["speed"] = sums.T
        state.book[:] = self.books.numpy()
        state.peak[:] = self.peak.numpy()
        state.last_tau[:] = self.last_tau.numpy()
        state.last_state[:] = self.last_state.numpy()
        state.memory[:, :memory_size] = self.memory.numpy()
        return state


def run(plan: engine.Plan, controllers, *, device=None, progress=False, desc="rollouts") -> engine.Outcome:
    """Run every rollout of ``plan`` on MuJoCo Warp (module docstring); the same :class:`~paa_mj.sim.engine.Outcome`
    as :func:`paa_mj.sim.engine.run`. ``device``: a Warp device name (default: :func:`device_name`'s)."""
    n = len(plan)
    if len(controllers) != n:
        raise PaaError(f"need one controller per rollout ({n}), got {len(controllers)}")
    _check_plan(plan)
    triple, params, memory = device_controllers(plan, controllers)
    wp, mjw = load_warp()
    device = device_name(wp, device)
    with wp.ScopedDevice(device):
        control, after = _kernels(wp, triple, plan.n_links)
        worlds = _Worlds(wp, mjw, plan, params, memory, device)
        interrupted = _advance(wp, mjw, plan, worlds, control, after, device, progress, desc)
        state = worlds.state(plan, memory.shape[1])
    running = state.rollouts["status"] == RUNNING
    state.rollouts["status"][running] = STOPPED
    return engine.Outcome(state, None, interrupted=interrupted or bool(running.any()),
                          meta={"engine": "warp", "device": device})


def _advance(wp, mjw, plan, worlds, control, after, device, progress, desc):
    """Step every world to the end (or until all stopped); returns True if interrupted (Ctrl-C)."""
    n = len(plan)
    w = worlds
    dt = float(plan.dt)
    retire = 1 if plan.run.retire else 0
    control_inputs = [w.data.qpos, w.data.qvel, w.data.ctrl, w.data.qfrc_applied, w.params, w.memory, w.seen, w.tau,
                      w.limits, w.noise, w.delays, w.ids, w.delay_line, w.pushes, w.push_end, w.task, w.cert, w.level,
                      w.counts, w.sums, w.books, w.peak, w.last_tau, w.last_state, int(plan.n_steps), dt, retire,
                      int(plan.run.seed)]
    after_inputs = [w.data.qpos, w.data.qvel, w.data.ctrl, w.counts, w.sums, w.last_state, dt]

    # launches recorded once: the arguments are packed once, not at every step
    control_cmd = wp.launch(control, dim=n, inputs=control_inputs, record_cmd=True)
    after_cmd = wp.launch(after, dim=n, inputs=after_inputs, record_cmd=True)

    def one_step():
        control_cmd.launch()
        mjw.step(w.model, w.data)
        after_cmd.launch()

    graph = None
    if wp.get_device(device).is_cuda:
        one_step()  # compiles every kernel before the capture
        try:
            with wp.ScopedCapture() as capture:
                for _ in range(GRAPH_STEPS):
                    one_step()
            graph = capture.graph
        except Exception:  # noqa: BLE001 - capture unsupported here: plain launches, the same numbers
            graph = None
        done = 1  # the step before the capture (a capture records, it runs nothing)
    else:
        done = 0
    total = plan.n_steps + 1  # controller evaluations: steps 0..n_steps
    bar = progress_bar(total=round(n * total * dt, 6), unit="s simulated", desc=desc, enabled=progress)
    reported = 0.0
    try:
        while done < total:
            segment = min(SEGMENT, total - done)
            if graph is not None:
                launches = -(-segment // GRAPH_STEPS)
                for _ in range(launches):
                    wp.capture_launch(graph)
                segment = launches * GRAPH_STEPS  # extra steps of stopped worlds change nothing
            else:
                for _ in range(segment):
                    one_step()
            done += segment
            counts = w.counts.numpy()
            status = counts[:, 1]
            steps = np.where(status == RUNNING, counts[:, 0], plan.n_steps)
            now = round(float(np.sum(steps)) * dt, 6)
            if now > reported:
                bar.update(now - reported)
                reported = now
            if not np.any(status == RUNNING):
                break
    except KeyboardInterrupt:
        return True
    finally:
        bar.close()
    return False
