"""The paper's conditions made computable (PAA_MODEL.md sections 2-6).

Everything here is computed from an :class:`~paa_mj.dynamics.AnalyticModel`;
no number of the paper is used. Maxima over angles are found on a grid and
then refined by a bounded Nelder-Mead search from the best grid points, which
gives far better than the 1e-4 relative accuracy the theory needs.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field
import numpy as np
from scipy import optimize

from .dynamics import AnalyticModel
from .vcl import beta2bar

TWO_PI = 2 * np.pi
#: The folded up-down-down equilibrium (8) and the down-up-up point of Theorem 1.
Q_UDD = np.array([0.0, -np.pi, 0.0])
Q_DUU = np.array([-np.pi, -np.pi, 0.0])
#: The paper's LQR weights for (67).
LQR_Q = 10000.0 * np.eye(6)
LQR_R = np.eye(2)


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


# --- (41), (42) -------------------------------------------------------------------

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
    return grid_maximum(lambda y, z: kd_bound_function(am, y, z), [(0, TWO_PI), (0, TWO_PI)],
                        n=(361, 361), periodic=(True, True))


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
                        n=(361, 361), periodic=(False, True))


def eta2_function(am: AnalyticModel, z):
    """-b2 b3 (b1 - beta2bar(z) + E_r) sin z / (beta2bar(z) z) of (60), z in [pi, 2 pi]."""
    b1, b2, b3 = am.beta
    bb = beta2bar(b2, b3, z)
    return -b2 * b3 * (b1 - bb + am.E_r) * np.sin(z) / (bb * z)


def eta2(am: AnalyticModel) -> Maximum:
    """eta2 of (60): Theorem 1 needs kP > eta2."""
    return grid_maximum(lambda z: eta2_function(am, z), [(np.pi, TWO_PI)], n=(20001,))


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
        min |f(z) - 1| over z, with ``z_closest`` where it happens.
    """

    holds: bool
    f_min: float
    f_max: float
    closest_to_one: float
    z_closest: float
    tolerance: float = 1e-9


def constraint_54(am: AnalyticModel, n=40001) -> Constraint54:
    """Check (54). f = 1 is treated as reached when |f - 1| <= 1e-9 (rounding)."""
    gamma, eps, lam = constraint_terms(am)
    z = np.linspace(0, TWO_PI, n)
    # Work with h(z) = Gamma beta2bar - (Eps cos z + Lam): f = 1 exactly where h = 0, and h
    # stays finite where the denominator of f vanishes.
    scale = abs(gamma) * (am.b2 + am.b3) + abs(eps) + abs(lam)
    h = (gamma * beta2bar(am.b2, am.b3, z) - (eps * np.cos(z) + lam)) / scale
    denominator = eps * np.cos(z) + lam
    f = f54(am, z) if np.all(denominator != 0) else None
    crosses = bool(np.any(np.sign(h[:-1]) * np.sign(h[1:]) < 0))
    i = int(np.argmin(np.abs(h)))
    res = optimize.minimize_scalar(
        lambda s: abs(gamma * beta2bar(am.b2, am.b3, s) - (eps * np.cos(s) + lam)) / scale,
        bounds=(z[max(i - 1, 0)], z[min(i + 1, n - 1)]), method="bounded", options={"xatol": 1e-13})
    z_close, h_close = (float(res.x), float(res.fun)) if res.fun < abs(h[i]) else (float(z[i]), float(abs(h[i])))
    sign_change = bool(np.any(np.sign(denominator[:-1]) * np.sign(denominator[1:]) < 0))
    if f is None or sign_change:
        f_min, f_max = -np.inf, np.inf
    else:
        f_min, f_max = float(f.min()), float(f.max())
    f_close = float(f54(am, z_close))
    tolerance = 1e-9
    holds = not crosses and abs(f_close - 1) > tolerance and h_close > tolerance
    return Constraint54(holds=bool(holds), f_min=f_min, f_max=f_max,
                        closest_to_one=abs(f_close - 1), z_closest=z_close, tolerance=tolerance)


# --- (26)-(30) --------------------------------------------------------------------

def deltabar(am: AnalyticModel, z):
    """deltabar(z) of (30) for the Acrobot obtained by freezing q3 = z (26)."""
    p = am.params
    bb = beta2bar(am.b2, am.b3, z)
    abar1 = am.a11
    abar2 = am.a22 + am.a33 + 2 * am.a23 * np.cos(z)
    abar3 = p.l[0] * bb / p.g
    return (abar2 - abar3) * am.b1 + (abar1 - abar3) * bb


# --- linearisation at UDD, controllability, LQR (67) ---------------------------------

def udd_linearization(am: AnalyticModel):
    """(A, B) of (1) linearised at UDD with x = [q1, q2 + pi, q3, d1, d2, d3]."""
    return am.linearize(Q_UDD)


@dataclass(frozen=True)
class Controllability:
    controllable: bool
    rank: int
    sigma_min_ratio: float
    pbh_min: float


def linear_controllability(A, B, tol=1e-10) -> Controllability:
    """Controllability of x_dot = A x + B u.

    Rank of the Kalman matrix [B, AB, ..., A^(n-1) B] (columns scaled to unit norm
    so that the rank test is not fooled by units), cross-checked by the PBH test
    min over eigenvalues lambda of A of sigma_min([A - lambda I, B]).
    """
    n = A.shape[0]
    blocks, block = [], B
    for _ in range(n):
        blocks.append(block)
        block = A @ block
    C = np.hstack(blocks)
    C = C / np.maximum(np.linalg.norm(C, axis=0, keepdims=True), np.finfo(float).tiny)
    s = np.linalg.svd(C, compute_uv=False)
    rank = int(np.sum(s > tol * s[0]))
    pbh = min(np.linalg.svd(np.hstack([A - lam * np.eye(n), B]), compute_uv=False)[-1]
              for lam in np.linalg.eigvals(A))
    pbh_rel = float(pbh / max(np.linalg.norm(A, 2), np.linalg.norm(B, 2)))
    return Controllability(controllable=rank == n and pbh_rel > tol, rank=rank,
                           sigma_min_ratio=float(s[-1] / s[0]), pbh_min=pbh_rel)


def udd_controllability(am: AnalyticModel, tol=1e-10) -> Controllability:
    """Linear controllability of the 3-link robot at UDD (:func:`linear_controllability`)."""
    return linear_controllability(*udd_linearization(am), tol=tol)


def lqr_gain(am: AnalyticModel, Q=LQR_Q, R=LQR_R):
    """LQR gain K of (67) from python-control on the UDD linearisation: tau = -K x."""
    import control

    A, Bl = udd_linearization(am)
    K, _, _ = control.lqr(A, Bl, Q, R, method="scipy")
    return np.asarray(K)


# --- closed loop at DUU ------------------------------------------------------------

def closed_loop_jacobian(vector_field, x0, h=1e-5):
    """Jacobian of ``vector_field`` at ``x0`` by central differences with one Richardson step."""
    x0 = np.asarray(x0, float)
    n = x0.size

    def central(step):
        J = np.empty((n, n))
        for i in range(n):
            dx = np.zeros(n)
            dx[i] = step
            J[:, i] = (vector_field(x0 + dx) - vector_field(x0 - dx)) / (2 * step)
        return J

    return (4 * central(h / 2) - central(h)) / 3


def duu_eigenvalues(am: AnalyticModel, kD, kP, kV):
    """Eigenvalues of the Jacobian of (1) closed by controller (40) at DUU = (-pi, -pi, 0).

    Returns
    -------
    eigenvalues : ndarray of complex, sorted by decreasing real part
    charpoly : ndarray
        Coefficients of det(s I - J), highest power first.
    """
    from .controllers import EnergyVCLController

    ctrl = EnergyVCLController(am, kD=kD, kP=kP, kV=kV, check=False)

    def field(x):
        q, qd = x[:3], x[3:]
        return np.concatenate([qd, am.acceleration(q, qd, ctrl.torque(q, qd))])

    J = closed_loop_jacobian(field, np.concatenate([Q_DUU, np.zeros(3)]))
    eig = np.linalg.eigvals(J)
    eig = eig[np.lexsort((-eig.imag, -eig.real))]
    return eig, np.real(np.poly(eig))


# --- the whole report ------------------------------------------------------------

@dataclass
class TheoryReport:
    """Every condition of the paper for one robot and one set of gains."""

    beta: list
    E_r: float
    kD_min: float
    kD_min_at: list
    eta1: float
    eta1_at: list
    eta2: float
    eta2_at: float
    constraint_54: dict
    deltabar_min: float
    deltabar_max: float
    frozen_acrobot_ud_controllable: bool
    udd_controllable: bool
    udd_controllability: dict
    lqr_K: list
    gains: dict
    duu_eigenvalues: list
    duu_charpoly: list
    duu_unstable: bool
    theorem1: dict = field(default_factory=dict)

    def to_json_dict(self):
        return asdict(self)


_THRESHOLD_CACHE: dict = {}


def thresholds(am: AnalyticModel):
    """(kD_min, eta1, eta2) as :class:`Maximum`; cached per robot (they cost a few grid searches)."""
    key = am.key()
    if key not in _THRESHOLD_CACHE:
        _THRESHOLD_CACHE[key] = (kd_min(am), eta1(am), eta2(am))
    return _THRESHOLD_CACHE[key]


def theory_report(am: AnalyticModel, kD, kP, kV) -> TheoryReport:
    """Compute every condition of PAA_MODEL.md sections 2-6 for ``am`` and the gains."""
    kd, e1, e2 = thresholds(am)
    c54 = constraint_54(am)
    z = np.linspace(0, TWO_PI, 20001)
    db = deltabar(am, z)
    ctrb = udd_controllability(am)
    eig, poly = duu_eigenvalues(am, kD, kP, kV)
    conditions = {
        "E_r > 0": bool(am.E_r > 0),
        "(54) holds": c54.holds,
        "kD > kD_min (41)": bool(kD > kd.value),
        "kP > eta1 (59)": bool(kP > e1.value),
        "kP > eta2 (60)": bool(kP > e2.value),
        "kV > 0": bool(kV > 0),
    }
    conditions["all hold"] = all(conditions.values())
    return TheoryReport(
        beta=am.beta.tolist(), E_r=float(am.E_r),
        kD_min=kd.value, kD_min_at=list(kd.argmax),
        eta1=e1.value, eta1_at=list(e1.argmax), eta2=e2.value, eta2_at=float(e2.argmax[0]),
        constraint_54=asdict(c54), deltabar_min=float(db.min()), deltabar_max=float(db.max()),
        frozen_acrobot_ud_controllable=bool(np.min(np.abs(db)) > 1e-9 * np.max(np.abs(db))
                                            and (np.all(db > 0) or np.all(db < 0))),
        udd_controllable=ctrb.controllable, udd_controllability=asdict(ctrb),
        lqr_K=lqr_gain(am).tolist(), gains={"kD": kD, "kP": kP, "kV": kV},
        duu_eigenvalues=[[float(e.real), float(e.imag)] for e in eig],
        duu_charpoly=[float(c) for c in poly],
        duu_unstable=bool(np.max(eig.real) > 0),
        theorem1=conditions,
    )
