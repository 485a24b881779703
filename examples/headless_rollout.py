"""A headless rollout: load a robot, run a controller, save the trajectory and plot it.

    python examples/headless_rollout.py --out out/example_rollout            # the paper's kip, 30 s
    python examples/headless_rollout.py --controller vc --t-final 20 --out run
    python examples/headless_rollout.py --robot acrobot --goal stretched --out acrobot   # the family

Writes ``trajectory.npz`` (reload it with ``Trajectory.load``), ``trajectory.csv``, ``summary.json``,
``angles.png`` and ``torques.png`` into ``--out``, and prints the outcome.
"""
import argparse

from paa_mj.model import load_robot
from paa_mj.outputs.plots import angles_figure, save_figure, torques_figure
from paa_mj.sim import simulate_mujoco


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default="gymnast", help="a named robot (paa-mj simulate --help) or an MJCF file")
    parser.add_argument("--goal", default="folded", choices=("folded", "stretched"), help="the task's goal")
    parser.add_argument("--controller", default="vcl", help="a built-in name or FILE.py:Class")
    parser.add_argument("--t-final", type=float, default=30.0, help="duration [s]")
    parser.add_argument("--out", default="out/example_rollout", help="output folder")
    args = parser.parse_args(argv)

    robot = load_robot(args.robot)
    traj = simulate_mujoco(robot, args.controller, t_final=args.t_final, task=args.goal)  # from the task's start
    traj.save(args.out)  # trajectory.npz, trajectory.csv, summary.json
    save_figure(angles_figure(traj, f"{robot.name}, {args.controller}: angles"), args.out, "angles")
    save_figure(torques_figure(traj, f"{robot.name}, {args.controller}: torques"), args.out, "torques")
    summary = traj.summary()
    print(f"{robot.name} under {args.controller} for {args.t_final:g} s: first switch at {summary['switch_time']} s,"
          f" success {summary['success']}, peak torques {summary['max_abs_tau']} N m; wrote {args.out}")
    return summary


if __name__ == "__main__":
    main()
