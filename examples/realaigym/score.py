"""RealAIGym's acrobot simulation metrics and scores of a paa_mj trajectory (record with --sample-dt equal to --dt).

    paa-mj simulate --robot realaigym_acrobot_v1 --goal stretched --x0 -3.141592653589793 0 0 0 --dt 0.002 \\
        --t-final 10 --sample-dt 0.002 --controller examples/realaigym/pfl_controller.py:PFLCollocatedLQR_C03 --out run
    python examples/realaigym/score.py run/trajectory.csv

A port of ``double_pendulum/src/python/double_pendulum/analysis/leaderboard.py`` (dfki-ric-underactuated-lab,
commit 1e8544e6): the swing-up time (the tip above 0.9 (l1 + l2) from then to the end), the energy
sum of abs(dq tau), the largest torque, the integrated torque, the torque cost sum tau^2 dt, the torque
smoothness std(diff tau), the velocity cost sum qd^2 dt, and the RealAI scores of their simulation_v1
leaderboard (weights and normalisations of that leaderboard) and simulation_v2 (1 - mean tanh(pi c / n); the
published v2 page omits the pi that the code uses). Their angles are from hanging down: q1 = paa's q1 + pi.
"""
import sys

import numpy as np

V1_WEIGHTS = dict(swingup_time=0.2, max_tau=0.1, energy=0.1, integ_tau=0.1, tau_cost=0.1, tau_smoothness=0.2,
                  velocity_cost=0.2)
V1_NORMS = dict(swingup_time=10.0, max_tau=6.0, energy=100.0, integ_tau=60.0, tau_cost=360.0, tau_smoothness=12.0,
                velocity_cost=1000.0)
V2_NORMS = dict(swingup_time=20.0, energy=60.0, tau_cost=20.0, tau_smoothness=0.1, velocity_cost=400.0)


def scores(t, q, qd, tau2, l1, l2, t_final=10.0):
    """The metrics and both scores of one run: times t (K,) [s], q, qd (K, 2) in paa_mj's angles, tau2 (K,) [N m]."""
    t = np.asarray(t, float)
    x = np.column_stack([np.asarray(q, float)[:, 0] + np.pi, np.asarray(q, float)[:, 1], np.asarray(qd, float)])
    u = np.column_stack([np.zeros_like(t), np.asarray(tau2, float)])
    tip = -l1 * np.cos(x[:, 0]) - l2 * np.cos(x[:, 0] + x[:, 1])
    up = tip > 0.9 * (l1 + l2)
    swingup = np.inf
    if t[-1] >= 0.99 * t_final:
        idx = len(t) - 1
        for i in range(len(up) - 2, 0, -1):
            if not up[i]:
                break
            idx = i
        swingup = t[idx]
    success = bool(swingup < t[-1])
    dt = np.diff(t)
    c = dict(swingup_time=float(swingup), max_tau=float(np.max(np.abs(u))),
             energy=float(np.sum(np.abs(np.diff(x[:, 0]) * u[:-1, 0])) + np.sum(np.abs(np.diff(x[:, 1]) * u[:-1, 1]))),
             integ_tau=float(np.sum(np.abs(u[:-1]) * dt[:, None])),
             tau_cost=float(np.einsum("ij,i,ij", u[:-1], dt, u[:-1])),
             tau_smoothness=float(np.std(np.diff(u[:, 0])) + np.std(np.diff(u[:, 1]))),
             velocity_cost=float(np.einsum("ij,i,ij", x[:-1, 2:], dt, x[:-1, 2:])))
    v1 = success * (1 - sum(V1_WEIGHTS[k] * c[k] / V1_NORMS[k] for k in V1_WEIGHTS))
    v2 = success * (1 - sum(np.tanh(np.pi * c[k] / n) for k, n in V2_NORMS.items()) / len(V2_NORMS))
    return {"success": success, **c, "score_v1": float(v1), "score_v2": float(v2)}


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    if not argv:
        sys.exit("usage: score.py trajectory.csv [l1 l2 t_final]")
    l1, l2, t_final = (float(a) for a in argv[1:4]) if len(argv) > 3 else (0.2, 0.3, 10.0)
    d = np.genfromtxt(argv[0], delimiter=",", names=True)
    result = scores(d["t"], np.column_stack([d["q1"], d["q2"]]), np.column_stack([d["d1"], d["d2"]]), d["tau2"],
                    l1, l2, t_final)
    print(", ".join(f"{k} {v:.6g}" for k, v in result.items()))
    return result


if __name__ == "__main__":
    main()
