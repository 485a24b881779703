"""RealAIGym's criteria and scores, as their code computes them (``double_pendulum``, commit 1e8544e6).

Ported from ``src/python/double_pendulum/analysis/leaderboard.py`` and ``benchmark_scores.py``; the
arrays are the rows of the CSV their leaderboard scripts save (T (K,), X (K, 2n) in their angles: q1 from
hanging down, U (K, n) the applied torques, joint 1 first), k = 0..K-1. For more than two links every sum over
joints runs over all n, and "up" is the tip above ``height`` times the tip's height at the goal (for their
acrobot's upright goal, 0.9 (l1 + l2), theirs exactly).

Performance (``leaderboard_scores``):

- swing-up time: T[i] for the first i after which the tip stays up (their loop never looks at the last row,
  nor at row 0); T[-1] when it is not up on the row before the last: then the run has failed;
- energy: sum_j sum_k |(x_{k+1,j} - x_{k,j}) u_{k,j}| [J];
- torque cost: sum_k u_k' u_k (t_{k+1} - t_k) [N^2 m^2 s]; smoothness: sum_j std_k(u_{k+1,j} - u_{k,j}) [N m];
- velocity cost: sum_k qd_k' qd_k (t_{k+1} - t_k) [rad^2/s];
- score v2: success (1 - (1 / w) sum_c tanh(pi c / n_c)), w the number of criteria with a non-zero weight (5);
  their code has the pi that their published rules page omits (tanh(c / n_c)): the code is followed.
- robot-scaled score v2 (ours, not theirs): the same with each n_c carried from their acrobot to the robot by dynamic
  similarity (:func:`scaled_norms`), for robots whose criteria saturate their acrobot's normalisations.

Robustness (``get_scores``): the share of successful runs (model, torque response, delay, perturbations) or of
levels whose repetitions succeed more than half the time (velocity noise, torque noise); the overall score is
the mean of the six (their ``create_leaderboard.py``). Global policy: the time up, sum of (t_k - t_{k-1}) over
the rows where the tip is up (the first row counts t_0 - 0), over the run's length.
"""
from __future__ import annotations

import numpy as np

from ..limits import MIN_TORQUE_FRACTION

#: Their simulation_v2 weights and normalisations (``calculate_leaderboard_score.py``).
V2_NORMS = {"swingup_time": 20.0, "energy": 60.0, "tau_cost": 20.0, "tau_smoothness": 0.1, "velocity_cost": 400.0}
#: Their simulation_v1 weights and normalisations (the archived leaderboard's).
V1_WEIGHTS = {"swingup_time": 0.2, "max_tau": 0.1, "energy": 0.1, "integ_tau": 0.1, "tau_cost": 0.1,
              "tau_smoothness": 0.2, "velocity_cost": 0.2}
V1_NORMS = {"swingup_time": 10.0, "max_tau": 6.0, "energy": 100.0, "integ_tau": 60.0, "tau_cost": 360.0,
            "tau_smoothness": 12.0, "velocity_cost": 1000.0}
ROBUSTNESS_CRITERIA = ("model", "measurement_noise", "u_noise", "u_responsiveness", "delay", "perturbation")


def scaled_norms(g, g_motors, t, links) -> dict:
    """:data:`V2_NORMS` carried from their acrobot to a robot whose scales against it are (g, g_j, t)
    (:func:`~paa_mj.model.similarity.similarity`: gravity torque, each motor's carried gravity torque, natural time)
    and whose joints number ``links`` times theirs: a motion that is their acrobot's in the units (G, C_j, T) then
    scores what theirs does. Swing-up time by t; energy (the work that lifts the chain) by g; torque cost
    (sum_j u_j^2 dt) by sum_j g_j^2 t; smoothness (sum_j of the torque's step-to-step change, at a fixed step) by
    sum_j g_j / t; velocity cost (sum over the joints of qd^2 dt) by links / t. Each is exactly theirs on their
    acrobot."""
    g_motors = np.asarray(g_motors, float)
    factors = {"swingup_time": t, "energy": g, "tau_cost": float(np.sum(g_motors ** 2)) * t,
               "tau_smoothness": float(np.sum(g_motors)) / t, "velocity_cost": links / t}
    return {k: V2_NORMS[k] * factors[k] for k in V2_NORMS}


def score_v2(criteria: dict, success: bool, norms=V2_NORMS) -> float:
    """Their score v2 of a run's ``criteria`` (module docstring) with the normalisations ``norms``."""
    return float(success * (1.0 - sum(np.tanh(np.pi * criteria[k] / n) for k, n in norms.items()) / len(norms)))


def tip_height(X, lengths):
    """Height of the chain's tip above the bar [m] at their angles X (K, 2n) (q1 = 0 hanging down)."""
    n = len(lengths)
    phi = np.cumsum(np.asarray(X, float)[:, :n], axis=1)
    return -np.sum(np.asarray(lengths, float) * np.cos(phi), axis=1)


def up_rows(X, lengths, goal_height, height=0.9):
    """Rows whose tip is above ``height`` times the goal's tip height."""
    return tip_height(X, lengths) > height * goal_height


def swingup_time(T, up, t_final):
    """Their ``get_swingup_time`` (method "height", has_to_stay) on the rows ``up``."""
    if T[-1] < 0.99 * t_final:
        return float("inf")
    index = len(T) - 1
    for i in range(len(up) - 2, 0, -1):
        if not up[i]:
            break
        index = i
    return float(T[index])


def energy(X, U):
    n = U.shape[1]
    return float(sum(np.sum(np.abs(np.diff(X[:, j]) * U[:-1, j])) for j in range(n)))


def integrated_torque(T, U):
    return float(np.sum(np.abs(U[:-1]) * np.diff(T)[:, None]))


def torque_cost(T, U):
    return float(np.einsum("ij, i, ij", U[:-1], np.diff(T), U[:-1]))


def tau_smoothness(U):
    return float(sum(np.std(np.diff(U[:, j])) for j in range(U.shape[1])))


def velocity_cost(T, X):
    n = X.shape[1] // 2
    return float(np.einsum("ij, i, ij", X[:-1, n:], np.diff(T), X[:-1, n:]))


def performance(T, X, U, up, t_final, scaled=None):
    """Their criteria and both scores of one run's rows (module docstring); ``up``: which rows count as up
    (their rule: :func:`up_rows`); ``scaled``: the robot's normalisations (:func:`scaled_norms`), which add the
    robot-scaled score v2."""
    T, X, U = (np.asarray(a, float) for a in (T, X, U))
    swingup = swingup_time(T, np.asarray(up, bool), t_final)
    success = bool(swingup < T[-1])
    c = {"swingup_time": swingup, "max_tau": float(np.max(np.abs(U))), "energy": energy(X, U),
         "integ_tau": integrated_torque(T, U), "tau_cost": torque_cost(T, U), "tau_smoothness": tau_smoothness(U),
         "velocity_cost": velocity_cost(T, X)}
    v1 = success * (1.0 - sum(V1_WEIGHTS[k] * c[k] / V1_NORMS[k] for k in V1_WEIGHTS))
    out = {"success": success, **c, "score_v1": float(v1), "score_v2": score_v2(c, success)}
    if scaled is not None:
        out["score_v2_scaled"] = score_v2(c, success, scaled)
    return out


def uptime(T, up):
    """Their ``get_uptime``: the time the tip is up [s]."""
    dt = np.diff(np.asarray(T, float), prepend=0.0)
    return float(np.sum(dt[np.asarray(up, bool)]))


def level_successes(successes, repeated):
    """Per level, success as their score counts it: the run's, or (``repeated``) more than half of its runs'."""
    s = np.asarray(successes, float)
    return (np.mean(s, axis=1) > 0.5) if repeated else s.astype(bool)


def robustness_score(per_criterion: dict) -> dict:
    """Their ``get_scores`` from, per criterion, the level-or-run successes (:func:`level_successes`; the model's
    over all its parameters together), and the overall score, the mean of the six."""
    scores = {c: float(np.mean(np.concatenate([np.ravel(v) for v in per_criterion[c]]))) for c in ROBUSTNESS_CRITERIA}
    scores["overall"] = float(sum(scores[c] for c in ROBUSTNESS_CRITERIA) / 6.0)
    return scores


def final_state_success(x_final, goal, eps=(0.35, 0.35, 1.0, 1.0)):
    """Their ``check_goal_success`` (epsilon, final state only): every angle within eps[0] of the goal's
    (wrapped to (-pi, pi]) and every speed within eps[2] [rad, rad/s]; ``eps`` per joint: positions then speeds."""
    x = np.asarray(x_final, float)
    n = x.size // 2
    goal = np.asarray(goal, float)
    error = np.mod(x[:n] - goal[:n] + np.pi, 2 * np.pi) - np.pi
    eps = np.asarray(eps, float)
    eps_q, eps_v = (eps[:n], eps[n:]) if eps.size == 2 * n else (np.full(n, eps[0]), np.full(n, eps[-1]))
    return bool(np.all(np.abs(error) < eps_q) and np.all(np.abs(x[n:] - goal[n:]) < eps_v))


#: A run "never left its start" when no coordinate moved more than this [rad, rad/s].
STILL = 1e-9


def no_action(X, U, gravity_constants) -> dict:
    """``{"no_action": {"max_abs_tau", "max_motion"}}`` for a run (states X, torques U) whose controller exerted no
    torque (below :data:`~paa_mj.limits.MIN_TORQUE_FRACTION` of the robot's gravity torque, its largest gravity
    constant b_k [J]) and whose robot never left its start (:data:`STILL`): a controller at rest at an equilibrium
    of its own law, whose scores say nothing of it; else ``{}``."""
    peak = float(np.max(np.abs(U))) if np.size(U) else 0.0
    moved = float(np.max(np.abs(np.asarray(X) - np.asarray(X)[0]))) if len(X) else 0.0
    gravity = float(np.max(np.abs(np.asarray(gravity_constants, float))))
    if peak < MIN_TORQUE_FRACTION * gravity and moved < STILL:
        return {"no_action": {"max_abs_tau": peak, "max_motion": moved}}
    return {}
