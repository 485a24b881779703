"""The basin of a controller: outcomes over a grid of initial states in two coordinates.

A grid of initial states over two chosen coordinates (the others zero) runs
through :func:`~paa_mj.studies.runner.run_study`; each cell records the first
switch time (or never), whether the run succeeded by the task's definition, and how it
ended (:data:`OUTCOME_NAMES`).
"""
from __future__ import annotations

import numpy as np

from ..control.registry import ControllerSpec
from ..errors import PaaError
from ..provenance import text_sha256
from ..limits import check_memory, check_steps
from ..model.robot import Robot
from ..sim import verdict
from ..task import Task, as_task
from .runner import CHUNK, RolloutSet, applied_limit, engine_definition, peak_torques, run_study
from .settings import BASIN_MAX_GRID as MAX_GRID, BASIN_RANGE as DEFAULT_RANGE
from .store import ChunkStore, runs_done, study_key

#: How a rollout ended, by code.
OUTCOME_NAMES = ("success", "switched, no success", "never switched, stuck at DUU", "never switched", "diverged")
SUCCESS, LOST, STUCK_DUU, NEVER, DIVERGED = range(len(OUTCOME_NAMES))
#: The outcome code of a run not run (an interrupted study's; False in its ``completed`` mask).
NOT_RUN_CODE = -1
#: A final state within this distance of DUU (each coordinate, rad and rad/s) is "stuck at DUU".
DUU_TOL = verdict.DUU_TOL


def coordinates(n_links=3):
    """The names of a chain's state coordinates: q1..qn, d1..dn (for the gymnast q1, q2, q3, d1, d2, d3)."""
    return tuple(f"q{i + 1}" for i in range(n_links)) + tuple(f"d{i + 1}" for i in range(n_links))


def coordinate_range(name):
    """The default range of a coordinate on the grid: an angle over a full turn [rad], a speed +-5 rad/s."""
    return DEFAULT_RANGE["q1" if name.startswith("q") else "d1"]


def parse_axes(text: str, n_links=3) -> tuple[int, int]:
    names = [a.strip() for a in str(text).split(",")]
    allowed = coordinates(n_links)
    if len(names) != 2 or any(n not in allowed for n in names) or names[0] == names[1]:
        raise PaaError(f"--axes needs two different coordinates out of {', '.join(allowed)}, got {text!r}")
    return allowed.index(names[0]), allowed.index(names[1])


def basin_grid(axes, grid, n_links=3):
    """Initial states (grid^2, 2n) and the two axis value vectors."""
    if not (isinstance(grid, (int, np.integer)) and 2 <= grid <= MAX_GRID):
        raise PaaError(f"--grid must be an integer in [2, {MAX_GRID}], got {grid}")
    i, j = axes
    names = coordinates(n_links)
    xs = np.linspace(*coordinate_range(names[i]), grid)
    ys = np.linspace(*coordinate_range(names[j]), grid)
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    x0 = np.zeros((grid * grid, 2 * n_links))
    x0[:, i], x0[:, j] = X.ravel(), Y.ravel()
    return x0, xs, ys


def classify(result, task: Task) -> np.ndarray:
    """The outcome code of each rollout (:data:`OUTCOME_NAMES`); "stuck at DUU" only for the gymnast's folded goal,
    where DUU is the other limit of Theorem 1."""
    near_duu = verdict.near_duu(result.final_state, task)  # the words of every command (paa_mj.sim.verdict)
    switched = np.isfinite(result.switch_time)
    code = np.where(switched, LOST, np.where(near_duu, STUCK_DUU, NEVER))
    code = np.where(result.success, SUCCESS, code)
    return np.where(result.diverged, DIVERGED, code).astype(np.int8)


def basin(robot: Robot, axes: tuple[int, int] = (0, 1), grid: int = 64, t_final: float | None = None,
          controller: ControllerSpec | str = "vcl", *, task: Task | str | None = None, progress: bool = False,
          scheduler: str = "inline", out_dir=None, fresh: bool = False, chunk: int = CHUNK,
          torque_limit=None, engine: str = "mujoco", device: str | None = None) -> tuple[dict, dict]:
    """Run the basin study; returns (summary dict, arrays dict).

    ``task`` (a :class:`~paa_mj.task.Task` or a goal's name, default the folded task) is what the controller
    aims at and what success means; ``t_final`` defaults to its horizon. ``torque_limit`` [N m] (one value or
    one per motor) saturates every run, on top of the model's actuator ranges; the summary reports the peak
    torques applied.

    ``scheduler``: "inline", "local" (a local Dask cluster) or a Dask scheduler
    address; the results are identical whichever (:mod:`paa_mj.studies.runner`).
    With ``out_dir``, finished chunks are kept there and a rerun resumes. ``engine``, ``device``: MuJoCo on the CPU
    (default) or MuJoCo Warp (:func:`~paa_mj.sim.batch.simulate_batch`).
    """
    task = as_task(task, robot)
    t_final = task.horizon if t_final is None else t_final
    spec = ControllerSpec(controller, task=task) if isinstance(controller, str) else controller
    if spec.task is None:
        spec = spec.for_task(task)
    names = coordinates(robot.params.n_links)
    if not (len(axes) == 2 and all(isinstance(a, (int, np.integer)) and 0 <= a < len(names) for a in axes)
            and axes[0] != axes[1]):
        raise PaaError(f"axes must be two different coordinates out of {', '.join(names)} (indices 0 to"
                       f" {len(names) - 1}), got {axes!r}")
    if not (isinstance(grid, (int, np.integer)) and 2 <= grid <= MAX_GRID):
        raise PaaError(f"--grid must be an integer in [2, {MAX_GRID}], got {grid}")
    check_memory(grid * grid * 400.0, "basin results", "--grid")
    if scheduler in ("inline", "local"):
        check_steps(grid * grid * t_final / float(robot.model.opt.timestep), f"{grid * grid} rollouts of {t_final:g} s",
                    "--grid or --t-final", links=robot.params.n_links, runs=grid * grid)
    x0, xs, ys = basin_grid(axes, grid, robot.params.n_links)
    spec.build(robot)  # checks the gains, and that it is built for this task (one line), before any work
    rollouts = RolloutSet(x0, spec, task, torque_limit=torque_limit)
    key = study_key({"study": "basin", "robot": robot.xml, "axes": list(axes), "grid": grid, "t_final": t_final,
                     "chunk": chunk, **rollouts.definition(), **engine_definition(engine)})
    result = run_study(robot, rollouts, t_final, scheduler=scheduler, store=ChunkStore(out_dir, key, fresh, "basin"),
                       progress=progress, desc="basin", chunk=chunk, engine=engine, device=device)
    completed = result.meta["completed"]
    success = result.success
    switched = result.switch_time[np.isfinite(result.switch_time)]
    outcome = np.where(completed, classify(result, task), NOT_RUN_CODE).astype(np.int8)

    def fraction(mask):  # over the finished runs: an interrupted study says nothing of the others
        return float(np.mean(mask[completed])) if completed.any() else None

    summary = {
        "robot": robot.name, "robot_sha256": text_sha256(robot.xml), "controller": spec.short_name,
        "axes": [names[a] for a in axes], "grid": grid, **task.describe(),
        "cells": int(grid * grid), "t_final": t_final, "t_reached": result.t_reached,
        "interrupted": result.interrupted, **runs_done(completed),
        "success": fraction(success),
        "torque_limit": applied_limit(robot, torque_limit),
        "max_abs_tau": peak_torques(result.max_abs_tau, completed),
        "switched_fraction": fraction(np.isfinite(result.switch_time)),
        "diverged_fraction": fraction(result.diverged),
        "median_switch_time": float(np.median(switched)) if switched.size else None,
        "outcomes": {name: int(np.sum(outcome[completed] == code)) for code, name in enumerate(OUTCOME_NAMES)},
        **engine_definition(engine),
    }
    arrays = {"x_values": xs, "y_values": ys, **{k: np.asarray(v) for k, v in result.arrays().items()},
              "outcome": outcome, "completed": completed}
    return summary, arrays
