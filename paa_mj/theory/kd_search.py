"""kD_min of (41) for any chain and goal, certified by a branch and bound over the actuated angles.

kD_min is the maximum over the (n - 1)-torus of f(x) = (E_r + mu(x)) lambda_max((B^T M^-1 B)^-1) (41), (42), x the
absolute angles of links 2..n from link 1 (:mod:`paa_mj.theory.bounds` states the function and its bounds on
boxes). :func:`kd_min_search` finds it in two steps:

1. a value: f at the best of a set of postures (straight, L shapes, random), refined by Newton's method; a value
   of f, so ``value <= kD_min``;
2. a certificate: the branch and bound of :func:`~paa_mj.theory.maxima.branch_and_bound` over
   [0, pi] x [-pi, pi]^(n - 2) (f is even), with the bounds of :func:`~paa_mj.theory.bounds.box_bounds`, proves
   ``kD_min <= upper``; certified when ``upper - value <= tol |value|``.

The boxes it needs grow about fivefold per link (:func:`estimated_cpu_s`): under a second at 6 links, 15 to 30
CPU-seconds at 8, two to three minutes at 9 (on two threads, half that in wall time; docs/model.md has the measured
costs). Past its budget
(:data:`BUDGET_CPU_S`) the search stops with the bracket ``value <= kD_min <= upper``: every kD > upper is still
singularity-free. A chain whose certificate is estimated at more than :data:`HOPELESS` budgets skips the search:
its ``upper`` is the global bound
(E_r + sum_k b_k)^+ lambda_global.
"""
from __future__ import annotations

import contextlib
import dataclasses
import json
import math
import os
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from ..errors import PaaError
from ..io import write_json
from ..limits import MAX_SECONDS, duration
from ..provenance import cache_key, cache_root
from .bounds import box_bounds, centre_matrices, gradient, values_into
from .maxima import Maximum, branch_and_bound

#: Relative tolerance of the certificate (Theorem 1 needs 1e-4 or better; 1e-6 costs about the same).
TOL = 1e-6
#: CPU-seconds the search may take (all threads; about a minute and a half of wall time on 2 cores).
BUDGET_CPU_S = 200.0
#: A chain whose certificate is estimated at more than this many budgets gets the global bound, without a search.
HOPELESS = 20.0
_BUDGET = {"cpu_s": BUDGET_CPU_S}


def default_budget() -> float:
    """CPU-seconds a search for kD_min takes where its caller names none: :data:`BUDGET_CPU_S`, or what
    :func:`search_budget` set for the process (every command's ``--kd-budget``)."""
    return _BUDGET["cpu_s"]


@contextlib.contextmanager
def search_budget(cpu_s: float | None):
    """Within the block, every search for kD_min that names no budget of its own takes ``cpu_s`` CPU-seconds at
    most (None: :data:`BUDGET_CPU_S`); at it the search stops with its certified bracket."""
    previous = _BUDGET["cpu_s"]
    _BUDGET["cpu_s"] = BUDGET_CPU_S if cpu_s is None else float(cpu_s)
    try:
        yield
    finally:
        _BUDGET["cpu_s"] = previous
METHOD = "a branch and bound over the actuated angles"


class BoundFunction:
    """f of (41) for one robot and goal energy E_r [J]: its values, its bounds on boxes (over ``threads`` threads)
    and its local maxima, the kernels of :mod:`~paa_mj.theory.bounds` with the robot's constants."""

    def __init__(self, am, E_r, threads=1):
        p = am.params
        n = p.n_links
        self.A, self.b = np.ascontiguousarray(am.inertia_constants), np.ascontiguousarray(am.gravity_constants)
        self.arm, self.mass = np.asarray(p.armature, float), np.asarray(p.m, float)
        self.gam = np.tril(np.broadcast_to(np.asarray(p.l, float), (n, n)), -1)  # com velocity of link k:
        self.gam[np.arange(n), np.arange(n)] = p.lc  # sum_{i<k} l_i u_i e^{i phi_i} + lc_k u_k e^{i phi_k}
        self.E_r, self.n, self.threads = float(E_r), n, max(1, int(threads))
        self.lam_global = self._global_lambda()

    def _global_lambda(self):
        """A bound of lambda_max(S) at every posture: S <= N_p = P^T M P, and |v^T N_p v| <= |v|^T (|Y|^T A |Y| +
        |P|^T diag(armature) |P|) |v| (A >= 0 entrywise, Y = T P), with p = -M_a1 / M_11 of the straight chain."""
        M, _ = centre_matrices(self.A, self.arm, np.zeros(self.n - 1))
        P = np.vstack([-M[0, 1:] / M[0, 0], np.eye(self.n - 1)])
        Y, P = np.abs(np.cumsum(P, axis=0)), np.abs(P)
        return float(np.linalg.eigvalsh(Y.T @ self.A @ Y + P.T @ (self.arm[:, None] * P))[-1])

    def global_bound(self) -> float:
        """f <= (E_r + sum_k b_k)^+ lambda_global at every posture (mu <= sum_k b_k)."""
        return max(self.E_r + float(np.sum(self.b)), 0.0) * self.lam_global

    def values(self, X):
        """f at each row of X (K, n - 1) [J kg m^2]."""
        out = np.empty(len(X))
        values_into(self.A, self.b, self.arm, self.E_r, np.ascontiguousarray(X, dtype=float), out)
        return out

    def bound(self, centres, radii, target):
        """Upper bounds of f on the boxes centres +- radii, f at their centres, the split scores (K, d)."""
        upper, value, score = np.empty(len(centres)), np.empty(len(centres)), np.empty(centres.shape)
        args = (self.A, self.b, self.arm, self.mass, self.gam, self.E_r, self.lam_global)
        chunks = np.array_split(np.arange(len(centres)), self.threads if len(centres) >= 64 else 1)

        def run(rows):
            if rows.size:
                s = slice(rows[0], rows[-1] + 1)
                box_bounds(*args, centres[s], radii[s], float(target), upper[s], value[s], score[s])

        if len(chunks) == 1:
            run(chunks[0])
        else:
            with ThreadPoolExecutor(len(chunks)) as pool:  # the kernel releases the GIL
                list(pool.map(run, chunks))
        return upper, value, score

    def ascend(self, x, iters=40, step=1e-5):
        """A local maximum from x by Newton's method on the exact gradient (the Hessian by its differences;
        negative curvature clipped, halving the step until f does not fall): (f, x)."""
        x = np.array(x, float)
        f, g = gradient(self.A, self.b, self.arm, self.E_r, x)
        eye = np.eye(x.size) * step
        for _ in range(iters):
            H = np.array([gradient(self.A, self.b, self.arm, self.E_r, x + e)[1]
                          - gradient(self.A, self.b, self.arm, self.E_r, x - e)[1] for e in eye]) / (2 * step)
            w, Q = np.linalg.eigh(0.5 * (H + H.T))
            move = -Q @ ((Q.T @ g) / np.minimum(w, -1e-3 * max(np.max(np.abs(w)), 1e-300)))
            for _ in range(40):
                f_new, g_new = gradient(self.A, self.b, self.arm, self.E_r, x + move)
                if f_new >= f:
                    break
                move /= 2
            else:
                break
            x, f, g = x + move, f_new, g_new
            if np.max(np.abs(move)) < 1e-13:
                break
        return float(f), x


def starting_postures(d, rng):
    """Postures to start the search from (absolute angles, d = n - 1): straight, the L shapes (the links from some
    k on turned by one angle, the shape of the maxima found) and random ones."""
    shapes = [np.zeros(d)]
    for k in range(d):
        for angle in np.linspace(np.pi / 8, np.pi, 8):
            shapes.append(np.where(np.arange(d) >= k, angle, 0.0))
    count = min(4096, 64 * 2**d) if d <= 20 else 512
    return np.vstack([np.array(shapes), rng.uniform(-np.pi, np.pi, (count, d))])


def estimated_cpu_s(n_links) -> float:
    """The CPU-seconds :func:`kd_min_search` is estimated to need for a certificate of an n-link chain.

    Measured on this project's 2-core machine over uniform and random chains (masses 0.5-30 kg, lengths 0.2-2 m,
    both goals): about 1e5 boxes at 7 links, growing about fivefold per link, each costing about
    3 + 0.35 n^2 microseconds; a chain may need a few times more or less.
    """
    boxes = 1.2e5 * 5.0 ** (n_links - 7)
    return boxes * (3.0 + 0.35 * n_links**2) * 1e-6


def search_threads() -> int:
    """Threads for the bounds: numba's thread count (``NUMBA_NUM_THREADS``, by default the machine's cores)."""
    from numba import config

    return max(1, min(int(config.NUMBA_NUM_THREADS), len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity")
                      else os.cpu_count() or 1))


def kd_min_search(am, E_r, tol=TOL, budget_cpu_s=None, desc=None) -> Maximum:
    """kD_min of (41) for the goal energy ``E_r`` [J]: a value, an upper bound and whether they certify it.

    Parameters
    ----------
    am : AnalyticModel
    E_r : float
        The goal's energy [J].
    tol : float
        Relative tolerance: certified when ``upper - value <= tol |value|``.
    budget_cpu_s : float, optional
        CPU-seconds the branch and bound may take (see the module's docstring; default :func:`default_budget`).
    desc : str, optional
        A progress bar on stderr with this description, and the bracket, while the search runs.

    Returns
    -------
    Maximum
        ``value`` (a value of f, at ``argmax``: the actuated angles q2..qn in [0, 2 pi)), ``upper`` (certified:
        kD_min <= upper), ``tol``, ``method``, ``boxes``; ``grid_value`` is the best starting posture's value.
    """
    budget_cpu_s = default_budget() if budget_cpu_s is None else float(budget_cpu_s)
    f = BoundFunction(am, E_r, threads=search_threads())
    d = am.n_links - 1
    starts = starting_postures(d, np.random.default_rng(0))
    values = f.values(starts)
    value, x = max((f.ascend(starts[i]) for i in np.argsort(values)[::-1][:4 if d <= 20 else 2]),
                   key=lambda pair: pair[0])
    boxes, upper, method = 0, f.global_bound(), METHOD
    need = estimated_cpu_s(am.n_links)
    if upper <= 0.0:  # E_r + mu <= 0 at every posture: f <= 0
        method = "E_r + sum_k b_k <= 0: f <= 0 everywhere, so kD_min <= 0"
    elif need > HOPELESS * budget_cpu_s:
        method = (f"Newton's method from {len(starts)} postures and the global bound, no search: a certificate would"
                  f" take about {duration(need)} of CPU" + (" (give it that budget: --kd-budget)"
                                                           if need <= MAX_SECONDS else
                                                           ", beyond the day a command may take"))
    else:
        lows, highs = np.full(d, -np.pi), np.full(d, np.pi)
        lows[0] = 0.0  # f(-x) = f(x)
        f.bound(lows[None], highs[None], np.inf)  # compiled (or loaded) before the search's clock starts
        value, x, upper, boxes, _ = branch_and_bound(f.bound, lows, highs, value, x, f.ascend, tol=tol,
                                                     budget_s=budget_cpu_s, desc=desc)
    q_a = np.diff(np.concatenate([[0.0], x])) % (2 * np.pi)
    return Maximum(float(value), tuple(float(q) for q in q_a), float(np.max(values)), upper=float(upper),
                   tol=float(tol), method=method, boxes=int(boxes))


def certificate_dir() -> Path:
    """Where the searches' results are kept between commands (:func:`kept_search`)."""
    return cache_root() / "kd_min"


def _certificate_path(am, E_r, tol) -> Path:
    return certificate_dir() / f"{cache_key(robot=am.key(), E_r=float(E_r), tol=float(tol))}.json"


def kept_search(am, E_r, budget_cpu_s, tol=TOL) -> Maximum | None:
    """The kD_min of this robot and goal energy that an earlier command's search found (keyed by the package's
    code, the robot's parameters, E_r and ``tol``), if f at its argmax is still its value and it is certified or
    its bracket was searched with at least ``budget_cpu_s``; else None."""
    try:
        fields = json.loads(_certificate_path(am, E_r, tol).read_text())
        budget = float(fields.pop("budget_cpu_s"))
        kept = Maximum(**{**fields, "argmax": tuple(float(q) for q in fields["argmax"])})
    except (OSError, ValueError, TypeError, KeyError):
        return None
    x = np.cumsum(np.asarray(kept.argmax, float))[None]  # the actuated angles back to absolute ones
    same = math.isclose(BoundFunction(am, E_r).values(x)[0], kept.value, rel_tol=1e-12)
    return kept if same and (kept.certified or budget >= budget_cpu_s) else None


def keep_search(am, E_r, kd: Maximum, budget_cpu_s):
    """Keep what a search found (certified, or a bracket with the budget it had) for :func:`kept_search`: a chain
    of 9 to 11 links spends its whole budget on each command otherwise."""
    if kd.boxes or kd.certified:  # not the global bound, which costs nothing again
        with contextlib.suppress(PaaError):  # an unwritable cache costs a search next time, nothing else
            write_json(_certificate_path(am, E_r, kd.tol), {**dataclasses.asdict(kd), "budget_cpu_s": budget_cpu_s})
