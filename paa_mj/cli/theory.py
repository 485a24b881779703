"""``paa-mj theory``, ``check`` and ``make-model``: the robot and the paper's conditions."""
from __future__ import annotations

from ..errors import PaaError
from .common import file_path, finite, gains_parent, positive, positive_int, print_json, robot_parent, seed


def cmd_theory(args):
    from ..model.robot import load_robot
    from ..outputs.theory_report import theory_report, theory_table

    robot = load_robot(args.robot)
    gains = robot.resolve_gains(args.kD, args.kP, args.kV)
    report = theory_report(robot.analytic, **gains).to_json_dict()
    if args.json:
        print_json(report)
    else:
        print(theory_table(robot.name, report))
    return 0


def cmd_check(args):
    from ..model.crosscheck import cross_check
    from ..model.robot import load_robot

    robot = load_robot(args.robot)
    result = cross_check(robot.model, samples=args.samples, seed=args.seed).as_dict()
    if args.json:
        print_json(result)
    else:
        print(f"MuJoCo against the analytic model of the paper, robot {robot.name}, {args.samples} random states:")
        for key in ("max_rel_err_M", "max_rel_err_bias", "max_rel_err_qacc", "max_rel_err_energy"):
            print(f"  {key:<22} {result[key]:.3e}")
    return 0


def cmd_make_model(args):
    from ..io import write_text
    from ..model.mjcf import compile_mjcf, mjcf_from_params, params_from_model
    from ..model.params import RobotParams

    if args.J is None:
        if args.lc is not None:
            raise PaaError("give --J with --lc (or neither, for uniform rods)")
        params = RobotParams.uniform_rods(args.m, args.l, name=args.name)
    else:
        if args.lc is None:
            raise PaaError("give --lc with --J")
        params = RobotParams(m=args.m, l=args.l, lc=args.lc, J=args.J, name=args.name)
    gains = None
    if any(v is not None for v in (args.kD, args.kP, args.kV)):
        if None in (args.kD, args.kP, args.kV):
            raise PaaError("give all three of --kD --kP --kV to store default gains")
        gains = {"kD": args.kD, "kP": args.kP, "kV": args.kV}
        from ..control.gains import check_gains
        from ..model.dynamics import AnalyticModel

        check_gains(AnalyticModel.from_params(params), **gains)  # every command would refuse the file later
    xml = mjcf_from_params(params, name=args.name, title=args.title, gains=gains)
    params_from_model(compile_mjcf(xml, "generated model"), source="generated model")
    chosen = ""
    if gains is None:
        gains = _rule_gains(params)
        if gains is None:
            chosen = "; no gains stored: the bounds (41), (59), (60) are not finite for this robot"
        else:
            xml = mjcf_from_params(params, name=args.name, title=args.title, gains=gains)
            chosen = ("; stored gains kD = {kD:.6g}, kP = {kP:.6g}, kV = {kV:.6g}, 5 % above the bounds (41),"
                      " (59), (60)").format(**gains)
    write_text(args.out, xml)
    print(f"wrote {args.out}{chosen}")
    return 0


def _rule_gains(params):
    """Gains 5 % above Theorem 1's bounds for ``params`` (the atlas's rule), or None where a bound is not finite."""
    import numpy as np

    from ..control.gains import gain_rule
    from ..model.dynamics import AnalyticModel
    from ..theory.conditions import thresholds

    kd, e1, e2 = thresholds(AnalyticModel.from_params(params))
    gains = gain_rule(kd.value, e1.value, e2.value)
    return gains if all(np.isfinite(v) and v > 0 for v in gains.values()) else None


def register(sub, parser_class):

    p = sub.add_parser("theory", parents=[robot_parent(), gains_parent()],
                       help="thresholds (41), (59), (60), constraint (54), controllability, LQR (67), DUU",
                       description="Every condition of Theorem 1 for a robot and gains, the LQR gain (67) and the"
                                   " closed loop at DUU.")
    p.add_argument("--json", action="store_true", help="one JSON object on stdout")
    p.set_defaults(func=cmd_theory)

    p = sub.add_parser("check", parents=[robot_parent()], help="cross-check MuJoCo against the analytic model",
                       description="MuJoCo's inertia matrix, bias forces, accelerations and energy against (1)-(7)"
                                   " at random states.")
    p.add_argument("--samples", type=positive_int, default=1000, help="random states to compare")
    p.add_argument("--seed", type=seed, default=0, help="seed of the random states")
    p.add_argument("--json", action="store_true", help="one JSON object on stdout")
    p.set_defaults(func=cmd_check)

    p = sub.add_parser("make-model", parents=[gains_parent(stored="5 % above the bounds (41), (59), (60) of the new"
                                                                   " robot")], help="write the MJCF of a gymnast with given parameters",
                       description="Write the MJCF file of a 3-link gymnast (gravity 9.81 m/s^2) from its"
                                   " parameters.")
    p.add_argument("--m", type=positive, nargs=3, required=True, metavar=("M1", "M2", "M3"), help="masses [kg]")
    p.add_argument("--l", type=positive, nargs=3, required=True, metavar=("L1", "L2", "L3"), help="lengths [m]")
    p.add_argument("--lc", type=finite, nargs=3, metavar=("LC1", "LC2", "LC3"),
                   help="joint to centre of mass [m] (default: l/2)")
    p.add_argument("--J", type=positive, nargs=3, metavar=("J1", "J2", "J3"),
                   help="inertia about the centre of mass [kg m^2] (default: m l^2/12)")
    p.add_argument("--name", default="custom", help="the model's name")
    p.add_argument("--title", default="", help="one line for the file's header comment")
    p.add_argument("--out", type=file_path, required=True, metavar="FILE.xml", help="MJCF file to write")
    p.set_defaults(func=cmd_make_model)
