"""Maxima over angles by a grid refined by Nelder-Mead: the bounds of Theorem 1 need them to 1e-4 or better."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import optimize


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


def grid_maximum(fun, bounds, n=(401, 401), periodic=None, n_starts=6):
    """Maximise ``fun`` over a box: a grid, then Nelder-Mead from the best local maxima.

    Parameters
    ----------
    fun : callable
        Vectorised: takes one array per coordinate (same shape) and returns values.
    bounds : sequence of (low, high)
    n : sequence of int
        Grid points per coordinate.
    periodic : sequence of bool, optional
        Coordinates on which the refinement may wander past the bounds.
    n_starts : int
        How many grid local maxima to refine.
    """
    dim = len(bounds)
    periodic = periodic or (False,) * dim
    axes = [np.linspace(lo, hi, k) for (lo, hi), k in zip(bounds, n)]
    mesh = np.meshgrid(*axes, indexing="ij")
    values = np.asarray(fun(*mesh), dtype=float)
    values = np.where(np.isfinite(values), values, -np.inf)
    order = np.argsort(values, axis=None)[::-1]
    starts, taken = [], np.zeros(values.shape, bool)
    for flat in order:
        idx = np.unravel_index(flat, values.shape)
        if taken[idx]:
            continue
        starts.append(idx)
        # Skip the neighbourhood of a start: refinements from next-door cells find the same peak.
        window = tuple(slice(max(0, i - 5), i + 6) for i in idx)
        taken[window] = True
        if len(starts) == n_starts:
            break
    grid_value = float(values[starts[0]])
    best_value, best_x = grid_value, tuple(float(axes[d][starts[0][d]]) for d in range(dim))
    local_bounds = [(None, None) if p else b for b, p in zip(bounds, periodic)]

    def negative(x):
        v = fun(*[np.asarray(xi) for xi in x])
        return -float(v) if np.isfinite(v) else np.inf

    for idx in starts:
        x0 = np.array([axes[d][idx[d]] for d in range(dim)])
        res = optimize.minimize(negative, x0, method="Nelder-Mead", bounds=local_bounds,
                                options={"xatol": 1e-12, "fatol": 1e-13 * max(1.0, abs(grid_value)),
                                         "maxiter": 4000})
        if -res.fun > best_value:
            best_value, best_x = float(-res.fun), tuple(float(v) for v in res.x)
    best_x = tuple(lo + (x - lo) % (hi - lo) if p else x
                   for x, (lo, hi), p in zip(best_x, bounds, periodic))
    return Maximum(best_value, best_x, grid_value)


