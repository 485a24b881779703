"""RealAIGym's acrobot simulation metrics and scores of a paa_mj trajectory (record with --sample-dt equal to --dt).

    paa-mj simulate --robot realaigym_acrobot_v1 --goal stretched --x0 -3.141592653589793 0 0 0 --dt 0.002 \\
        --t-final 10 --sample-dt 0.002 --controller examples/realaigym/pfl_controller.py:PFLCollocatedLQR_C03 --out run
    python examples/realaigym/score.py run/trajectory.csv                        # as their current code scores it
    python examples/realaigym/score.py run/trajectory.csv --record pre-4cddb6c   # as their published v1 row was

The metrics are a port of ``double_pendulum/src/python/double_pendulum/analysis/leaderboard.py``
(dfki-ric-underactuated-lab, commit 1e8544e6; the seven used here are unchanged since its first commit e780739):
the swing-up time (the tip above 0.9 (l1 + l2) from then to the end), the energy sum over joints of
sum_k abs((x_{k+1} - x_k) u_k), the largest torque, the integrated torque, the torque cost sum u_k^2 dt, the torque
smoothness std(diff u), the velocity cost sum qd_k^2 dt, and the RealAI scores of their simulation_v1 leaderboard
(weights and normalisations of that leaderboard) and simulation_v2 (1 - mean tanh(pi c / n); the published v2 page
omits the pi that the code uses). Their angles are from hanging down: q1 = paa's q1 + pi.

Their metrics read the rows of the CSV that their leaderboard script (``sim_controller.py``) saves from
``Simulator.simulate_and_animate``; which state sits beside which torque in that file changed in their history, and
the energy (a sum of displacement times torque) depends on it. paa_mj's trajectory has rows k = 0..N:
(t_k, x_k, u_k), u_k held from t_k to t_{k+1} (the last torque is never applied). ``record`` picks the rows:

``current``      double_pendulum since 4cddb6c (2024-05-21) up to 1e8544e6: the recorder holds (t0, x0) first, and
                 ``save_trajectory`` cuts the columns to the shortest, so rows (t_k, x_k, u_k), k = 0..N-1.
``pre-4cddb6c``  double_pendulum before 4cddb6c (e.g. 1a0885e, 2023-03-29), which wrote the sim_swingup.csv behind
                 their published v1 row (real_ai_gym_leaderboard 6c9adf5, 2023-03-30; scored c865432, 2023-07-20):
                 with ``save_video=True`` the recorder was never given (t0, x0), so rows (t_{k+1}, x_{k+1}, u_k),
                 k = 0..N-1: each torque sits beside the state it produced, one sample after the current code.
``as-recorded``  paa_mj's rows as they are (k = 0..N).
"""
import argparse
import sys

import numpy as np

V1_WEIGHTS = dict(swingup_time=0.2, max_tau=0.1, energy=0.1, integ_tau=0.1, tau_cost=0.1, tau_smoothness=0.2,
                  velocity_cost=0.2)
V1_NORMS = dict(swingup_time=10.0, max_tau=6.0, energy=100.0, integ_tau=60.0, tau_cost=360.0, tau_smoothness=12.0,
                velocity_cost=1000.0)
V2_NORMS = dict(swingup_time=20.0, energy=60.0, tau_cost=20.0, tau_smoothness=0.1, velocity_cost=400.0)
RECORDS = ("current", "pre-4cddb6c", "as-recorded")


def their_rows(t, x, u, record="current"):
    """paa_mj's rows k = 0..N (t_k, x_k, u_k; u_k held from t_k to t_{k+1}) as the rows of their saved CSV."""
    if record == "current":
        return t[:-1], x[:-1], u[:-1]
    if record == "pre-4cddb6c":
        return t[1:], x[1:], u[:-1]
    if record == "as-recorded":
        return t, x, u
    raise ValueError(f"record must be one of {RECORDS}, not {record!r}")


def swingup_time(T, X, l1, l2, t_final=10.0, height=0.9):
    """Their get_swingup_time (method "height", has_to_stay): the first time after which the tip stays up."""
    if T[-1] < 0.99 * t_final:
        return np.inf
    tip = -l1 * np.cos(X[:, 0]) - l2 * np.cos(X[:, 0] + X[:, 1])
    up = tip > height * (l1 + l2)
    idx = len(T) - 1
    for i in range(len(up) - 2, 0, -1):
        if not up[i]:
            break
        idx = i
    return float(T[idx])


def energy(X, U):
    """Their get_energy: sum over joints of sum_k abs((x_{k+1} - x_k) u_k), u_k the torque on row k."""
    return float(sum(np.sum(np.abs(np.diff(X[:, j]) * U[:-1, j])) for j in range(U.shape[1])))


def integrated_torque(T, U):
    return float(np.sum(np.abs(U[:-1]) * np.diff(T)[:, None]))


def torque_cost(T, U):
    return float(np.einsum("ij,i,ij", U[:-1], np.diff(T), U[:-1]))


def tau_smoothness(U):
    return float(sum(np.std(np.diff(U[:, j])) for j in range(U.shape[1])))


def velocity_cost(T, X):
    return float(np.einsum("ij,i,ij", X[:-1, 2:], np.diff(T), X[:-1, 2:]))


def metrics(T, X, U, l1, l2, t_final=10.0):
    """Their metrics and both scores of the rows of their CSV: T (K,), X (K, 4) in their angles, U (K, 2)."""
    T, X, U = (np.asarray(a, float) for a in (T, X, U))
    swingup = swingup_time(T, X, l1, l2, t_final)
    success = bool(swingup < T[-1])
    c = dict(swingup_time=swingup, max_tau=float(np.max(np.abs(U))), energy=energy(X, U),
             integ_tau=integrated_torque(T, U), tau_cost=torque_cost(T, U), tau_smoothness=tau_smoothness(U),
             velocity_cost=velocity_cost(T, X))
    v1 = success * (1 - sum(V1_WEIGHTS[k] * c[k] / V1_NORMS[k] for k in V1_WEIGHTS))
    v2 = success * (1 - sum(np.tanh(np.pi * c[k] / n) for k, n in V2_NORMS.items()) / len(V2_NORMS))
    return {"success": success, **c, "score_v1": float(v1), "score_v2": float(v2)}


def scores(t, q, qd, tau2, l1, l2, t_final=10.0, record="current"):
    """The metrics and both scores of one paa_mj run: times t (K,) [s], q, qd (K, 2) in paa_mj's angles, tau2 (K,)
    [N m], each row's torque held from its time on; ``record`` (see the module's text) says which of their code
    paths' CSV rows to score."""
    t = np.asarray(t, float)
    x = np.column_stack([np.asarray(q, float)[:, 0] + np.pi, np.asarray(q, float)[:, 1], np.asarray(qd, float)])
    u = np.column_stack([np.zeros_like(t), np.asarray(tau2, float)])
    return metrics(*their_rows(t, x, u, record), l1, l2, t_final)


def main(argv=None):
    parser = argparse.ArgumentParser(prog="score.py", description=__doc__.splitlines()[0])
    parser.add_argument("trajectory", help="paa_mj's trajectory.csv")
    parser.add_argument("geometry", nargs="*", type=float, metavar="l1 l2 t_final",
                        help="link lengths [m] and the run's length [s] (default 0.2 0.3 10)")
    parser.add_argument("--record", choices=RECORDS, default="current",
                        help="whose CSV rows to score (default: their current code's)")
    args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    if len(args.geometry) not in (0, 3):
        parser.error("give all of l1 l2 t_final, or none")
    l1, l2, t_final = args.geometry or (0.2, 0.3, 10.0)
    d = np.genfromtxt(args.trajectory, delimiter=",", names=True)
    result = scores(d["t"], np.column_stack([d["q1"], d["q2"]]), np.column_stack([d["d1"], d["d2"]]), d["tau2"],
                    l1, l2, t_final, record=args.record)
    print(", ".join(f"{k} {v:.6g}" for k, v in result.items()))
    return result


if __name__ == "__main__":
    main()
