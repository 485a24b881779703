"""Studies over many initial conditions: the basin of the hybrid controller.

A grid of initial states over two chosen coordinates (the others zero) is run
through :func:`paa_mj.batch.simulate_batch`; each cell records the first switch
time (or never), whether the robot ended balanced at UDD, and the final V.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .batch import simulate_batch
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


def basin(robot: Robot, axes=(0, 1), grid=64, t_final=30.0, gains=None, progress=False):
    """Run the basin study; returns (summary dict, arrays dict)."""
    x0, xs, ys = basin_grid(axes, grid)
    result = simulate_batch(robot, x0, t_final, gains=gains, progress=progress)
    success = result.success()
    switched = result.switch_time[np.isfinite(result.switch_time)]
    summary = {
        "robot": robot.name, "axes": [COORDINATES[a] for a in axes], "grid": grid, "cells": int(grid * grid),
        "t_final": t_final, "t_reached": result.t_reached, "interrupted": result.interrupted,
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
