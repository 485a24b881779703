"""The engine's plans stepped through MuJoCo's batch API (``mujoco.batch.Batch``), for comparison with the engine.

:func:`run` runs a :class:`~paa_mj.sim.compiled.engine.Plan` as :func:`paa_mj.sim.compiled.engine.run` does, step by step over the
whole batch instead of rollout by rollout: every control step, one compiled loop over the running rollouts
evaluates their controllers (the engine's packed kernels, :func:`~paa_mj.sim.compiled.engine.pack`, called as the engine
calls them) and does everything of the step before the physics (:func:`~paa_mj.sim.compiled.step.before_physics`:
measurement noise, delay, torque noise, saturation, outcomes, samples, retirement, pushes); then
``Batch.step`` advances the rollouts still running by one ``mj_step`` each, on the batch's threads; then one
compiled loop does the rest of the step (:func:`~paa_mj.sim.compiled.step.after_physics`). The rollouts' plants are the
batch's per-simulation models (``Batch.set_models``), their states its state rows, written and read in place.

Same kernels, same order of operations within a rollout, counter-based noise (:mod:`paa_mj.sim.noise`) and
MuJoCo's batch bit-identical to one ``MjData`` per simulation: the outcome equals the engine's bit for bit
(:func:`agreement` measures it; ``paa-mj bench`` reports it, with the two costs' ratio). Only compiled
controllers run here.
"""
from __future__ import annotations

import os

import mujoco
import numpy as np
from numba import njit, types

from ...control.base import KERNEL_TYPE
from ...errors import PaaError
from ...jit import lazy_njit
from ...mujoco_log import mujoco_log_off
from .engine import RUNNING, Outcome, Plan, RunArrays, memory_size, packed_controllers
from .records import RUN_T, SAMPLES_T, SETTINGS_T, STATE_T, Physics
from .step import after_physics, before_physics, begin_rollout, call_controller, measure

__all__ = ["available", "run", "agreement"]


def available() -> bool:
    """Whether the installed MuJoCo has the batch API (``mujoco.batch``, MuJoCo 4 on)."""
    try:
        import mujoco.batch  # noqa: F401
    except ImportError:
        return False
    return True


# --- compiled: the batch's state rows as the engine's Physics records -----------------------------------------

@njit(cache=True)
def _physics(r, rows, at, warnings):
    """Rollout ``r``'s :class:`~paa_mj.sim.compiled.records.Physics`: views of its state row (qpos, qvel, ctrl,
    qfrc_applied at the offsets ``at``, sizes n, n, m, n) and of its warning counters (no model or data)."""
    row = rows[r]
    n, nu = at[4], at[5]
    return Physics(0, 0, row[at[0]:at[0] + n], row[at[1]:at[1] + n], row[at[2]:at[2] + nu], row[at[3]:at[3] + n],
                   warnings[r, :, 1])


_C1, _I1 = types.float64[::1], types.int64[::1]
_BEGIN_SIG = types.void(_I1, types.float64[:, ::1], _I1, types.int32[:, :, ::1], types.float64[:, ::1], STATE_T,
                        _C1)
_BEFORE_SIG = types.void(KERNEL_TYPE, KERNEL_TYPE, KERNEL_TYPE, _C1, _I1, types.int64, types.float64[:, ::1], _I1,
                         types.int32[:, :, ::1], RUN_T, SETTINGS_T, STATE_T, SAMPLES_T, types.int8[::1])
_AFTER_SIG = types.void(_I1, types.int64, types.float64[:, ::1], _I1, types.int32[:, :, ::1], RUN_T,
                        STATE_T, SAMPLES_T)


@lazy_njit(_BEGIN_SIG, cache=True)
def _begin(group, rows, at, warnings, x0, state, memory0):
    """Start the rollouts ``group`` (their rows reset): x0 into the rows, the records at their start."""
    for r in group:
        begin_rollout(r, _physics(r, rows, at, warnings), x0, state, memory0)


@lazy_njit(_BEFORE_SIG, cache=True)
def _before(first, second, condition, params, group, step, rows, at, warnings, run, settings, state, samples, go):
    """Step ``step`` of the running rollouts of ``group`` up to the physics: measure, the controller (as
    :func:`~paa_mj.sim.compiled.step.advance_compiled` calls it), :func:`~paa_mj.sim.compiled.step.before_physics`; ``go[r]`` = 1
    for those that go on to ``mj_step``, 0 for the others."""
    n = at[4]
    seen, tau = np.empty(2 * n), np.empty(at[5])
    for r in group:
        go[r] = 0
        if state.rollouts[r].status != RUNNING:
            continue
        physics = _physics(r, rows, at, warnings)
        measure(r, step, physics, run, settings, seen)
        mode = call_controller(first, second, condition, seen, step * run.dt, params, state.memory[r], tau)
        if not before_physics(r, step, mode, tau, physics, run, settings, state, samples):
            go[r] = 1


@lazy_njit(_AFTER_SIG, cache=True)
def _after(ids, step, rows, at, warnings, run, state, samples):
    """Step ``step`` of the rollouts ``ids`` after their ``mj_step``: :func:`~paa_mj.sim.compiled.step.after_physics`."""
    for r in ids:
        after_physics(r, step, _physics(r, rows, at, warnings), run, state, samples)


# --- Python: the batch, the loop over steps -------------------------------------------------------------------

def _offsets(batch, n_links, n_motors) -> np.ndarray:
    """Where qpos, qvel, ctrl and qfrc_applied start in a state row, then n and m (the motors)."""
    base = batch.state.__array_interface__["data"][0]
    start = [(batch.bind(name).__array_interface__["data"][0] - base) // batch.state.itemsize
             for name in ("qpos", "qvel", "ctrl", "qfrc_applied")]
    return np.array(start + [n_links, n_motors], np.int64)


def _groups(forms, keys):
    """(packed form, its rollouts) for each distinct controller of :func:`~paa_mj.sim.compiled.engine.packed_controllers`; a
    :class:`PaaError` for one without a compiled form (this path runs compiled controllers only)."""
    groups = {}
    for r, key in enumerate(keys):
        if forms[key] is None:
            raise PaaError(f"mujoco.batch runs compiled controllers only; rollout {r}'s has no compiled form")
        groups.setdefault(key, []).append(r)
    return [(forms[key], np.array(rows, np.int64)) for key, rows in groups.items()]


def _batch_of(plan, nthread):
    """A ``mujoco.batch.Batch`` of the plan's rollouts, each on its plant, reset (no forward pass, as the
    engine's ``mj_resetData``)."""
    if not available():
        raise PaaError(f"MuJoCo {mujoco.__version__} has no batch API (mujoco.batch); it needs MuJoCo 4 or later")
    from mujoco.batch import Batch

    batch = Batch(plan.models[0], len(plan), nthread=max(1, nthread or os.cpu_count() or 1))
    if len(plan.models) > 1:
        batch.set_models([plan.models[i] for i in plan.model_index])
    batch.reset(stage=mujoco.mjtStage.mjSTAGE_NONE)
    return batch


def run(plan: Plan, controllers, nthread=None) -> Outcome:
    """Run every rollout of ``plan`` through ``mujoco.batch.Batch``: the outcome of :func:`paa_mj.sim.compiled.engine.run`.

    Parameters
    ----------
    plan : Plan
        The rollouts (robot, task, plants, starts, disturbances, time step and length).
    controllers : list
        One controller per rollout (repeats allowed), each with a compiled form.
    nthread : int, optional
        The batch's threads for ``mj_step`` (default: all cores); the controllers run in the calling thread.

    Returns
    -------
    Outcome
        Each rollout's records and samples, as the engine's; ``interrupted`` after Ctrl-C.
    """
    n = len(plan)
    forms, keys = packed_controllers(plan, controllers)
    groups = _groups(forms, keys)
    batch = _batch_of(plan, nthread)
    run_ = plan.run
    arrays = RunArrays(plan, memory_size(forms))
    state, samples = arrays.state, arrays.samples
    rows, at, warnings = batch.state, _offsets(batch, plan.n_links, plan.n_motors), batch.warning
    for packed, group in groups:
        _begin(group, rows, at, warnings, plan.x0, state, packed.memory)
    go = np.zeros(n, np.int8)
    interrupted = False
    try:
        with mujoco_log_off():
            for step in range(run_.n_steps + 1):
                for packed, group in groups:
                    _before(packed.first, packed.second, packed.condition, packed.params, group, step, rows, at,
                            warnings, run_, plan.settings, state, samples, go)
                ids = np.flatnonzero(go)
                if not ids.size:
                    break
                batch.step(ids)
                _after(ids, step, rows, at, warnings, run_, state, samples)
    except KeyboardInterrupt:
        interrupted = True
    except mujoco.batch.SimulationError as error:
        raise PaaError(f"MuJoCo's batch failed: {error}") from None
    return arrays.outcome(plan, interrupted)


def _equal(x, y) -> bool:
    """Whether two arrays (structured ones field by field) are equal bit for bit, NaN equal to NaN."""
    if x.dtype.names is not None:
        return x.dtype == y.dtype and all(_equal(x[name], y[name]) for name in x.dtype.names)
    return np.array_equal(x, y, equal_nan=x.dtype.kind == "f")


def agreement(first: Outcome, second: Outcome) -> dict:
    """How two outcomes of one plan agree.

    Returns
    -------
    dict
        ``identical``: every record and sample equal, bit for bit (NaN equal to NaN); ``same_outcomes``: status,
        step, switch and the task's book of success equal for every rollout; ``max_abs_final_state_diff``: the
        largest difference of the final states.
    """
    a, b = first.state, second.state
    identical = all(_equal(x, y) for x, y in zip(a, b))
    if first.samples is not None or second.samples is not None:
        identical = identical and first.samples is not None and second.samples is not None and all(
            _equal(first.samples[k], second.samples[k]) for k in first.samples)
    same = all(np.array_equal(a.rollouts[k], b.rollouts[k]) for k in ("status", "step", "switch")) and \
        np.array_equal(a.book, b.book)
    return {"identical": bool(identical), "same_outcomes": bool(same),
            "max_abs_final_state_diff": float(np.max(np.abs(a.last_state - b.last_state), initial=0.0))}
