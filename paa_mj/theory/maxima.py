"""Maxima over angles: the bounds of Theorem 1 need them to 1e-4 or better.

- :func:`grid_maximum`: a coarse grid, then zoomed grids around its best points (cheap in one or two angles);
- :func:`branch_and_bound`: a certified maximum, the best value found and an upper bound within a relative
  tolerance of it, for functions with upper bounds on boxes (kD_min of (41) for any chain,
  :mod:`paa_mj.theory.bounds`).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Maximum:
    """A maximum: the best value found, where, and (when certified) an upper bound on the true maximum.

    Attributes
    ----------
    value : float
        The refined maximum: a value the function takes (at ``argmax``), so a lower bound of the true maximum.
    argmax : tuple of float
        Where it is attained.
    grid_value : float
        The best value on the grid or of the starting points, before refinement (<= value).
    upper : float
        An upper bound of the true maximum, certified by :func:`branch_and_bound` (NaN from a grid search,
        which certifies nothing).
    tol : float
        The relative tolerance asked for: the maximum is certified when ``upper - value <= tol * |value|``.
    method : str
        How it was found, in words.
    boxes : int
        Boxes the branch and bound bounded (0 for a grid).
    """

    value: float
    argmax: tuple
    grid_value: float
    upper: float = math.nan
    tol: float = math.nan
    method: str = "grid and zoomed grids (not certified)"
    boxes: int = 0

    @property
    def certified(self) -> bool:
        """``value <= max <= upper`` with ``upper - value <= tol * |value|`` (False from a grid)."""
        return bool(self.upper - self.value <= self.tol * abs(self.value))

    @property
    def gap(self) -> float:
        """``(upper - value) / |value|``: the relative accuracy the bracket certifies (NaN from a grid)."""
        return float((self.upper - self.value) / abs(self.value)) if self.value else math.inf

    def as_dict(self, name) -> dict:
        """``name``, ``name_at`` and, where certified or bracketed, ``name_upper``, ``name_certified``,
        ``name_tolerance`` (asked), ``name_gap`` (reached) and ``name_method``, for a JSON report."""
        data = {name: self.value, f"{name}_at": list(self.argmax), f"{name}_method": self.method}
        if not math.isnan(self.upper):
            data.update({f"{name}_upper": self.upper, f"{name}_certified": self.certified,
                         f"{name}_tolerance": self.tol, f"{name}_gap": self.gap})
        return data


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



#: Most bytes the live boxes of :func:`branch_and_bound` may take; beyond it the search stops with its bracket.
LIVE_BYTES = 400 * 2**20


def branch_and_bound(bound, lows, highs, value, x, refine, tol=1e-6, budget_s=math.inf, batch=1024, desc=None):
    """The maximum of f over the box [lows, highs], certified: best-first branch and bound.

    Each step halves the live boxes of highest upper bound (``batch`` of them, or an eighth of those alive if more)
    along their axis of largest score, bounds the halves, and drops every box whose bound is at most
    ``value + tol |value|``: f stays below it there. The best centre found is refined by ``refine`` when it beats
    ``value``. The search ends when no box is left: the maximum is certified,
    ``value <= max f <= upper <= value + tol |value|``; or when it has run ``budget_s`` CPU-seconds, or its live
    boxes would take more than :data:`LIVE_BYTES`: then ``upper``, the largest bound of a box left, is still an
    upper bound of f everywhere; a half keeps its box's bound where its own is larger, so ``upper`` only falls,
    and the best-first order makes it fall as far as the search goes.

    Parameters
    ----------
    bound : callable
        ``bound(centres, radii, target) -> (upper, values, scores)``: upper bounds of f on the boxes
        centres +- radii (K, d), f at the centres (K,), and each radius's share of the bound (K, d). A box whose
        bound is at most ``target`` will be dropped, so its bound may be a cheap one.
    lows, highs : array_like (d,)
    value, x : float, ndarray (d,)
        The best value known and where f takes it.
    refine : callable
        ``refine(point) -> (value, point)``: a local ascent.
    tol : float
        Relative tolerance of the certificate.
    budget_s : float
        CPU-seconds (of this process, all its threads) the search may take.
    desc : str, optional
        Shown, with the bracket, beside a progress bar on stderr (:func:`paa_mj.progress.progress`).

    Returns
    -------
    value, x, upper : float, ndarray, float
    boxes : int
        Boxes bounded.
    finished : bool
        No box left: ``upper`` is within ``tol`` of ``value``.
    """
    from ..progress import progress

    lows, highs = np.asarray(lows, float), np.asarray(highs, float)
    d = lows.size
    centres, radii = ((lows + highs) / 2)[None], ((highs - lows) / 2)[None]
    uppers, axes = np.array([np.inf]), np.argmax(radii, axis=1)
    dropped, boxes, live_cap = -np.inf, 0, max(batch, LIVE_BYTES // (8 * (2 * d + 2)))
    deadline = time.process_time() + budget_s
    bar = progress(desc=desc, unit="box", enabled=desc is not None)
    while uppers.size and uppers.size < live_cap and time.process_time() < deadline:
        pick = _best(uppers, max(batch, uppers.size // 8))
        keep = np.ones(uppers.size, bool)
        keep[pick] = False
        new_c, new_r = _halves(centres[pick], radii[pick], axes[pick])
        new_u, new_v, scores = bound(new_c, new_r, value + tol * abs(value))
        new_u = np.minimum(new_u, np.tile(uppers[pick], 2))  # a half's bound is also its box's
        boxes += new_u.size
        best = int(np.argmax(new_v))
        if new_v[best] > value:
            value, x = max((new_v[best], new_c[best]), refine(new_c[best]), key=lambda pair: pair[0])
        centres, radii = np.concatenate([centres[keep], new_c]), np.concatenate([radii[keep], new_r])
        uppers = np.concatenate([uppers[keep], new_u])
        axes = np.concatenate([axes[keep], np.argmax(scores, axis=1)])
        alive = uppers > value + tol * abs(value)
        if not alive.all():
            dropped = max(dropped, float(np.max(uppers[~alive])))
            centres, radii, uppers, axes = centres[alive], radii[alive], uppers[alive], axes[alive]
        if uppers.size:
            bar.set_description_str(f"{desc}: max in [{value:.7g}, {np.max(uppers):.7g}]", refresh=False)
        bar.update(new_u.size)
    bar.close()
    upper = max(dropped, value, float(np.max(uppers)) if uppers.size else -np.inf)
    return value, x, upper, boxes, not uppers.size


def _best(uppers, k):
    """The indices of the ``k`` largest ``uppers`` (all of them if there are no more)."""
    if k >= uppers.size:
        return np.arange(uppers.size)
    return np.argpartition(-uppers, k - 1)[:k]


def _halves(centres, radii, axes):
    """The two halves of each box centres +- radii, cut across its axis ``axes``: (centres, radii), the lower
    halves first."""
    rows = np.arange(len(axes))
    halves = radii.copy()
    halves[rows, axes] /= 2
    shift = np.zeros_like(halves)
    shift[rows, axes] = halves[rows, axes]
    return np.concatenate([centres - shift, centres + shift]), np.concatenate([halves, halves])


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
