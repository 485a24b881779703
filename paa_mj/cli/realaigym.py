"""``paa-mj realaigym``: RealAIGym's benchmark protocols (performance v2, robustness v2, global policy v3)."""
from __future__ import annotations

from ..errors import PaaError
from .studies import check_engine_args
from .common import (check_fresh, controller_parent, finish, folder, finite, initial_state, output_lock, print_json, robot_parent,
                     seed, spec_from_args)


def cmd_realaigym(args):
    from ..model.robot import load_robot
    from ..outputs.realaigym import write_realaigym
    from ..studies.realaigym import run_protocol
    from ..task import Task

    check_fresh(args)
    if args.seed is not None and args.protocol == "performance-v2":
        raise PaaError("--seed applies to the protocols robustness-v2 and global-v3: performance-v2 draws nothing")
    engine = check_engine_args(args)
    robot = load_robot(args.robot)
    task = Task.named(args.goal, robot)
    spec = spec_from_args(args, robot, task)
    x0 = None if args.x0 is None else initial_state(args, robot, task)
    with output_lock(args.out, "realaigym"):
        drawn = {} if args.seed is None else {"seed": args.seed}  # else the protocols' own default
        summary, arrays = run_protocol(args.protocol, robot, spec, task, x0, out_dir=args.out, fresh=args.fresh,
                                       progress=not args.json, **engine, **drawn)
        if args.out and not summary["interrupted"]:
            write_realaigym(args.out, summary, arrays)
    if args.json:
        print_json(summary)
    else:
        _print(summary, args.out)
    return finish(summary["interrupted"], f"{100 * summary['completed_fraction']:.0f} % of the runs done", args.out)


def _print(summary, out):
    result = summary["result"]
    head = f"{summary['protocol']} on {summary['robot']}, {summary['controller']} ({summary['goal']} goal)"
    if summary["protocol"] == "performance-v2":
        c = result["criteria"]
        print(f"{head}: success {int(c['success'])}, swing-up {c['swingup_time']:.3f} s, energy {c['energy']:.2f} J,"
              f" torque cost {c['tau_cost']:.2f}, smoothness {c['tau_smoothness']:.4f}, velocity cost"
              f" {c['velocity_cost']:.2f}; RealAI score v2 {result['score']:.3f}")
    elif summary["protocol"] == "global-v3":
        print(f"{head}, seed {summary['seed']}: up {result['time_up']:.3f} s of 60, score {result['score']:.3f}")
    elif "scores" in result:
        s = result["scores"]
        print(f"{head}, seed {summary['seed']}: " + ", ".join(f"{k} {100 * v:.1f} %" for k, v in s.items()
                                                              if k != "overall")
              + f"; overall {s['overall']:.3f}")
    if out and not summary["interrupted"]:
        print(f"wrote {out}/realaigym.json and the files of the protocol")


def register(sub, parser_class):
    from ..studies.settings import REALAIGYM_ENGINES as ENGINES, REALAIGYM_PROTOCOLS as PROTOCOLS

    p = sub.add_parser("realaigym", parents=[robot_parent("realaigym_acrobot"), controller_parent()],
                       help="RealAIGym's benchmark protocols, as their code computes them",
                       description="Run a controller through one of RealAIGym's acrobot and pendubot leaderboard"
                                   " protocols (double_pendulum 1e8544e6): performance v2 (RealAI score), robustness v2"
                                   " (six criteria, 21 levels each) or the global policy test v3 (60 s, 15 random"
                                   " resets), on their acrobot, their pendubot (--robot realaigym_pendubot) or any"
                                   " robot of the family.")
    p.add_argument("--protocol", choices=PROTOCOLS, required=True,
                   help="performance-v2 (10 s, the RealAI score), robustness-v2 (722 runs, six criteria) or global-v3"
                        " (60 s, 15 random resets, the time up)")
    p.add_argument("--goal", choices=("folded", "stretched"), default="stretched",
                   help="the goal (default stretched: every link up, their acrobot's goal)")
    p.add_argument("--x0", type=finite, nargs="+", metavar="X",
                   help="start q1..qn d1..dn in paa_mj's angles [rad, rad/s] (default: hanging at rest, their"
                        " [0, 0, 0, 0], which is -pi 0 0 0 here)")
    p.add_argument("--seed", type=seed, default=None,
                   help="seed of the random draws (default 777, the one their pendubot script has commented out;"
                        " their acrobot script draws unseeded)")
    p.add_argument("--out", type=folder, metavar="DIR", help="folder for realaigym.json, the CSV or the charts"
                   " (robustness: the finished runs too, a rerun resumes)")
    p.add_argument("--fresh", action="store_true", help="forget the runs kept in --out")
    p.add_argument("--engine", choices=ENGINES, default="cpu",
                   help="cpu: their simulator compiled on this machine's CPU; warp: every run a thread of a Warp"
                        " device, the controller on the device too (pip install 'paa_mj[gpu]'; float64; every built-in"
                        " controller, not a Python one)")
    p.add_argument("--device", metavar="NAME",
                   help="the Warp device of --engine warp: cpu, cuda:0, ... (default: $PAA_MJ_WARP_DEVICE, else the"
                        " first GPU, else cpu)")
    p.add_argument("--json", action="store_true", help="print the summary as one JSON object on stdout")
    p.set_defaults(func=cmd_realaigym)
