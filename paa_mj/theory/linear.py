"""Linear analysis at the goal: linearisation of (1) at UDD, controllability, the LQR gain of (67)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model.dynamics import AnalyticModel
from ..model.states import Q_UDD

#: The paper's LQR weights for (67).
LQR_Q = 10000.0 * np.eye(6)
LQR_R = np.eye(2)


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
    """LQR gain K of (67) on the UDD linearisation: tau = -K x, K = R^-1 B^T S with S the stabilising
    solution of the continuous algebraic Riccati equation (SciPy)."""
    from scipy.linalg import solve_continuous_are

    A, Bl = udd_linearization(am)
    S = solve_continuous_are(A, Bl, Q, R)
    return np.linalg.solve(R, Bl.T @ S)


def sampled_closed_loop(am: AnalyticModel, K, dt):
    """Phi = Ad - Bd K: the linearisation at UDD sampled with zero-order hold at ``dt`` [s], under tau = -K x."""
    from scipy.linalg import expm

    A, B = udd_linearization(am)
    block = np.zeros((8, 8))
    block[:6, :6], block[:6, 6:] = A, B
    sampled = expm(block * dt)
    return sampled[:6, :6] - sampled[:6, 6:] @ np.asarray(K, float)


def sampled_spectral_radius(am: AnalyticModel, K, dt) -> float:
    """The spectral radius of :func:`sampled_closed_loop` (below 1: the sampled balance is stable)."""
    phi = sampled_closed_loop(am, K, dt)
    return float(np.max(np.abs(np.linalg.eigvals(phi)))) if np.all(np.isfinite(phi)) else float("inf")
