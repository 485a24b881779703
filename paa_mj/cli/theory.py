"""``paa-mj theory``, ``check`` and ``make-model``: the robot and the paper's conditions."""
from __future__ import annotations

from ..errors import PaaError
from ..provenance import text_sha256
from .common import (file_path, finite, gains_parent, goal_parent, links_count, non_negative, positive, positive_int,
                     print_json, robot_parent, search_parent, seed, task_from_args)


def cmd_theory(args):
    from ..model.robot import load_robot
    from ..outputs.theory_report import chain_theory_report, chain_theory_table, theory_report, theory_table
    from ..theory.conditions import chain_kd_min
    from ..theory.linear import require_passive_first, theorem1_covers

    from ..control.gains import FAMILY_RULE, family_gains, resolve_gains
    robot = load_robot(args.robot)
    require_passive_first(robot.analytic, "paa-mj theory (the conditions of Theorem 1, (41), (59), (60), (54))",
                          robot.name)
    task = task_from_args(args, robot)
    if args.kd_budget is not None and not theorem1_covers(robot.analytic, task):
        chain_kd_min(robot.analytic, task, budget_cpu_s=args.kd_budget)  # the gains below then use this search
    gains = resolve_gains(robot, task, args.kD, args.kP, args.kV)
    dt = float(robot.model.opt.timestep)
    if theorem1_covers(robot.analytic, task):
        report = theory_report(robot.analytic, **gains, dt=dt).to_json_dict()
        text = theory_table
    else:
        report = chain_theory_report(robot.analytic, **gains, task=task, dt=dt, kd_budget_cpu_s=args.kd_budget)
        text = chain_theory_table
    report["family_rule"] = {"rule": FAMILY_RULE.describe(), "gains": family_gains(robot.analytic, task)}
    if args.json:
        print_json({"robot": robot.name, "robot_sha256": text_sha256(robot.xml), **task.describe(), **report})
    else:
        print(text(robot.name, report))
    return 0


def cmd_check(args):
    from ..model.crosscheck import AGREEMENT, cross_check
    from ..model.robot import load_robot

    robot = load_robot(args.robot)
    check = cross_check(robot.model, samples=args.samples, seed=args.seed)
    result = {"robot": robot.name, "robot_sha256": text_sha256(robot.xml), **check.as_dict(), "agrees": check.agrees,
              "agreement": AGREEMENT}
    if args.json:
        print_json(result)
    else:
        model = "the paper's (1)-(7)" if robot.analytic.paper_shape else f"the {robot.params.n_links}-link chain's"
        print(f"MuJoCo against the analytic model, {model}, robot {robot.name}, {args.samples} random states:")
        for key in ("max_rel_err_M", "max_rel_err_bias", "max_rel_err_qacc", "max_rel_err_energy"):
            print(f"  {key:<22} {result[key]:.3e}")
        print(f"  agree within {AGREEMENT:g}    {'yes' if check.agrees else 'NO'}")
    if not check.agrees:
        raise PaaError(f"MuJoCo and the analytic model disagree on {robot.name}: a relative error of {check.worst():.3g}"
                       f" > {AGREEMENT:g}; the model has a feature the analytic model does not describe")
    return 0


def cmd_gain_search(args):
    from ..control.gains import FAMILY_RULE
    from ..studies.gain_search import gain_search, search_table

    found = gain_search(t_final=args.t_final, progress=not args.json)
    summary = {"t_final": found["t_final"], "robots": [f"{n} {g}" for n, g in found["robots"]],
               "rules": [vars(rule) for rule in found["rules"]], "success": found["success"].tolist(),
               "best": vars(found["best"]), "family_rule": vars(FAMILY_RULE),
               # a task per robot and goal: each run's success is its own task's
               "success_definition": {label: task.success_definition for label, task in found["tasks"].items()},
               "task": {label: task.describe()["task"] for label, task in found["tasks"].items()}}
    if args.json:
        print_json(summary)
    else:
        print(search_table(found))
        print(f"best rule: {found['best'].describe()}; the family rule: {FAMILY_RULE.describe()}")
    return 0


def _per_link(args, key, count, what):
    """The values of ``--key``: ``count`` of them, or one for all where the option allows it."""
    values = getattr(args, key)
    if values is None:
        return None
    if len(values) == 1 and key in ("damping", "armature", "torque_limit"):
        return values * count
    if len(values) != count:
        raise PaaError(f"--{key.replace('_', '-')} needs {count} values ({what}) for --links {args.links},"
                       f" got {len(values)}")
    return values


def cmd_make_model(args):
    from ..io import write_text
    from ..model.mjcf import mjcf_from_params
    from ..model.mjcf_read import compile_mjcf, params_from_model
    from ..model.params import RobotParams

    n = args.links
    passive = sorted(set(args.passive))
    if any(not 1 <= j <= n for j in passive) or len(passive) != len(args.passive):
        raise PaaError(f"--passive takes distinct joints of 1..{n}, got {' '.join(map(str, args.passive))}")
    actuated = tuple(i for i in range(n) if i + 1 not in passive)
    if not actuated:
        raise PaaError(f"--passive {' '.join(map(str, passive))} leaves no motor: at least one joint must be driven")
    per_link = {key: _per_link(args, key, n, "one per link") for key in ("m", "l", "lc", "J", "damping", "armature")}
    limits = _per_link(args, "torque_limit", len(actuated),
                       "one per motor, joints " + ", ".join(str(j + 1) for j in actuated))
    for key in ("m", "l"):
        if per_link[key] is None:
            raise PaaError(f"give --{key}: {n} values, one per link")
    extra = dict(g=args.gravity, name=args.name, damping=per_link["damping"], armature=per_link["armature"],
                 actuated=actuated)
    if per_link["J"] is None:
        if per_link["lc"] is not None:
            raise PaaError("give --J with --lc (or neither, for uniform rods)")
        params = RobotParams.uniform_rods(per_link["m"], per_link["l"], **extra)
    else:
        if per_link["lc"] is None:
            raise PaaError("give --lc with --J")
        params = RobotParams(m=per_link["m"], l=per_link["l"], lc=per_link["lc"], J=per_link["J"], **extra)
    gains = None
    if not params.passive_first and any(v is not None for v in (args.kD, args.kP, args.kV)):
        raise PaaError(f"--kD --kP --kV are gains of (40), whose theory needs joint 1 alone passive: this robot has"
                       f" {params.actuation_text()}")
    if any(v is not None for v in (args.kD, args.kP, args.kV)):
        if None in (args.kD, args.kP, args.kV):
            raise PaaError("give all three of --kD --kP --kV to store default gains")
        gains = {"kD": args.kD, "kP": args.kP, "kV": args.kV}
        from ..control.gains import check_gains_for
        from ..model.dynamics import AnalyticModel
        from ..task import Task

        model = AnalyticModel.from_params(params)
        check_gains_for(model, **gains, task=Task.named("folded", model))  # every command would refuse it later

    rule_text = ""
    given = gains
    if gains is None and params.passive_first:
        gains, rule_text = _rule_gains(params)
    from ..control.gains import check_runnable_gains
    from ..model.dynamics import AnalyticModel

    if params.passive_first:  # what every run of the robot takes (its stored gains, the family rule's for either
        check_runnable_gains(AnalyticModel.from_params(params), stored=given)  # goal) in every command's range
    timestep, step_text = _time_step(params, args.timestep)
    title = " ".join(t for t in (args.title or "Parameters given by the user.", rule_text, step_text) if t)
    xml = mjcf_from_params(params, name=args.name, title=title, gains=gains, torque_limits=limits, timestep=timestep)
    params_from_model(compile_mjcf(xml, "generated model"), source="generated model")
    chosen = ("; stored gains kD = {kD:.6g}, kP = {kP:.6g}, kV = {kV:.6g}".format(**gains) if gains else
              f"; {params.actuation_text()}, no gains of (40) stored (its theory needs joint 1 alone passive)")
    write_text(args.out, xml)
    print(f"wrote {args.out}{chosen}" + (f" ({rule_text})" if rule_text else ""))
    if step_text:
        print(step_text)
    return 0


def _time_step(params, given):
    """The model's time step [s]: ``given``, else the largest of 1 ms / 2^k at which the balance LQR (67) of both
    goals (the paper's weights) is stable when sampled; and a line for the header and the terminal (empty when
    given)."""
    from ..model.dynamics import AnalyticModel
    from ..task import Task
    from ..theory.linear import balance_time_step

    if given is not None:
        return given, ""
    model = AnalyticModel.from_params(params)
    try:
        step = balance_time_step(model, [Task.named(goal, model) for goal in ("folded", "stretched")])
    except PaaError as err:  # no LQR at a goal: nothing to choose the step by
        return 1e-3, f"Time step 1 ms (the LQR (67) could not choose one: {err})."
    if step is None:
        return 1e-3, ("Time step 1 ms: the balance LQR (67) with the paper's weights is stable when sampled at no"
                      " step down to 1/256 ms; give its runs --lqr-weights Q R.")
    return step, (f"Time step {step * 1e3:g} ms, the largest of 1 ms / 2^k at which the balance LQR (67) of both"
                  " goals is stable when sampled.")


def _rule_gains(params):
    """The family rule's gains for the folded goal (stored), and a line for the file's header with both goals'."""
    from ..control.gains import FAMILY_RULE, family_gains
    from ..model.dynamics import AnalyticModel
    from ..task import Task

    from ..theory.conditions import bracket_words, chain_kd_min
    from ..theory.linear import theorem1_covers

    model = AnalyticModel.from_params(params)
    tasks = {goal: Task.named(goal, model) for goal in ("folded", "stretched")}
    per_goal = {goal: family_gains(model, task) for goal, task in tasks.items()}
    # a search stopped at its budget: its bracket, whose upper end the rule's kD stands on
    brackets = [f"{goal} goal: {bracket_words(kd)}" for goal, task in tasks.items()
                if not theorem1_covers(model, task) and not (kd := chain_kd_min(model, task)).certified]
    text = f"Gains of the family rule ({FAMILY_RULE.describe()}): " + "; ".join(
        f"{goal} goal kD = {g['kD']:.6g}, kP = {g['kP']:.6g}, kV = {g['kV']:.6g}" for goal, g in per_goal.items())
    return per_goal["folded"], text + " (the folded goal's stored)" + (
        f"; kD_min taken at the budget of its search (--kd-budget): {'; '.join(brackets)}." if brackets else ".")


def register(sub, parser_class):

    p = sub.add_parser("theory", parents=[robot_parent(), goal_parent(), gains_parent()],
                       help="thresholds (41), (59), (60), constraint (54), controllability, LQR (67), DUU",
                       description="Every condition of Theorem 1 for a robot and gains, the LQR gain (67) and the"
                                   " closed loop at DUU.")
    p.add_argument("--json", action="store_true", help="one JSON object on stdout")
    p.set_defaults(func=cmd_theory)

    p = sub.add_parser("gain-search", help="the search behind the family rule's gains (no gains given)",
                       description="Kip every stored robot at both goals with vcl under each gain rule of a grid"
                                   " (kD = margin kD_min (41), kP = p kD, kV = v kD): which rules succeed on which.")
    p.add_argument("--t-final", type=positive, default=30.0, help="duration of each kip [s]")
    p.add_argument("--json", action="store_true", help="one JSON object on stdout")
    p.set_defaults(func=cmd_gain_search)

    p = sub.add_parser("check", parents=[robot_parent(searches=False)], help="cross-check MuJoCo against the analytic model",
                       description="MuJoCo's inertia matrix, bias forces, accelerations and energy against (1)-(7)"
                                   " at random states.")
    p.add_argument("--samples", type=positive_int, default=1000, help="random states to compare")
    p.add_argument("--seed", type=seed, default=0, help="seed of the random states")
    p.add_argument("--json", action="store_true", help="one JSON object on stdout")
    p.set_defaults(func=cmd_check)

    p = sub.add_parser("make-model", parents=[search_parent("make-model searches for both goals, so twice the budget"
                                                            " at most, and states any bracket in the file's header"), gains_parent(stored="the family rule's for the folded goal, written"
                                                                   " into the file's header with the stretched goal's")],
                       help="write the MJCF of a chain on the bar (the gymnast by default) with given parameters",
                       description="Write the MJCF file of a planar chain of N links hanging from the bar (by default"
                                   " joint 1 passive, a motor on each of joints 2..N; N = 3 is the gymnast, N = 2 an"
                                   " acrobot; --passive 2 with N = 2 a pendubot) from its parameters, one value per"
                                   " link where they are per link.")
    p.add_argument("--links", type=links_count, default=3, metavar="N", help="number of links N >= 2 (default 3)")
    p.add_argument("--m", type=positive, nargs="+", metavar="M", help="masses [kg], N values")
    p.add_argument("--l", type=positive, nargs="+", metavar="L", help="lengths [m], N values")
    p.add_argument("--lc", type=finite, nargs="+", metavar="LC",
                   help="joint to centre of mass [m], N values (default: l/2)")
    p.add_argument("--J", type=positive, nargs="+", metavar="J",
                   help="inertia about the centre of mass [kg m^2], N values (default: m l^2/12)")
    p.add_argument("--damping", type=non_negative, nargs="+", metavar="D",
                   help="viscous joint damping [N m s/rad], N values or one for all (default 0)")
    p.add_argument("--armature", type=non_negative, nargs="+", metavar="A",
                   help="joint armature (rotor inertia) [kg m^2], N values or one for all (default 0)")
    p.add_argument("--gravity", type=positive, default=9.81, metavar="G", help="gravity [m/s^2] (default 9.81)")
    p.add_argument("--passive", type=positive_int, nargs="+", default=[1], metavar="J",
                   help="the joints without a motor, 1..N (default 1: the hands on the bar, the paper's family, whose"
                        " theory and controllers (12), (40) need it; every other joint carries a motor)")
    p.add_argument("--torque-limit", type=positive, nargs="+", metavar="T",
                   help="each motor's torque limit [N m] (its ctrlrange), one per driven joint or one for all"
                        " (default: none)")
    p.add_argument("--timestep", type=positive, default=None, metavar="DT",
                   help="the model's time step [s] (default: the largest of 1 ms / 2^k at which the balance LQR (67)"
                        " of both goals is stable when sampled, stated in the file's header)")
    p.add_argument("--name", default="custom", help="the model's name")
    p.add_argument("--title", default="", help="one line for the file's header comment")
    p.add_argument("--out", type=file_path, required=True, metavar="FILE.xml", help="MJCF file to write")
    p.set_defaults(func=cmd_make_model)
