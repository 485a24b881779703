"""RealAIGym's simulator on a Warp device: many rollouts of their protocols at once, the controller on the device.

``--engine warp`` of ``paa-mj realaigym`` runs each rollout of :mod:`paa_mj.realaigym.simulator` as one thread of a
Warp kernel (a GPU, or Warp's CPU device). The kernel holds no equation of its own: each step it calls the
translations to Warp (:mod:`paa_mj.sim.warp.translate`) of the functions the CPU's
:func:`~paa_mj.realaigym.simulator.rollout_compiled` calls, in the same order:

1. :func:`~paa_mj.realaigym.simulator.measure_or_reset`: the measurement (delay and noise) and the global test's reset;
2. the controller's compiled law (:func:`~paa_mj.sim.compiled.step.call_controller` with its two laws and the switch) and
   :func:`~paa_mj.realaigym.simulator.command`;
3. :func:`~paa_mj.realaigym.simulator.advance`: the motor (responsiveness, noise, saturation, pulses) and their RK4 step.

Unlike the engine on MuJoCo Warp, everything here is float64: their simulator is this package's own code, so the
device computes what the CPU computes, to the rounding of the device's ``sin``, ``cos`` and ``atan``
(``tests/test_realaigym_warp.py`` holds every kind of run to 1e-9 of the CPU's over 300 steps, and a robustness
protocol to the CPU's summary). Every rollout keeps its whole trajectory on the device (the delay reads back along it), so a
batch is refused in one line where it would not fit in the device's memory.

What runs here: the controllers whose compiled laws translate (:data:`~paa_mj.sim.warp.engine.DEVICE_LAWS`);
anything else is refused in one line before any work.
"""
# No ``from __future__ import annotations``: the kernel's annotations are Warp's array types, made at run time.
import numpy as np

from . import simulator as protocol
from ..sim.compiled.step import call_controller
from ..sim.warp.device import device_name, load_warp

__all__ = ["Rollouts", "run"]

#: Steps a thread runs between two looks from Python (progress, Ctrl-C).
SEGMENT = 250

_KERNELS = {}


class Rollouts:
    """The inputs of a batch of rollouts of their simulator over the times ``T`` (K,), one row each: the plants P
    (R, :func:`~paa_mj.realaigym.simulator.plant_constants`), the starts (R, 2n) and each rollout's disturbances (the
    keyword arguments of :meth:`paa_mj.realaigym.study.Runs.run`, already in steps and arrays)."""

    def __init__(self, n_links, T, dt):
        self.n, self.T, self.dt = n_links, np.ascontiguousarray(T, float), float(dt)
        self.rows = []

    def add(self, P, x0, delay_steps, sigma_meas, responsiveness, sigma_u, normals, perturbation, reset):
        """One rollout, with the arguments :func:`~paa_mj.realaigym.simulator.rollout_compiled` takes after X, U, T and dt
        (the normals, the pulses and the reset record None where the run has none)."""
        self.rows.append((np.asarray(P, float), np.asarray(x0, float), int(delay_steps),
                          np.asarray(sigma_meas, float), float(responsiveness), np.asarray(sigma_u, float), normals,
                          perturbation, reset))

    def __len__(self):
        return len(self.rows)


def _functions(wp, triple, n_links):
    """The step's functions on the device, float64, for a chain of ``n_links``: the law (``triple`` of compiled
    kernels switched by :func:`~paa_mj.sim.compiled.step.call_controller`), then measure_or_reset, command, advance."""
    from ..sim.warp.translate import device_function

    def translated(fn, bind=None):
        return device_function(wp, fn, bind=bind, real=wp.float64, state_size=2 * n_links)

    first, second, condition = (translated(k) for k in triple)
    law = translated(call_controller, {"first": first, "second": second, "condition": condition})
    return law, translated(protocol.measure_or_reset), translated(protocol.command), translated(protocol.advance)


def _kernel(wp, triple, n_links):
    key = (id(wp), triple, n_links)
    if key not in _KERNELS:
        _KERNELS[key] = _rollout_kernel(wp, *_functions(wp, triple, n_links))
    return _KERNELS[key]


def _rollout_kernel(wp, law, measure_or_reset, command, advance):
    """The kernel: steps k0..k1 - 1 of each rollout still running, the loop of
    :func:`~paa_mj.realaigym.simulator.rollout_compiled`; ``done`` counts each rollout's steps (fewer once it blew up, and
    ``stopped`` marks it so)."""
    F64, F64_3 = wp.array2d(dtype=wp.float64), wp.array3d(dtype=wp.float64)
    V64, I32 = wp.array(dtype=wp.float64), wp.array(dtype=wp.int32)

    @wp.kernel(module="unique", enable_backward=False)
    def rollouts(A: F64_3, P: F64, X: F64_3, U: F64_3, T: V64, dt: wp.float64, delays: I32, sigma_meas: F64,
                 responsiveness: V64, sigma_u: F64, normals: F64_3, noise_rows: I32, perturbation: F64_3,
                 pulse_rows: I32, pulses: I32, reset: F64, resetting: I32, params: F64, memory: F64, work: F64,
                 mass: F64_3, force: F64_3, x_meas: F64, seen: F64, u: F64, tau: F64, done: I32, stopped: I32,
                 k0: wp.int32, k1: wp.int32):
        r = wp.tid()
        if stopped[r] != 0:  # blew up in an earlier segment, perhaps at its last step
            return
        for k in range(k0, k1):
            normals_k = normals[noise_rows[r], k]
            if measure_or_reset(A[r], P[r], X[r], k, T, delays[r], sigma_meas[r], normals_k, reset[r],
                                resetting[r] != 0, x_meas[r], seen[r], u[r], work[r]):
                law(seen[r], T[k], params[r], memory[r], tau[r])
                command(P[r], u[r], tau[r])
            if not advance(A[r], P[r], X[r], U[r], k, T, dt, u[r], responsiveness[r], sigma_u[r], normals_k,
                           perturbation[pulse_rows[r]], pulses[r], work[r], mass[r], force[r]):
                done[r] = k + 1
                stopped[r] = 1
                return
        done[r] = k1

    return rollouts


def _stacked(arrays, shape):
    """``arrays`` of the same ``shape`` (None: zeros) as one array whose row 0 is zeros, and each one's row."""
    distinct, rows = [np.zeros(shape)], []
    for a in arrays:
        if a is None:
            rows.append(0)
        else:
            rows.append(len(distinct))
            distinct.append(np.broadcast_to(np.asarray(a, float), shape))
    return np.ascontiguousarray(np.stack(distinct)), np.array(rows, np.int32)


def _inputs(batch: Rollouts, params, memory):
    """The kernel's arrays (host side, in its argument order) for ``batch``; ``params``, ``memory``: the packed
    controller's, the same for every rollout."""
    n, R, steps = batch.n, len(batch), len(batch.T) - 1
    cols = list(zip(*batch.rows))
    P = np.stack(cols[0])
    X = np.full((R, steps + 1, 2 * n), np.nan)
    X[:, 0] = np.stack(cols[1])
    normals, noise_rows = _stacked(cols[6], (steps, 5 * n))
    pulse_width = max([p.shape[1] for p in cols[7] if p is not None], default=1)
    padded = [None if p is None else np.pad(p, ((0, 0), (0, pulse_width - p.shape[1]))) for p in cols[7]]
    perturbation, pulse_rows = _stacked(padded, (n, pulse_width))
    pulses = np.array([0 if p is None else p.shape[1] for p in cols[7]], np.int32)
    resetting = np.array([w is not None for w in cols[8]], np.int32)
    width = max([w.size for w in cols[8] if w is not None], default=1)
    reset = np.stack([np.zeros(width) if w is None else np.asarray(w, float) for w in cols[8]])
    work, mass, force = protocol.scratch(n)
    return dict(
        A=np.stack([protocol.inertia_constants(p, n) for p in P]), P=P, X=X, U=np.full((R, steps, n), np.nan),
        T=batch.T, dt=batch.dt, delays=np.array(cols[2], np.int32),
        sigma_meas=np.stack(cols[3]), responsiveness=np.array(cols[4], float), sigma_u=np.stack(cols[5]),
        normals=normals, noise_rows=noise_rows, perturbation=perturbation, pulse_rows=pulse_rows, pulses=pulses,
        reset=reset, resetting=resetting, params=np.tile(params, (R, 1)), memory=np.tile(memory, (R, 1)),
        work=np.zeros((R, work.size)), mass=np.zeros((R,) + mass.shape), force=np.zeros((R,) + force.shape),
        x_meas=np.zeros((R, 2 * n)), seen=np.zeros((R, 2 * n)), u=np.zeros((R, n)),
        tau=np.zeros((R, protocol.motors(P[0], n))),
        done=np.zeros(R, np.int32), stopped=np.zeros(R, np.int32))


def _check_room(wp, arrays, device):
    from ..limits import check_memory

    nbytes = sum(a.nbytes for a in arrays.values() if isinstance(a, np.ndarray))
    check_memory(nbytes, f"{device} memory for {len(arrays['P'])} rollouts of {arrays['X'].shape[1] - 1} steps",
                 "the number of rollouts", budget=wp.get_device(device).free_memory, where="the device's free memory")


def run(batch: Rollouts, packed, name, *, device=None, advanced=None):
    """Every rollout of ``batch`` with the packed compiled controller ``packed`` (:func:`paa_mj.sim.compiled.engine.pack`,
    whose law must have a device form; ``name``: the controller's, for a refusal): the states X (R, K, 2n) and the
    applied torques U (R, K - 1, n), NaN past each rollout's end, the steps each ran (R,) and whether Ctrl-C stopped
    the batch. ``advanced(steps)`` is told of the rollouts' steps after each :data:`SEGMENT`."""
    from ..sim.warp.engine import device_law

    triple = device_law(packed, name, instead="--engine cpu")
    wp, _ = load_warp(mujoco=False)
    device = device_name(wp, device)
    arrays = _inputs(batch, packed.params, packed.memory)
    steps = len(batch.T) - 1
    interrupted = False
    with wp.ScopedDevice(device):
        _check_room(wp, arrays, device)
        kernel = _kernel(wp, triple, batch.n)
        inputs = [wp.array(v, dtype=_dtype(wp, v), device=device) if isinstance(v, np.ndarray) else v
                  for v in arrays.values()]
        on_device = dict(zip(arrays, inputs))
        try:
            for k0 in range(0, steps, SEGMENT):
                k1 = min(k0 + SEGMENT, steps)
                wp.launch(kernel, dim=len(batch), inputs=inputs + [k0, k1])
                wp.synchronize_device(device)
                if advanced is not None:
                    advanced(len(batch) * (k1 - k0))
        except KeyboardInterrupt:
            interrupted = True
        X, U, done = (on_device[k].numpy() for k in ("X", "U", "done"))
    return X, U, done, interrupted


def _dtype(wp, array):
    return wp.int32 if array.dtype == np.int32 else wp.float64
