"""The ``paa-mj`` command line: a thin layer over the package.

Every failure the user can cause ends in one line on stderr and exit code 2
(3 for a simulation that diverged, after what was computed has been kept).
"""
from __future__ import annotations

import argparse
import sys
import warnings

from .errors import PaaError, SimulationDiverged

EXIT_BAD_INPUT = 2
EXIT_DIVERGED = 3


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        raise PaaError(f"{self.prog}: {message}")


def _add_robot(p):
    p.add_argument("--robot", default="gymnast",
                   help="gymnast (Table 1), example2 (Table 2) or a path to an MJCF file of the same shape")


def _add_gains(p):
    p.add_argument("--kD", type=float, help="gain kD of (40) (default: the robot's stored gains)")
    p.add_argument("--kP", type=float, help="gain kP of (40)")
    p.add_argument("--kV", type=float, help="gain kV of (40)")


def _print_json(obj):
    from .io import dumps

    print(dumps(obj))


# --- theory ------------------------------------------------------------------------

def cmd_theory(args):
    from .model import load_robot
    from .report_text import theory_table
    from .theory import theory_report

    robot = load_robot(args.robot)
    gains = robot.resolve_gains(args.kD, args.kP, args.kV)
    report = theory_report(robot.analytic, **gains).to_json_dict()
    if args.json:
        _print_json(report)
    else:
        print(theory_table(robot.name, report))
    return 0


def cmd_check(args):
    from .crosscheck import cross_check
    from .model import load_robot

    if args.samples < 1:
        raise PaaError("--samples must be at least 1")
    robot = load_robot(args.robot)
    result = cross_check(robot.model, samples=args.samples, seed=args.seed).as_dict()
    if args.json:
        _print_json(result)
    else:
        print(f"MuJoCo against the analytic model of the paper, robot {robot.name}, {args.samples} random states:")
        for key in ("max_rel_err_M", "max_rel_err_bias", "max_rel_err_qacc", "max_rel_err_energy"):
            print(f"  {key:<22} {result[key]:.3e}")
    return 0


def cmd_make_model(args):
    from .io import write_text
    from .model import mjcf_from_params, model_from_xml
    from .params import RobotParams

    if args.J is None:
        params = RobotParams.uniform_rods(args.m, args.l, g=args.g, name=args.name) if args.lc is None else None
        if params is None:
            raise PaaError("give --J (or neither --lc nor --J for uniform rods)")
    else:
        if args.lc is None:
            raise PaaError("give --lc with --J")
        params = RobotParams(m=args.m, l=args.l, lc=args.lc, J=args.J, g=args.g, name=args.name)
    gains = None
    if any(v is not None for v in (args.kD, args.kP, args.kV)):
        if None in (args.kD, args.kP, args.kV):
            raise PaaError("give all three of --kD --kP --kV to store default gains")
        gains = {"kD": args.kD, "kP": args.kP, "kV": args.kV}
    xml = mjcf_from_params(params, name=args.name, title=args.title, gains=gains)
    model_from_xml(xml, source="generated model")
    write_text(args.out, xml)
    print(f"wrote {args.out}")
    return 0


def build_parser():
    parser = _Parser(prog="paa-mj", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    p = sub.add_parser("theory", help="thresholds (41), (59), (60), constraint (54), controllability, LQR, DUU")
    _add_robot(p)
    _add_gains(p)
    p.add_argument("--json", action="store_true", help="one JSON object on stdout")
    p.set_defaults(func=cmd_theory)

    p = sub.add_parser("check", help="cross-check MuJoCo against the analytic model")
    _add_robot(p)
    p.add_argument("--samples", type=int, default=1000)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_check)

    p = sub.add_parser("make-model", help="write the MJCF of a gymnast with given parameters")
    p.add_argument("--m", type=float, nargs=3, required=True, metavar=("M1", "M2", "M3"), help="masses [kg]")
    p.add_argument("--l", type=float, nargs=3, required=True, metavar=("L1", "L2", "L3"), help="lengths [m]")
    p.add_argument("--lc", type=float, nargs=3, metavar=("LC1", "LC2", "LC3"), help="joint to COM [m] (default l/2)")
    p.add_argument("--J", type=float, nargs=3, metavar=("J1", "J2", "J3"), help="inertia about COM [kg m^2] (default m l^2/12)")
    p.add_argument("--g", type=float, default=9.81)
    p.add_argument("--name", default="custom")
    p.add_argument("--title", default="")
    _add_gains(p)
    p.add_argument("--out", required=True, help="MJCF file to write")
    p.set_defaults(func=cmd_make_model)

    from .cli_sim import register

    register(sub, _Parser)  # simulation, reproduction, video, studies, viewer
    return parser


def main(argv=None):
    from .controllers import TheoryWarning

    warnings.formatwarning = lambda msg, cat, *a, **k: f"paa-mj: warning: {msg}\n"
    warnings.simplefilter("always", TheoryWarning)
    try:
        args = build_parser().parse_args(argv)
        return args.func(args)
    except SimulationDiverged as err:
        print(f"paa-mj: error: {err}", file=sys.stderr)
        return EXIT_DIVERGED
    except PaaError as err:
        print(f"paa-mj: error: {err}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("paa-mj: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
