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


def bounded_minimum(func, low, high, xatol=1e-5, maxiter=500):
    """The minimum of a scalar ``func`` on [low, high]: (x, func(x)).

    Brent's bounded method, operation for operation as SciPy's ``minimize_scalar(method="bounded")``
    (``scipy.optimize._optimize._minimize_scalar_bounded``, SciPy 1.17, BSD-3-Clause; after Forsythe, Malcolm
    and Moler's ``fmin``): the same numbers, without importing ``scipy.optimize``, which costs a command half a
    second of CPU before it does anything.
    """
    sqrt_eps = np.sqrt(2.2e-16)
    golden_mean = 0.5 * (3.0 - np.sqrt(5.0))
    a, b = low, high
    fulc = a + golden_mean * (b - a)
    nfc, xf = fulc, fulc
    rat = e = 0.0
    x = xf
    fx = func(x)
    num = 1
    ffulc = fnfc = fx
    xm = 0.5 * (a + b)
    tol1 = sqrt_eps * np.abs(xf) + xatol / 3.0
    tol2 = 2.0 * tol1
    while np.abs(xf - xm) > (tol2 - 0.5 * (b - a)):
        golden = 1
        if np.abs(e) > tol1:  # a parabolic fit
            golden = 0
            r = (xf - nfc) * (fx - ffulc)
            q = (xf - fulc) * (fx - fnfc)
            p = (xf - fulc) * q - (xf - nfc) * r
            q = 2.0 * (q - r)
            if q > 0.0:
                p = -p
            q = np.abs(q)
            r = e
            e = rat
            if (np.abs(p) < np.abs(0.5 * q * r)) and (p > q * (a - xf)) and (p < q * (b - xf)):
                rat = (p + 0.0) / q
                x = xf + rat
                if ((x - a) < tol2) or ((b - x) < tol2):
                    si = np.sign(xm - xf) + ((xm - xf) == 0)
                    rat = tol1 * si
            else:
                golden = 1
        if golden:  # a golden-section step
            e = a - xf if xf >= xm else b - xf
            rat = golden_mean * e
        si = np.sign(rat) + (rat == 0)
        x = xf + si * np.maximum(np.abs(rat), tol1)
        fu = func(x)
        num += 1
        if fu <= fx:
            if x >= xf:
                a = xf
            else:
                b = xf
            fulc, ffulc = nfc, fnfc
            nfc, fnfc = xf, fx
            xf, fx = x, fu
        else:
            if x < xf:
                a = x
            else:
                b = x
            if (fu <= fnfc) or (nfc == xf):
                fulc, ffulc = nfc, fnfc
                nfc, fnfc = x, fu
            elif (fu <= ffulc) or (fulc == xf) or (fulc == nfc):
                fulc, ffulc = x, fu
        xm = 0.5 * (a + b)
        tol1 = sqrt_eps * np.abs(xf) + xatol / 3.0
        tol2 = 2.0 * tol1
        if num >= maxiter:
            break
    return xf, fx
