"""Studies over many initial conditions: the basin of the hybrid controller.

A grid of initial states over two chosen coordinates (the others zero) is run
through :func:`paa_mj.batch.simulate_batch`; each cell records the first switch
time (or never), whether the robot ended balanced at UDD, and the final V.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .distributed import run_rollouts
from .errors import PaaError
from .io import ensure_dir, write_json, write_npz
from .model import Robot

COORDINATES = ("q1", "q2", "q3", "d1", "d2", "d3")
#: Default range of each coordinate on the grid: angles over a full turn, speeds +-5 rad/s.
DEFAULT_RANGE = {"q1": (-np.pi, np.pi), "q2": (-np.pi, np.pi), "q3": (-np.pi, np.pi),
                 "d1": (-5.0, 5.0), "d2": (-5.0, 5.0), "d3": (-5.0, 5.0)}


def parse_axes(text: str) -> tuple[int, int]:
    names = [a.strip() for a in text.split(",")]
    if len(names) != 2 or any(n not in COORDINATES for n in names) or names[0] == names[1]:
        raise PaaError(f"--axes needs two different coordinates out of {', '.join(COORDINATES)}, got {text!r}")
    return COORDINATES.index(names[0]), COORDINATES.index(names[1])


def basin_grid(axes, grid):
    """Initial states (grid^2, 6) and the two axis value vectors."""
    if not (isinstance(grid, (int, np.integer)) and grid >= 2):
        raise PaaError(f"--grid must be an integer >= 2, got {grid}")
    i, j = axes
    xs = np.linspace(*DEFAULT_RANGE[COORDINATES[i]], grid)
    ys = np.linspace(*DEFAULT_RANGE[COORDINATES[j]], grid)
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    x0 = np.zeros((grid * grid, 6))
    x0[:, i], x0[:, j] = X.ravel(), Y.ravel()
    return x0, xs, ys


def basin(robot: Robot, axes=(0, 1), grid=64, t_final=30.0, gains=None, progress=False, scheduler="inline"):
    """Run the basin study; returns (summary dict, arrays dict).

    ``scheduler``: "inline", "local" (a local Dask cluster) or a Dask scheduler
    address; the results are identical whichever (:mod:`paa_mj.distributed`).
    """
    x0, xs, ys = basin_grid(axes, grid)
    result = run_rollouts(robot, x0, scheduler=scheduler, progress=progress, t_final=t_final, gains=gains)
    success = result.success()
    switched = result.switch_time[np.isfinite(result.switch_time)]
    summary = {
        "robot": robot.name, "axes": [COORDINATES[a] for a in axes], "grid": grid, "cells": int(grid * grid),
        "t_final": t_final, "t_reached": result.t_reached, "interrupted": result.interrupted,
        "completed_fraction": float(np.mean(result.meta["completed"])),
        "success_fraction": float(np.mean(success)),
        "switched_fraction": float(np.mean(np.isfinite(result.switch_time))),
        "diverged_fraction": float(np.mean(result.diverged)),
        "median_switch_time": float(np.median(switched)) if switched.size else None,
    }
    arrays = {"x_values": xs, "y_values": ys, **{k: np.asarray(v) for k, v in result.arrays().items()}}
    return summary, arrays


def write_basin(out_dir, summary, arrays):
    """basin.npz, basin.png and summary.json in ``out_dir``."""
    from .plots import plot_basin

    out = ensure_dir(out_dir)
    write_npz(out / "basin.npz", **arrays)
    plot_basin(summary, arrays, out / "basin.png")
    write_json(out / "summary.json", summary)
    return Path(out)


#: Levels of each robustness factor (the first is the nominal case).
ROBUSTNESS_FACTORS = {
    "noise": {"label": "measurement noise std on q [rad] and qd [rad/s]", "levels": [0.0, 0.01, 0.03, 0.1]},
    "torque_limit": {"label": "torque limit, fraction of the nominal peak |tau|", "levels": [np.inf, 1.0, 0.6, 0.3]},
    "model_error": {"label": "controller's masses and lengths off by [%]", "levels": [0.0, 2.0, 5.0, 10.0]},
    "delay": {"label": "control delay [ms]", "levels": [0.0, 2.0, 5.0, 10.0]},
}


def random_initial_states(trials, seed=0):
    """Angles uniform over a full turn, speeds uniform in +-1 rad/s."""
    rng = np.random.default_rng(seed)
    x0 = np.empty((trials, 6))
    x0[:, :3] = rng.uniform(-np.pi, np.pi, (trials, 3))
    x0[:, 3:] = rng.uniform(-1.0, 1.0, (trials, 3))
    return x0


def robustness(robot: Robot, trials=64, t_final=30.0, seed=0, gains=None, progress=False, scheduler="inline",
               model_error=None):
    """Success rate against each factor, every level run on the same ``trials`` random initial states.

    Success: under LQR and still inside region (68) at the end (noise keeps the
    state from settling to within 1e-3 of UDD, so "balanced" would be too strict).

    All (factor, level, trial) rollouts run in one batch. The torque limit is a
    fraction of the largest |tau| of the nominal swing-up from (65); the model
    error makes the controller believe masses and lengths scaled by (1 + e/100)
    and (1 - e/100) while MuJoCo simulates the true robot.
    """
    from .controllers import SwitchingController
    from .rollout import X0_HANGING, simulate_mujoco

    if not (isinstance(trials, (int, np.integer)) and trials >= 1):
        raise PaaError(f"--trials must be a positive integer, got {trials}")
    factors = {name: dict(spec) for name, spec in ROBUSTNESS_FACTORS.items()}
    if model_error is not None:
        if any(not (0 <= e < 100) for e in model_error):
            raise PaaError(f"--model-error percentages must lie in [0, 100), got {list(model_error)}")
        factors["model_error"]["levels"] = [float(e) for e in model_error]
    nominal_gains = robot.resolve_gains() if gains is None else gains
    nominal = simulate_mujoco(robot, SwitchingController.for_model(robot.analytic, **nominal_gains), X0_HANGING,
                              t_final)
    peak = float(np.max(np.abs(nominal.tau)))
    base = random_initial_states(trials, seed)
    dt = robot.model.opt.timestep
    x0, noise, limit, believed, delay, index = [], [], [], [], [], []
    for factor, spec in factors.items():
        for level_i, level in enumerate(spec["levels"]):
            for trial in range(trials):
                x0.append(base[trial])
                noise.append([level, level] if factor == "noise" else [0.0, 0.0])
                limit.append(level * peak if factor == "torque_limit" else np.inf)
                e = level / 100 if factor == "model_error" else 0.0
                believed.append(robot.params.scaled(1 + e, 1 - e) if e else robot.params)
                delay.append(int(round(level * 1e-3 / dt)) if factor == "delay" else 0)
                index.append((factor, level_i))
    g = [nominal_gains["kD"], nominal_gains["kP"], nominal_gains["kV"]]
    result = run_rollouts(robot, np.array(x0), scheduler=scheduler, progress=progress, t_final=t_final, gains=g,
                          controller_params=believed, torque_limit=np.array(limit), noise_std=np.array(noise),
                          delay_steps=np.array(delay), seed=seed)
    success = result.held
    summary = {"robot": robot.name, "trials": trials, "t_final": t_final, "seed": seed,
               "completed_fraction": float(np.mean(result.meta["completed"])),
               "success": "under LQR (67) and inside region (68) at t_final, without divergence",
               "nominal_peak_torque": peak, "interrupted": result.interrupted, "factors": {}}
    for factor, spec in factors.items():
        rates = []
        for level_i, level in enumerate(spec["levels"]):
            rows = [i for i, key in enumerate(index) if key == (factor, level_i)]
            rates.append({"level": None if not np.isfinite(level) else float(level),
                          "success_rate": float(np.mean(success[rows])),
                          "diverged_rate": float(np.mean(result.diverged[rows]))})
        summary["factors"][factor] = {"label": spec["label"], "levels": rates}
    return summary, {"x0": np.array(x0), "success": success, "diverged": result.diverged,
                     "switch_time": result.switch_time}


def write_robustness(out_dir, summary, arrays):
    from .plots import plot_robustness

    out = ensure_dir(out_dir)
    write_npz(out / "robustness.npz", **arrays)
    for factor, data in summary["factors"].items():
        plot_robustness(factor, data, summary, out / f"robustness_{factor}.png")
    write_json(out / "summary.json", summary)
    return Path(out)
