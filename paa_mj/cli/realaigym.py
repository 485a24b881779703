"""``paa-mj realaigym``: RealAIGym's benchmark protocols (performance v2, robustness v2, global policy v3)."""
from __future__ import annotations

from ..errors import PaaError, SimulationDiverged
from .studies import check_engine_args
from .folders import output_lock
from .common import (check_fresh, controller_parent, diverged_note, engine_option, finish, folder, finite,
                     initial_state, note, print_json, robot_parent, seed, spec_from_args)


def cmd_realaigym(args):
    from ..model.robot import load_robot
    from ..realaigym.outputs import write_realaigym
    from ..realaigym.study import run_protocol
    from ..task import Task

    check_fresh(args)
    if args.seed is not None and args.protocol == "performance-v2":
        raise PaaError("--seed applies to the protocols robustness-v2 and global-v3: performance-v2 draws nothing")
    engine = check_engine_args(args)
    robot = load_robot(args.robot)
    task = Task.named(args.goal, robot)
    spec = spec_from_args(args, robot, task)
    x0 = None if args.x0 is None else initial_state(args, robot, task)
    with output_lock(args.out, "realaigym", f"realaigym --protocol {args.protocol}", fresh=args.fresh):
        drawn = {} if args.seed is None else {"seed": args.seed}  # else the protocols' own default
        summary, arrays = run_protocol(args.protocol, robot, spec, task, x0, out_dir=args.out, fresh=args.fresh,
                                       progress=not args.json, **engine, **drawn)
        if args.out and not summary["interrupted"]:
            write_realaigym(args.out, summary, arrays)
    if summary["result"].get("no_action"):
        idle = summary["result"]["no_action"]
        note(f"note: {summary['controller']} exerted no torque (at most {idle['max_abs_tau']:.2g} N m) and the robot"
             f" never left its start {summary['x0']}: the start is an equilibrium of the controller's law, so the"
             " score says nothing of it; start it off the equilibrium (--x0) or try a controller that swings up from"
             " rest (--controller mpc, on every robot of the family)")
    if args.json:
        print_json(summary)
    else:
        _print(summary, args.out)
    code = finish(summary["interrupted"], f"{100 * summary['completed_fraction']:.0f} % of the runs done"
                  f" ({summary['not_run']} not run: null in the JSON)",
                  args.out if args.protocol == "robustness-v2" else None)  # the others' one run keeps nothing
    diverged = summary["result"].get("diverged")
    if code == 0 and diverged:  # one run, diverged: said and exited as simulate says it (what it computed is kept)
        from ..control.catalog import GAIN_CONTROLLERS, HANDS_OVER
        from ..sim.verdict import outcome_words

        words = outcome_words(status=diverged, success=False, task=task, t_final=0.0, switch_time=None,
                              t_region=None, hands_over=spec.name in HANDS_OVER, final_state=[],
                              gains=spec.name in GAIN_CONTROLLERS, engine="protocol")
        raise SimulationDiverged(f"simulation {words}" + (f" (kept in {args.out})" if args.out else ""))
    if code == 0 and summary["result"].get("diverged_runs"):  # a study's runs: counted, each a failure
        diverged_note(summary["result"]["diverged_runs"], summary["result"]["runs"])
    return code


def _num(value, decimals):
    """A criterion for the text line: fixed decimals, 4 significant digits from a million on (a diverged run's
    costs run to 1e138), "none" where the JSON has null (a diverged run's undefined scores)."""
    if value is None or value != value:
        return "none"
    return f"{value:.{decimals}f}" if abs(value) < 1e6 else f"{value:.4g}"


def _print(summary, out):
    result = summary["result"]
    if summary["interrupted"] and summary["protocol"] != "robustness-v2":  # its one run not run: nothing to print
        return
    head = f"{summary['protocol']} on {summary['robot']}, {summary['controller']} ({summary['goal']} goal)"
    if summary["protocol"] == "performance-v2":
        c = result["criteria"]
        print(f"{head}: success {int(c['success'])}, swing-up {_num(c['swingup_time'], 3)} s, energy"
              f" {_num(c['energy'], 2)} J, torque cost {_num(c['tau_cost'], 2)}, smoothness"
              f" {_num(c['tau_smoothness'], 4)}, velocity cost {_num(c['velocity_cost'], 2)}; RealAI score v2"
              f" {_num(result['score'], 3)}" + ("" if result["score_robot_scaled"] == result["score"] else
                                                 f" (robot-scaled {_num(result['score_robot_scaled'], 3)})"))
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
    p.add_argument("--fresh", action="store_true",
                   help="start over in --out: forget the runs kept there, and replace another protocol's or study's"
                        " results (default: resume; a folder holding another's is refused)")
    engine_option(p, ENGINES, extra=" (here their simulator in float64)")
    p.add_argument("--device", metavar="NAME",
                   help="the Warp device of --engine warp: cpu, cuda:0, ... (default: $PAA_MJ_WARP_DEVICE, else the"
                        " first GPU, else cpu)")
    p.add_argument("--json", action="store_true", help="print the summary as one JSON object on stdout")
    p.set_defaults(func=cmd_realaigym)
