"""``paa-mj roa``: the region of attraction of the balance LQR (67) with the torque limit (:mod:`paa_mj.theory.roa`)."""
from __future__ import annotations

import math
import os

from ..errors import PaaError
from .common import file_path, goal_parent, note, positive, positive_int, print_json, robot_parent, seed, \
    task_from_args

#: States sampled in the set and simulated in MuJoCo by default, and trajectories drawn from its edge.
CHECK_STATES = 50
PLOTTED = 6
#: The shortest run of each state of the MuJoCo check [s] (twice the LQR's settling time where that is longer).
CHECK_SECONDS = 10.0


def _torque_limits(robot, given):
    """Each motor's limit [N m]: the model's actuator ranges, capped by --torque-limit; None where none is finite."""
    import numpy as np

    limits = robot.capped_torque_limits(given)
    return limits if np.any(np.isfinite(limits)) else None


def _check_size(states, n, dt):
    """The MuJoCo check's ``states`` (--check) sized before the region is computed: memory and time of that many
    rollouts of at least :data:`CHECK_SECONDS` (one line where it is more than this machine gives)."""
    from ..limits import check_memory, check_steps

    check_memory(states * 2 * n * 8.0 * 4, "the MuJoCo check's states", "--check")
    check_steps(states * CHECK_SECONDS / dt, f"the MuJoCo check of {states} states of at least {CHECK_SECONDS:g} s",
                "--check", links=n, runs=states)


def mujoco_check(robot, task, weights, roa, limits, errors, record=False):
    """States at ``errors`` from the goal simulated in MuJoCo under (67) with the torque limit: how many reach the
    goal (balanced: within the task's tolerance at the end). With ``record``, also their errors over time."""
    import numpy as np

    from ..control.registry import ControllerSpec
    from ..sim.batch import simulate_batch
    from ..theory.roa import settling_time

    n = task.n_links
    if len(errors) == 0:
        return {"states": 0, "reached": 0}, []
    x0 = np.concatenate([task.goal + errors[:, :n], errors[:, n:]], axis=1)
    spec = ControllerSpec("lqr", options=(("lqr_weights", tuple(weights)),) if weights else (), task=task)
    from ..control.lqr import LQRController

    K = LQRController.for_model(robot.analytic, task, weights).K
    t_final = max(CHECK_SECONDS, 2.0 * settling_time(robot.analytic, task, K))
    t_final = t_final if math.isfinite(t_final) else CHECK_SECONDS
    limits = None if limits is None else np.broadcast_to(limits, (len(x0), robot.params.n_motors)).copy()
    result = simulate_batch(robot, x0, t_final, task=task, controller=spec, torque_limit=limits, record=record,
                            sample_dt=0.01, retire=not record, nthread=1)
    paths = []
    if record:
        traj = result.trajectories
        for r in range(len(x0)):
            count = int(traj["count"][r])
            paths.append(task.error(traj["q"][r, :count], traj["qd"][r, :count]))
    out = {"states": int(len(x0)), "reached": int(np.sum(result.balanced)), "t_final": float(t_final),
           "engine": "MuJoCo, the robot's integrator and time step, torque held over each step"}
    return out, paths


def cmd_roa(args):
    import numpy as np

    from ..model.robot import load_robot
    from ..control.lqr import lqr_weights
    from ..theory.linear import LQR_WEIGHT, lqr_solution, lqr_weight_matrices
    from ..theory.roa import choose_method, region_of_attraction, uniform_in_ellipsoid, on_ellipsoid

    robot = load_robot(args.robot)
    task = task_from_args(args, robot)
    n, motors = robot.params.n_links, robot.params.n_motors
    Q, R = lqr_weight_matrices(n, *lqr_weights(n, args.lqr_weights, motors), n_motors=motors)
    K, S = lqr_solution(robot.analytic, task, Q, R)
    limits = _torque_limits(robot, args.torque_limit)
    dt = float(robot.model.opt.timestep)
    if args.samples is not None and (args.method == "sos" or choose_method(args.method, n) == "sos"):
        raise PaaError("--samples applies to --method sampling, not to sos")
    sampled = {} if args.samples is None else {"samples": args.samples}
    _check_size(args.check, n, dt)
    roa = region_of_attraction(robot.analytic, task, K, S, Q, R, u_max=limits, dt=dt, method=args.method,
                               seed=args.seed, progress=not args.json, **sampled)
    rng = np.random.default_rng(args.seed)
    inside = uniform_in_ellipsoid(S, roa.rho, args.check, rng) if roa.rho > 0 else np.zeros((0, 2 * n))
    check, _ = mujoco_check(robot, task, args.lqr_weights, roa, limits, inside)
    if check["reached"] < check["states"]:
        note(f"{check['states'] - check['reached']} of {check['states']} states inside x'Sx <= {roa.rho:.6g} did not"
             " reach the goal in MuJoCo: the set overstates the region of attraction"
             + (" (more --samples gives a safer estimate)" if roa.method == "sampling" else
                " (the certificate is for the Taylor model of the loop)"))
    summary = {"robot": robot.name, "goal": task.name, "controller": "lqr",
               "lqr_weights": list(args.lqr_weights) if args.lqr_weights else [LQR_WEIGHT, 1.0],
               "K": K.tolist(), **roa.to_dict(), "mujoco_check": check, **task.describe()}
    if args.plot:
        from ..outputs.roa import write_roa_figure

        edge = on_ellipsoid(S, roa.rho, PLOTTED, rng) if roa.rho > 0 else np.zeros((0, 2 * n))
        _, paths = mujoco_check(robot, task, args.lqr_weights, roa, limits, edge, record=True)
        stem, suffix = os.path.splitext(args.plot)
        stem = args.plot if suffix not in (".png", ".svg") else stem
        write_roa_figure(os.path.dirname(stem) or ".", os.path.basename(stem), summary, paths)
    if args.json:
        print_json(summary)
    else:
        _print_text(summary)
    return 0


def _print_text(s):
    fraction = s["fraction_of_switch_region_inside"]
    print(f"region of attraction of the LQR (67), robot {s['robot']}, {s['goal']} goal, method {s['method']}:")
    print(f"  rho                  {s['rho']:.6g}  (certified: {s['certified']})")
    print("  rho_torque           " + ("none (no torque limit)" if s["rho_torque"] is None else f"{s['rho_torque']:.6g}"))
    print(f"  spectral radius      {s['spectral_radius']:.4g} at dt = {s['dt']:g} s")
    print(f"  (68) inside          {100 * fraction['fraction']:.2f} % of {fraction['samples']} states")
    print(f"  MuJoCo check         {s['mujoco_check']['reached']} of {s['mujoco_check']['states']} reached the goal")
    print(f"  certificate          {s['certificate']}")


def register(sub, parser_class):
    p = sub.add_parser("roa", parents=[robot_parent(), goal_parent()],
                       help="region of attraction of the balance LQR (67) with the torque limit: x'Sx <= rho",
                       description="An inner estimate x'Sx <= rho (S the Riccati solution of (67)) of the LQR's region"
                                   " of attraction with the torque limit: certified by sums of squares for the"
                                   " degree-3 Taylor model (Drake), or estimated by simulation; with the sampled-data"
                                   " spectral radius, the fraction of region (68) inside and a MuJoCo check.")
    p.add_argument("--controller", choices=("lqr",), default="lqr", help="the balance controller: the LQR (67)")
    p.add_argument("--lqr-weights", type=positive, nargs=2, metavar=("Q", "R"),
                   help="weights of (67): Q = Q I, R = R I (default the paper's 1e4 and 1)")
    p.add_argument("--method", choices=("sos", "sampling"),
                   help="sos (Drake; the default where it imports, chains of up to 4 links) or sampling")
    p.add_argument("--samples", type=positive_int, default=None,
                   help="sampling: states simulated on the boundary of each level tried, and inside the level"
                        " kept (default 64)")
    p.add_argument("--check", type=positive_int, default=CHECK_STATES,
                   help="states sampled uniformly in the set and simulated in MuJoCo")
    p.add_argument("--seed", type=seed, default=0, help="seed of every sample")
    p.add_argument("--torque-limit", type=positive, metavar="T",
                   help="each motor's torque limit [N m] (default: the model's actuator ranges)")
    p.add_argument("--plot", type=file_path, metavar="PATH",
                   help="write slices of the set as PATH.png and PATH.svg")
    p.add_argument("--json", action="store_true", help="one JSON object on stdout")
    p.set_defaults(func=cmd_roa)
