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

from paa_mj.realaigym.scores import performance, up_rows

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


def metrics(T, X, U, l1, l2, t_final=10.0):
    """Their metrics and both scores of the rows of their CSV: T (K,), X (K, 4) in their angles, U (K, 2)
    (paa_mj.realaigym.scores.performance, the tip's goal height l1 + l2)."""
    return performance(T, X, U, up_rows(X, (l1, l2), l1 + l2), t_final)


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
