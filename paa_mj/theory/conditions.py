"""The paper's conditions on the robot and the gains, made computable.

- (41), (42): kD_min, above which controller (40) is singularity-free;
- (59), (60): eta1 and eta2, the lower bounds on kP of Theorem 1;
- (54): the mechanical constraint f(z) != 1 on the robot;
- (26)-(30): deltabar of the Acrobot obtained by freezing q3.

Everything is computed from an :class:`~paa_mj.model.dynamics.AnalyticModel`;
no number of the paper is used. Maxima over angles come from
:func:`~paa_mj.theory.maxima.grid_maximum` (a coarse grid, then zoomed grids), far
better than the 1e-4 relative accuracy the theory needs. See ``docs/model.md``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model.dynamics import AnalyticModel
from ..model.vcl import beta2bar
from .maxima import Maximum, bounded_minimum, grid_maximum

TWO_PI = 2 * np.pi


def mu(am: AnalyticModel, q2, q3):
    """mu(q2, q3) of (42) [J]."""
    b1, b2, b3 = am.beta
    return np.sqrt(b1**2 + b2**2 + b3**2 + 2 * b1 * b2 * np.cos(q2)
                   + 2 * b1 * b3 * np.cos(q2 + q3) + 2 * b2 * b3 * np.cos(q3))


def actuated_inertia_lambda_max(am: AnalyticModel, q2, q3):
    """lambda_max((B^T M^-1 B)^-1) [kg m^2], via the Schur complement of M11 in M."""
    M = am.mass_matrix_23(q2, q3)
    S = M[..., 1:, 1:] - M[..., 1:, :1] * M[..., :1, 1:] / M[..., :1, :1]
    half_trace = 0.5 * (S[..., 0, 0] + S[..., 1, 1])
    det = S[..., 0, 0] * S[..., 1, 1] - S[..., 0, 1] * S[..., 1, 0]
    return half_trace + np.sqrt(np.maximum(half_trace**2 - det, 0.0))


def kd_bound_function(am: AnalyticModel, q2, q3):
    """(E_r + mu(q2, q3)) lambda_max((B^T M^-1 B)^-1), whose maximum is kD_min of (41)."""
    return (am.E_r + mu(am, q2, q3)) * actuated_inertia_lambda_max(am, q2, q3)


def kd_min(am: AnalyticModel) -> Maximum:
    """kD_min of (41): controller (40) is singularity-free iff kD > kD_min [J kg m^2]."""
    _require_paper(am, "kD_min of (41), (42)")
    return grid_maximum(lambda y, z: kd_bound_function(am, y, z), [(0, TWO_PI), (0, TWO_PI)],
                        n=(121, 121), periodic=(True, True))


def chain_mu(am: AnalyticModel, q_a):
    """max over q1 of -P(q), the length of sum_k b_k e(phi_k - phi_1) [J], for the actuated angles ``q_a``
    (..., n - 1): (42) for the gymnast."""
    q_a = np.asarray(q_a, float)
    relative = np.concatenate([np.zeros(q_a.shape[:-1] + (1,)), np.cumsum(q_a, axis=-1)], axis=-1)
    b = am.gravity_constants
    return np.hypot(np.sum(b * np.cos(relative), -1), np.sum(b * np.sin(relative), -1))


def chain_actuated_inertia_lambda_max(am: AnalyticModel, q_a):
    """lambda_max((B^T M^-1 B)^-1) [kg m^2] for any chain: the Schur complement of M11 in M."""
    q_a = np.asarray(q_a, float)
    q = np.concatenate([np.zeros(q_a.shape[:-1] + (1,)), q_a], axis=-1)
    M = am.mass_matrix(q)
    S = M[..., 1:, 1:] - M[..., 1:, :1] * M[..., :1, 1:] / M[..., :1, :1]
    return np.linalg.eigvalsh(S)[..., -1]


def chain_kd_min(am: AnalyticModel, task, budget_cpu_s=None, progress=True) -> Maximum:
    """kD_min of (41) from its definition, for any chain and goal [J kg m^2]: a certified maximum.

    E - E_r >= -(E_r + mu(q_a)) at every state (kinetic energy >= 0, P >= -mu), so Lambda =
    (E - E_r) I + kD B^T M^-1 B of (38) stays nonsingular for every state when kD exceeds the
    maximum over q_a of (E_r + mu) lambda_max((B^T M^-1 B)^-1). For the gymnast's UDD this is
    (41), (42) (:func:`kd_min`); elsewhere it is beyond the paper: the same definition, maximised by the branch and
    bound of :func:`~paa_mj.theory.kd_search.kd_min_search`, certified to a relative 1e-6 (15 to 30 CPU-seconds
    at 8 links, minutes at 9). Where its budget runs out first (from about 10 links) the result is a bracket:
    ``value <= kD_min <= upper``, ``certified`` False. Cached per robot and goal: a later call reuses the result
    when it is certified, when it asks for no budget of its own, or when it asks for no more than the first; it is
    also kept on disk for later commands, a bracket with its budget (:func:`~paa_mj.theory.kd_search.kept_search`).

    Parameters
    ----------
    am : AnalyticModel
    task : Task
        Its goal's energy is E_r.
    budget_cpu_s : float, optional
        CPU-seconds the search may take (default :func:`~paa_mj.theory.kd_search.default_budget`: 200, or the
        command's ``--kd-budget``).
    progress : bool
        A progress bar on stderr, with the bracket, while the search runs (lines from 2 s on).
    """
    from .kd_search import default_budget, keep_search, kd_min_search, kept_search

    budget = default_budget() if budget_cpu_s is None else float(budget_cpu_s)
    E_r = task.goal_energy(am)
    key = (am.key(), float(E_r))
    known = _KD_MIN_CACHE.get(key)
    if known is None or not (known[1].certified or budget_cpu_s is None or known[0] >= budget):
        desc = f"kD_min (41), {am.n_links} links, {task.name} goal" if progress else None
        kd = kept_search(am, E_r, budget)
        if kd is None:
            kd = kd_min_search(am, E_r, budget_cpu_s=budget, desc=desc)
            keep_search(am, E_r, kd, budget)
        known = _KD_MIN_CACHE[key] = (budget, kd)
    return known[1]


_KD_MIN_CACHE: dict = {}


def chain_kd_min_grid(am: AnalyticModel, E_r) -> Maximum:
    """kD_min of (41) as it was computed before the branch and bound: the maximum over a grid of the n - 1 actuated
    angles (721 points for one, 121^2, 41^3, 17^4, then 9 per angle), refined by zoomed grids; not certified.

    Kept as the reference the tests hold :func:`chain_kd_min` to on 2 to 6 links; its cost grows ninefold per link
    (about 4 CPU-s at 6 links, 45 at 7, 0.9 GB).
    """
    dim = am.n_links - 1
    coarse = {1: 721, 2: 121, 3: 41, 4: 17}.get(dim, 9)

    def bound(*angles):
        q_a = np.stack(np.broadcast_arrays(*angles), axis=-1)
        return (E_r + chain_mu(am, q_a)) * chain_actuated_inertia_lambda_max(am, q_a)

    return grid_maximum(bound, [(0, TWO_PI)] * dim, n=(coarse,) * dim, periodic=(True,) * dim,
                        zoom=21 if dim <= 2 else 7)


def bracket_words(kd: Maximum) -> str:
    """How far a :func:`chain_kd_min` is known, in words: its value, and its bracket where not certified."""
    if kd.certified:
        return f"kD_min = {kd.value:.6g} of (41) (certified to {kd.tol:.0e})"
    return (f"kD_min of (41) is only bracketed, in [{kd.value:.6g}, {kd.upper:.6g}] ({kd.method}); every kD above"
            f" {kd.upper:.6g} is singularity-free")


# --- (59), (60) ---------------------------------------------------------------------

def eta1_function(am: AnalyticModel, y, z):
    """b1 beta2bar(z) (Phi + E_r) sin y / (Phi (y + pi)) of (59) [J]."""
    b1, b2, b3 = am.beta
    bb = beta2bar(b2, b3, z)
    phi = np.sqrt(b1**2 + bb**2 + 2 * b1 * bb * np.cos(y))
    return b1 * bb * (phi + am.E_r) * np.sin(y) / (phi * (y + np.pi))


def eta1(am: AnalyticModel) -> Maximum:
    """eta1 of (59): Theorem 1 needs kP > eta1."""
    return grid_maximum(lambda y, z: eta1_function(am, y, z), [(0, np.pi), (0, TWO_PI)],
                        n=(61, 121), periodic=(False, True))


def eta2_function(am: AnalyticModel, z):
    """-b2 b3 (b1 - beta2bar(z) + E_r) sin z / (beta2bar(z) z) of (60), z in [pi, 2 pi]."""
    b1, b2, b3 = am.beta
    bb = beta2bar(b2, b3, z)
    return -b2 * b3 * (b1 - bb + am.E_r) * np.sin(z) / (bb * z)


def eta2(am: AnalyticModel) -> Maximum:
    """eta2 of (60): Theorem 1 needs kP > eta2."""
    return grid_maximum(lambda z: eta2_function(am, z), [(np.pi, TWO_PI)], n=(2001,))


# --- (54) -------------------------------------------------------------------------

def constraint_terms(am: AnalyticModel):
    """Gamma, Eps and Lam of (54)."""
    p, g = am.params, am.params.g
    l1 = p.l[0]
    gamma = l1 * am.b1 - am.a11 * g
    eps = 2 * (g * am.a23 * am.b1 - l1 * am.b2 * am.b3)
    lam = g * (am.a22 + am.a33) * am.b1 - l1 * (am.b2**2 + am.b3**2)
    return gamma, eps, lam


def f54(am: AnalyticModel, z):
    """f(z) = Gamma beta2bar(z) / (Eps cos z + Lam) of (54)."""
    gamma, eps, lam = constraint_terms(am)
    return gamma * beta2bar(am.b2, am.b3, z) / (eps * np.cos(z) + lam)


@dataclass(frozen=True)
class Constraint54:
    """Constraint (54): f(z) != 1 for all z in [0, 2 pi].

    Attributes
    ----------
    holds : bool
    f_min, f_max : float
        Extremes of f on [0, 2 pi] (+-inf when the denominator vanishes).
    closest_to_one : float
        :math:`\\min_z |f(z) - 1|`, with ``z_closest`` where it happens.
    """

    holds: bool
    f_min: float
    f_max: float
    closest_to_one: float
    z_closest: float
    tolerance: float = 1e-9


def constraint_54(am: AnalyticModel, n=40001) -> Constraint54:
    """Check (54). f = 1 is treated as reached when :math:`|f - 1| \\le 10^{-9}` (rounding).

    Whether f reaches 1 is decided on h(z) = (Gamma beta2bar - (Eps cos z + Lam)) / scale, which vanishes exactly
    where f = 1 and stays finite where the denominator of f vanishes; how close f comes to 1 is min abs(f - 1) itself
    (h has another minimiser: its denominator is not f's).
    """
    gamma, eps, lam = constraint_terms(am)
    z = np.linspace(0, TWO_PI, n)
    scale = abs(gamma) * (am.b2 + am.b3) + abs(eps) + abs(lam)

    def signed(s):
        return (gamma * beta2bar(am.b2, am.b3, s) - (eps * np.cos(s) + lam)) / scale

    h = signed(z)
    crosses = bool(np.any(np.sign(h[:-1]) * np.sign(h[1:]) < 0))
    h_touch = _refined_minimum(lambda s: abs(signed(s)), z, np.abs(h))[1]
    denominator = eps * np.cos(z) + lam
    sign_change = bool(np.any(np.sign(denominator[:-1]) * np.sign(denominator[1:]) < 0)) or not np.all(denominator)
    with np.errstate(divide="ignore", invalid="ignore"):
        f = f54(am, z)

        def distance(s):
            value = abs(f54(am, s) - 1.0)
            return value if np.isfinite(value) else np.inf

        z_close, f_close_distance = _refined_minimum(distance, z, np.where(np.isfinite(f), np.abs(f - 1.0), np.inf))
    f_min, f_max = (-np.inf, np.inf) if sign_change else (float(f.min()), float(f.max()))
    tolerance = 1e-9
    holds = not crosses and f_close_distance > tolerance and h_touch > tolerance
    return Constraint54(holds=bool(holds), f_min=f_min, f_max=f_max,
                        closest_to_one=float(f_close_distance), z_closest=float(z_close), tolerance=tolerance)


def _refined_minimum(func, z, values):
    """The minimum of ``func`` over [0, 2 pi] from its ``values`` on the grid ``z``: Brent's method on the cells
    beside the grid's least value, kept only where it does better. (z, func(z))."""
    i = int(np.argmin(values))
    x_min, v_min = bounded_minimum(func, z[max(i - 1, 0)], z[min(i + 1, len(z) - 1)], xatol=1e-13)
    return (float(x_min), float(v_min)) if v_min < values[i] else (float(z[i]), float(values[i]))


# --- (26)-(30) --------------------------------------------------------------------

def deltabar(am: AnalyticModel, z):
    """deltabar(z) of (30) for the Acrobot obtained by freezing q3 = z (26)."""
    p = am.params
    bb = beta2bar(am.b2, am.b3, z)
    abar1 = am.a11
    abar2 = am.a22 + am.a33 + 2 * am.a23 * np.cos(z)
    abar3 = p.l[0] * bb / p.g
    return (abar2 - abar3) * am.b1 + (abar1 - abar3) * bb



_THRESHOLD_CACHE: dict = {}


def _require_paper(am: AnalyticModel, what: str):
    if not am.paper_shape:
        from ..errors import PaaError

        raise PaaError(f"{what} is Theorem 1's, proved for the paper's 3-link gymnast without damping or armature;"
                       f" this robot has {am.n_links} links{' and damping or armature' if am.n_links == 3 else ''}")


def thresholds(am: AnalyticModel) -> tuple[Maximum, Maximum, Maximum]:
    """(kD_min, eta1, eta2) as :class:`Maximum`; cached per robot (they cost a few grid searches)."""
    _require_paper(am, "the thresholds (41), (59), (60)")
    key = am.key()
    if key not in _THRESHOLD_CACHE:
        _THRESHOLD_CACHE[key] = (kd_min(am), eta1(am), eta2(am))
    return _THRESHOLD_CACHE[key]


def frozen_acrobot_controllable(am: AnalyticModel, n=20001) -> tuple[bool, float, float]:
    """Whether deltabar (30) keeps one sign over z in [0, 2 pi]: (controllable for every z, min, max)."""
    db = deltabar(am, np.linspace(0, TWO_PI, n))
    ok = bool(np.min(np.abs(db)) > 1e-9 * np.max(np.abs(db)) and (np.all(db > 0) or np.all(db < 0)))
    return ok, float(db.min()), float(db.max())

