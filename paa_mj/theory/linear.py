"""Linear analysis at a task's goal: linearisation of (1) at UDD (or any goal), controllability, the LQR gain (67).

Every function takes the :class:`~paa_mj.task.Task` whose goal it linearises at; the ``udd_*`` ones are the
paper's case, the folded goal of its gymnast.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import PaaError
from ..model.dynamics import AnalyticModel
from ..task import Task

#: The paper's LQR weights for (67): Q = 1e4 I, R = I (sized for the gymnast, 6 and 2; for n links 2n and n - 1).
LQR_WEIGHT = 10000.0
LQR_Q = LQR_WEIGHT * np.eye(6)
LQR_R = np.eye(2)


def goal_linearization(am: AnalyticModel, task: Task):
    """(A, B) of (1) linearised at the task's goal with x = [q - q*, qd]: at UDD, x = [q1, q2 + pi, q3, d1, d2, d3]."""
    return am.linearize(task.goal)


def udd_linearization(am: AnalyticModel):
    """(A, B) of (1) linearised at UDD with x = [q1, q2 + pi, q3, d1, d2, d3] (the folded task)."""
    return goal_linearization(am, Task.named("folded", am))


@dataclass(frozen=True)
class Controllability:
    controllable: bool
    rank: int
    sigma_min_ratio: float
    pbh_min: float


def linear_controllability(A, B, tol=1e-10) -> Controllability:
    """Controllability of x_dot = A x + B u.

    The verdict is the PBH test: min over eigenvalues lambda of A of sigma_min([A - lambda I, B]), relative to the
    norms of A and B, above its rounding, 100 n eps (n states; an uncontrollable mode gives a few eps). The rank of the Kalman matrix [B, AB, ..., A^(n-1) B] (columns scaled to unit
    norm so that the rank test is not fooled by units) is its cross-check; on long chains the powers of A make it
    too ill-conditioned to decide (its columns turn towards A's dominant eigenvectors), so it is reported, not
    trusted; ``tol`` is its relative threshold of a singular value.
    """
    n = A.shape[0]
    blocks, block = [], B
    for _ in range(n):
        blocks.append(block)
        block = A @ block
        # each column rescaled on the way: the same directions, without the overflow of A^(n-1) on long chains
        block = block / np.maximum(np.linalg.norm(block, axis=0, keepdims=True), np.finfo(float).tiny)
    C = np.hstack(blocks)
    C = C / np.maximum(np.linalg.norm(C, axis=0, keepdims=True), np.finfo(float).tiny)
    s = np.linalg.svd(C, compute_uv=False)
    rank = int(np.sum(s > tol * s[0]))
    pbh = min(np.linalg.svd(np.hstack([A - lam * np.eye(n), B]), compute_uv=False)[-1]
              for lam in np.linalg.eigvals(A))
    pbh_rel = float(pbh / max(np.linalg.norm(A, 2), np.linalg.norm(B, 2)))
    return Controllability(controllable=bool(pbh_rel > 100 * n * np.finfo(float).eps), rank=rank,
                           sigma_min_ratio=float(s[-1] / s[0]), pbh_min=pbh_rel)


def goal_controllability(am: AnalyticModel, task: Task, tol=1e-10) -> Controllability:
    """Linear controllability of the robot at the task's goal (:func:`linear_controllability`)."""
    return linear_controllability(*goal_linearization(am, task), tol=tol)


def udd_controllability(am: AnalyticModel, tol=1e-10) -> Controllability:
    """Linear controllability of the robot at UDD (the folded task)."""
    return goal_controllability(am, Task.named("folded", am), tol)


def lqr_gain(am: AnalyticModel, task: Task, Q=None, R=None):
    """LQR gain K of (67) on the linearisation at the task's goal: tau = -K x, K = R^-1 B^T S with S the
    stabilising solution of the continuous algebraic Riccati equation (SciPy); Q, R default to the paper's
    1e4 I and I.

    Raises
    ------
    PaaError
        The Riccati equation has no stabilising solution that SciPy can compute with these weights (weights
        too far apart, or a goal that is not stabilisable), or the gain is not finite.
    """
    return lqr_solution(am, task, Q, R)[0]


def lqr_weight_matrices(n_links, Q=None, R=None, n_motors=None):
    """(Q, R) of (67), each the paper's where None: Q = 1e4 I (2n x 2n), R = I (m x m, m = ``n_motors``, default
    n - 1)."""
    motors = n_links - 1 if n_motors is None else n_motors
    return (LQR_WEIGHT * np.eye(2 * n_links) if Q is None else Q, np.eye(motors) if R is None else R)


def lqr_solution(am: AnalyticModel, task: Task, Q=None, R=None):
    """(K, S) of (67): S the stabilising solution of A^T S + S A - S B R^-1 B^T S + Q = 0 on the linearisation at
    the task's goal, K = R^-1 B^T S, so that x^T S x is the LQR's cost-to-go of the linear loop (:func:`lqr_gain`
    for the weights and the errors)."""
    from scipy.linalg import solve_continuous_are

    Q, R = lqr_weight_matrices(am.n_links, Q, R, am.n_motors)
    A, Bl = goal_linearization(am, task)
    try:
        S = solve_continuous_are(A, Bl, Q, R)
        K = np.linalg.solve(R, Bl.T @ S)
    except (np.linalg.LinAlgError, ValueError) as err:
        raise PaaError(f"the LQR (67) at the {task.name} goal has no finite gain with these weights"
                       f" ({type(err).__name__}: {' '.join(str(err).split())})") from None
    if not (np.all(np.isfinite(K)) and np.all(np.isfinite(S))):
        raise PaaError(f"the LQR (67) at the {task.name} goal has no finite gain with these weights")
    return K, S


def sampled_closed_loop(am: AnalyticModel, K, dt, task: Task):
    """Phi = Ad - Bd K: the linearisation at the task's goal sampled with zero-order hold at ``dt`` [s], under
    tau = -K x."""
    from scipy.linalg import expm

    A, B = goal_linearization(am, task)
    m, k = B.shape
    block = np.zeros((m + k, m + k))
    block[:m, :m], block[:m, m:] = A, B
    sampled = expm(block * dt)
    return sampled[:m, :m] - sampled[:m, m:] @ np.asarray(K, float)


def sampled_spectral_radius(am: AnalyticModel, K, dt, task: Task) -> float:
    """The spectral radius of :func:`sampled_closed_loop` (below 1: the sampled balance is stable)."""
    phi = sampled_closed_loop(am, K, dt, task)
    return float(np.max(np.abs(np.linalg.eigvals(phi)))) if np.all(np.isfinite(phi)) else float("inf")


def stable_sampling_step(am: AnalyticModel, K, dt, task: Task, halvings=8) -> float | None:
    """The largest of ``dt``, ``dt``/2, ..., ``dt``/2^``halvings`` [s] at which the balance tau = -K x is stable
    when sampled (:func:`sampled_spectral_radius` below 1), or None if it is at none of them.

    A continuous-time LQR (67) is stable, but its gain held over a step of zero-order hold is stable only for steps
    short against the loop's fastest mode: a long chain's, or a light link's, can need well under 1 ms.
    """
    step = float(dt)
    for _ in range(halvings + 1):
        if sampled_spectral_radius(am, K, step, task) < 1.0:
            return step
        step /= 2.0
    return None


def sampled_balance(am: AnalyticModel, K, dt, task: Task) -> dict:
    """The balance tau = -K x at the task's goal sampled at ``dt`` [s]: ``radius``, the spectral radius of its loop
    (below 1: stable), and ``stable_dt``, the largest of ``dt``/2^k (k = 0..8) at which it is stable (None if
    none). Kept per robot, gain, step and task: a run's warning and its summary ask for the same one."""
    K = np.asarray(K, float)
    key = (am.key(), K.shape, K.tobytes(), float(dt), task)
    if key not in _SAMPLED_BALANCE:
        if len(_SAMPLED_BALANCE) >= 256:  # a study of many perturbed robots keeps only the latest
            _SAMPLED_BALANCE.clear()
        radius = sampled_spectral_radius(am, K, dt, task)
        _SAMPLED_BALANCE[key] = {"radius": radius,
                                 "stable_dt": dt if radius < 1.0 else stable_sampling_step(am, K, dt / 2, task, 7)}
    return dict(_SAMPLED_BALANCE[key])


_SAMPLED_BALANCE: dict = {}


def balance_time_step(am: AnalyticModel, tasks, dt=1e-3, halvings=8, Q=None, R=None) -> float | None:
    """The largest of ``dt``/2^k (k = 0..``halvings``) [s] at which the LQR (67) of every task in ``tasks`` is
    stable when sampled (:func:`stable_sampling_step` of each; a step that halves a stable one again is taken as
    stable, as it is for every chain here), or None if one of them is stable at none."""
    steps = [stable_sampling_step(am, lqr_gain(am, task, Q, R), dt, task, halvings) for task in tasks]
    return None if None in steps else min(steps)


def require_passive_first(am: AnalyticModel, what: str, name: str | None = None):
    """Refuse, in one line that says why, ``what`` (the paper's controllers (40), (12), the conditions of
    Theorem 1, Spong's acrobot swing-up) on a robot whose passive joint is not joint 1 alone: their energy
    shaping, their virtual constraints and the proofs are written for B = [0; I] (a torque on every joint but the
    one on the bar)."""
    if not am.passive_first:
        robot = name or am.params.name
        raise PaaError(f"{what} needs joint 1 alone passive (B = [0; I], a motor on every joint but the one on the"
                       f" bar: it is built on that); robot {robot} has {am.params.actuation_text()} (the LQR, trajopt"
                       " and your own controllers run on it)")


def theorem1_covers(am: AnalyticModel, task: Task) -> bool:
    """Whether Theorem 1 (and the paper's closed forms of (40)) covers the robot and task: the paper's gymnast
    shape (three links, no damping, no armature, joint 1 passive) and its folded goal UDD (8). The one test of
    it."""
    return bool(am.paper_shape and task.name == "folded")
