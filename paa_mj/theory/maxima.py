"""Maxima over angles by a coarse grid and zoomed grids: the bounds of Theorem 1 need them to 1e-4 or better."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Maximum:
    """A maximum found by grid search and local refinement.

    Attributes
    ----------
    value : float
        The refined maximum.
    argmax : tuple of float
        Where it is attained.
    grid_value : float
        The best value on the grid, before refinement (<= value).
    """

    value: float
    argmax: tuple
    grid_value: float


def _evaluate(fun, mesh):
    """``fun`` on a grid, its non-finite values no candidates for the maximum.

    The functions of (59) and (60) are 0/0 where Phi or beta2bar vanishes (y = pi with b1 = beta2bar(z);
    z = pi with b2 = b3), and bounded near those points; in floating point, sin(pi) = 1.2e-16 turns the 0/0
    into +-inf or NaN.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        values = np.asarray(fun(*mesh), dtype=float)
    return np.where(np.isfinite(values), values, -np.inf)


def grid_maximum(fun, bounds, n=(121, 121), periodic=None, n_starts=6, zoom=21, tol=1e-11):
    """Maximise ``fun`` over a box: a coarse grid, then zoomed grids around its best local maxima.

    The coarse grid finds the peaks; around each of the ``n_starts`` best (distinct) grid
    maxima, a ``zoom``-point grid per coordinate over +-1 coarse cell is evaluated, recentred
    on its best point and shrunk to +-1 of its own cells, until the cells are below ``tol``
    (radians). Every step is one vectorised evaluation, so a maximum costs a few thousand
    evaluations in a handful of NumPy calls; the value is exact to rounding for smooth
    functions (the error falls with the square of the final cell).

    Parameters
    ----------
    fun : callable
        Vectorised: takes one array per coordinate (same shape) and returns values.
    bounds : sequence of (low, high)
    n : sequence of int
        Coarse grid points per coordinate.
    periodic : sequence of bool, optional
        Coordinates that wrap (the zoomed grids may cross their bounds).
    n_starts : int
        How many coarse local maxima to refine.
    """
    dim = len(bounds)
    periodic = periodic or (False,) * dim
    axes = [np.linspace(lo, hi, k) for (lo, hi), k in zip(bounds, n)]
    values = _evaluate(fun, np.meshgrid(*axes, indexing="ij"))
    order = np.argsort(values, axis=None)[::-1]
    starts, taken = [], np.zeros(values.shape, bool)
    for flat in order:
        idx = np.unravel_index(flat, values.shape)
        if taken[idx]:
            continue
        starts.append(idx)
        # Skip the neighbourhood of a start: refinements from next-door cells find the same peak.
        window = tuple(slice(max(0, i - 3), i + 4) for i in idx)
        taken[window] = True
        if len(starts) == n_starts:
            break
    grid_value = float(values[starts[0]])
    best_value, best_x = grid_value, np.array([axes[d][starts[0][d]] for d in range(dim)])
    cells = np.array([(hi - lo) / (k - 1) for (lo, hi), k in zip(bounds, n)])
    lows, highs = np.array([b[0] for b in bounds]), np.array([b[1] for b in bounds])
    offsets = np.linspace(-1.0, 1.0, zoom)
    for idx in starts:
        centre, half = np.array([axes[d][idx[d]] for d in range(dim)]), cells.copy()
        value = float(values[idx])
        while np.max(half) > tol:
            grids = [centre[d] + half[d] * offsets for d in range(dim)]
            grids = [g if periodic[d] else np.clip(g, lows[d], highs[d]) for d, g in enumerate(grids)]
            mesh = np.meshgrid(*grids, indexing="ij")
            local = _evaluate(fun, mesh)
            best = np.unravel_index(int(np.argmax(local)), local.shape)
            if local[best] >= value:
                value, centre = float(local[best]), np.array([mesh[d][best] for d in range(dim)])
            half = half * 2.0 / (zoom - 1)
        if value > best_value:
            best_value, best_x = value, centre
    best_x = tuple(float(lo + (x - lo) % (hi - lo)) if p else float(x)
                   for x, (lo, hi), p in zip(best_x, bounds, periodic))
    return Maximum(best_value, best_x, grid_value)
