"""``paa-mj basin``, ``robustness``, ``compare``, ``atlas``, ``bench``, ``compile``: many rollouts, their costs."""
from __future__ import annotations

from ..errors import PaaError
from .folders import output_lock
from .common import (check_fresh, controller_parent, diverged_note, engine_option, finish, goal_parent, non_negative,
                     note, output_parent, positive, positive_int, print_json, robot_parent, seed, spec_from_args,
                     study_parent, task_from_args, whole_number, TASK_HORIZON)


def _finish_study(summary, args, what):
    return finish(summary["interrupted"], f"{100 * summary['completed_fraction']:.0f} % of the {what} done"
                  f" ({summary['not_run']} of {summary['runs']} runs not run)", args.out)


def _study(args, command, run, write):
    """Load, check, run under the output lock, write, report: the common course of a study command."""
    from ..model.robot import load_robot
    from ..studies.runner import check_scheduler

    check_fresh(args)
    robot = load_robot(args.robot)
    task = task_from_args(args, robot)
    spec = spec_from_args(args, robot, task)
    engine = check_engine_args(args)
    # the warp engine's worlds are one device's: its chunks run in this process unless a scheduler is named
    scheduler = check_scheduler("inline" if args.scheduler is None and engine["engine"] == "warp" else args.scheduler)
    with output_lock(args.out, command, fresh=args.fresh):
        summary, arrays = run(robot, spec, dict(task=task, progress=not args.json, scheduler=scheduler,
                                                out_dir=args.out, fresh=args.fresh, chunk=args.chunk,
                                                torque_limit=args.torque_limit, **engine))
        if args.out and summary["completed_fraction"] > 0:  # no figure of a study with no finished run
            write(args.out, summary, arrays)
    if args.json:
        print_json(summary)
    done = arrays["completed"]
    diverged_note(int((arrays["diverged"] & done).sum()), int(done.sum()))
    return summary


def engine_parent():
    import argparse

    p = argparse.ArgumentParser(add_help=False)
    engine_option(p, ("cpu", "warp"), internal={"cpu": "mujoco"},
                  extra=" (here MuJoCo Warp in float32; chunks inline unless --scheduler)")
    p.add_argument("--device", metavar="NAME",
                   help="the Warp device of --engine warp: cpu, cuda:0, ... (default: $PAA_MJ_WARP_DEVICE, else the"
                        " first GPU, else cpu)")
    return p


def check_engine_args(args) -> dict:
    """The engine options, checked: ``--device`` goes with ``--engine warp``, which needs MuJoCo Warp installed."""
    if args.device is not None and args.engine != "warp":
        raise PaaError("--device chooses the Warp device of --engine warp; drop it or add --engine warp")
    if args.engine == "warp":
        from ..sim.warp.device import device_name, load_warp

        wp, _ = load_warp(mujoco=False)  # MuJoCo Warp checked installed, imported by the engine that runs it
        device_name(wp, args.device)
    return {"engine": args.engine, "device": args.device}


def cmd_basin(args):
    from ..outputs.results import write_basin
    from ..studies.basin import basin, parse_axes

    summary = _study(args, "basin", lambda robot, spec, common: basin(
        robot, parse_axes(args.axes, robot.params.n_links), args.grid, args.t_final, controller=spec, **common),
        write_basin)
    if not args.json and summary["completed_fraction"] > 0:
        done = summary["completed_fraction"]
        print(f"{summary['cells']} starts over ({', '.join(summary['axes'])}), {summary['controller']}:"
              + (f" {100 * done:.0f} % of them finished," if done < 1 else "")
              + f" {100 * summary['success']:.1f} % success, median first switch"
              + (" none (no run switched)" if summary["median_switch_time"] is None else
                 f" {summary['median_switch_time']:.4g} s")
              + (f"; wrote {args.out}/basin.png, basin.svg, basin.npz, summary.json" if args.out else ""))
    return _finish_study(summary, args, "basin")


def cmd_robustness(args):
    from ..outputs.results import write_robustness
    from ..studies.robustness import robustness

    factors = [f.strip() for f in args.factors.split(",") if f.strip()]
    if args.torque_scale is not None and not {"torque_limit", "torque_noise"} & set(factors):
        raise PaaError("--torque-scale applies to the factors torque_limit and torque_noise, and --factors has"
                       " neither")
    summary = _study(args, "robustness", lambda robot, spec, common: robustness(
        robot, trials=args.trials, t_final=args.t_final, seed=args.seed, controller=spec, factors=factors,
        start=args.start, model_error=args.model_error, torque_scale=args.torque_scale, **common), write_robustness)
    if not args.json and summary["completed_fraction"] > 0:
        print(f"robot {summary['robot']}, {summary['controller']}: success rate over up to {summary['trials']}"
              f" {summary['start']} starts per level [95 % interval over random draws; (1 run) where nothing is"
              " drawn]")
        for factor, data in summary["factors"].items():
            cells = ", ".join(f"{'none' if lv['level'] is None else format(lv['level'], 'g')}: "
                              + ("-" if lv["success_rate"] is None else
                                 f"{100 * lv['success_rate']:.0f} % [{100 * lv['low']:.0f}-{100 * lv['high']:.0f}]"
                                 if lv["random"] else f"{100 * lv['success_rate']:.0f} % (1 run)")
                              for lv in data["levels"])
            print(f"  {factor:<13} ({data['label']}): {cells}")
    return _finish_study(summary, args, "robustness study")


def cmd_compare(args):
    from ..model.robot import load_robot
    from ..outputs.results import leaderboard_markdown, write_compare
    from ..studies.compare import compare
    from ..studies.runner import check_scheduler

    names = [n.strip() for n in args.controllers.split(",") if n.strip()]
    if args.gl is not None and (args.no_video or args.out is None):
        raise PaaError("--gl chooses the backend of the video, which " + ("--no-video skips" if args.no_video else
                                                                          "is only made with --out"))
    check_fresh(args)
    robot = load_robot(args.robot)
    scheduler = check_scheduler(args.scheduler)
    video = args.out is not None and not args.no_video
    if video:
        from ..view.gl import select_backend

        try:
            select_backend(args.gl or "auto")
        except PaaError as err:
            note(f"warning: no video: {err}")
            video = False
    with output_lock(args.out, "compare", fresh=args.fresh):
        summary, trajectories, _ = compare(robot, names, torque_limit=args.torque_limit, trials=args.trials,
                                           quick=args.quick, t_final=args.t_final, seed=args.seed,
                                           task=task_from_args(args, robot), scheduler=scheduler, out_dir=args.out,
                                           fresh=args.fresh, progress=not args.json, grid=args.grid,
                                           chunk=args.chunk)
        if args.out:
            write_compare(args.out, summary, trajectories, robot, video=video and not summary["interrupted"])
    if args.json:
        print_json(summary)
    else:
        print(leaderboard_markdown(summary, written=args.out is not None))
    return finish(summary["interrupted"], f"the leaderboard is incomplete ({summary['not_run']} of"
                  f" {summary['runs']} controllers not run whole)", args.out)


def cmd_atlas(args):
    from ..model.robot import load_robot
    from ..outputs.results import write_atlas
    from ..studies.atlas import atlas, parse_range, parse_vary
    from ..studies.runner import check_scheduler

    factor_range = parse_range(args.range)
    robot = load_robot(args.robot)
    vary = parse_vary(args.vary, robot.params.n_links)
    scheduler = check_scheduler(args.scheduler)
    simulation = {name: value for name, value in (("starts", args.starts), ("t_final", args.t_final),
                                                   ("seed", args.seed), ("torque_limit", args.torque_limit))
                  if value is not None}
    if simulation and not args.simulate:
        given = [f"--{name.replace('_', '-')}" for name in simulation]
        raise PaaError(f"{', '.join(given)} appl{'ies' if len(given) == 1 else 'y'} with --simulate only")
    if args.starts is not None and args.starts < 0:
        raise PaaError(f"--starts must be >= 0, got {args.starts}")
    check_fresh(args)
    with output_lock(args.out, "atlas", fresh=args.fresh):
        summary, arrays = atlas(robot, vary, factor_range, args.grid, simulate=args.simulate, **simulation,
                                scheduler=scheduler, out_dir=args.out, fresh=args.fresh,
                                progress=not args.json, chunk=args.chunk, task=task_from_args(args, robot))
        if args.out:
            write_atlas(args.out, summary, arrays)
    if args.json:
        print_json(summary)
    else:
        print(f"atlas of {summary['robot']} over ({', '.join(summary['vary'])}), {summary['grid']} x {summary['grid']}"
              f" robots, {summary['goal']} goal" + (f"; wrote {args.out}/atlas_theory.png, atlas.json, atlas.npz" if args.out else ""))
        for line in summary["findings"]:
            print(f"  {line}")
    if "outcome" in arrays:  # --simulate: each robot's kip from the task's start
        diverged_note(summary["counts"]["diverged"], int((arrays["outcome"] >= 0).sum()), "kips")
    return finish(summary["interrupted"], f"the atlas is incomplete ({summary['not_run']} of {summary['runs']}"
                  " robots not run)", args.out)


def cmd_bench(args):
    from ..studies.bench import format_bench, run_bench

    from ..realaigym.bench import realaigym_rows

    result = run_bench(batch_size=args.batch_size, progress=not args.json, robot=args.robot, task=args.goal,
                       realaigym=realaigym_rows)
    print_json(result) if args.json else print(format_bench(result))
    return 0


def cmd_compile(args):
    from ..precompile import cache_folder, compile_kernels, kernels_of_several_signatures, uncached_kernels

    stages = compile_kernels(progress=None if args.json else lambda stage: note(f"compiling {stage}"))
    missing = uncached_kernels()
    if args.json:
        print_json({"stages": stages, "cpu_s": sum(s["cpu_s"] for s in stages), "cache": cache_folder(),
                    "uncached": missing, "several_signatures": kernels_of_several_signatures()})
        return 0
    for stage in stages:
        print(f"{stage['cpu_s']:7.1f} CPU-s  {stage['stage']}")
    print(f"kernels cached in {cache_folder()}")
    if missing:
        note(f"warning: not in the cache after compiling: {', '.join(missing)}")
    return 0


def _register_basin(sub):
    from ..studies.settings import BASIN_COORDINATES as COORDINATES, BASIN_MAX_GRID as MAX_GRID

    p = sub.add_parser("basin", parents=[robot_parent(), goal_parent(), controller_parent(), study_parent(), engine_parent(),
                                         output_parent("basin.png, basin.svg, basin.npz, summary.json and the"
                                                       " finished chunks (a rerun resumes)")],
                       help="outcome over a grid of initial states (two coordinates, the others zero)",
                       description="Run the controller from every start of a grid over two coordinates and map"
                                   " how each run ends.")
    p.add_argument("--axes", default="q1,q2", metavar="A,B",
                   help=f"two of {', '.join(COORDINATES)} for the gymnast, of q1..qn, d1..dn for a chain of n links"
                        " (angles over [-pi, pi], speeds over [-5, 5] rad/s)")
    p.add_argument("--grid", type=positive_int, default=64, help=f"points per axis, 2..{MAX_GRID} (starts = grid^2)")
    p.add_argument("--t-final", type=positive, help=f"duration of each run [s] (default: {TASK_HORIZON})")
    p.add_argument("--torque-limit", type=positive, metavar="T",
                   help="saturate each torque of every run at T [N m] (the model's actuator ranges also apply)")
    p.set_defaults(func=cmd_basin)


def _register_robustness(sub):
    from ..studies.settings import ROBUSTNESS_DEFAULT_FACTORS as DEFAULT_FACTORS, ROBUSTNESS_FACTORS as FACTORS, \
        STARTS

    p = sub.add_parser("robustness", parents=[robot_parent(), goal_parent(), controller_parent(), study_parent(),
                                              engine_parent(),
                                              output_parent("one chart per factor (PNG, SVG), robustness.npz,"
                                                            " summary.json and the finished chunks")],
                       help="success rate against noise, limits, model error, delay, pushes and starts",
                       description="Success rate of the controller, one factor at a time, every level on the same"
                                   " starts: with a 95 % Wilson interval where the runs are independent random draws,"
                                   " one run without an interval where a setting is deterministic.")
    p.add_argument("--trials", type=positive_int, default=64, help="starts per level")
    p.add_argument("--t-final", type=positive, help=f"duration of each run [s] (default: {TASK_HORIZON})")
    p.add_argument("--seed", type=seed, default=0, help="seed of the starts and the noise")
    p.add_argument("--factors", default=",".join(DEFAULT_FACTORS), metavar="F,...",
                   help=f"comma-separated, out of {', '.join(FACTORS)}")
    p.add_argument("--start", choices=STARTS, default="random",
                   help="random: angles over a full turn, speeds +-1 rad/s; hanging: the task's start (the kip from"
                        " (65))")
    p.add_argument("--model-error", type=non_negative, nargs="+", metavar="PCT",
                   help="controller model errors to test [%%] (default: 0 2 5 10)")
    p.add_argument("--torque-limit", type=positive, metavar="T",
                   help="saturate each torque of every run at T [N m] (the torque_limit factor goes below it)")
    p.add_argument("--torque-scale", type=positive, metavar="N_M",
                   help="the scale of the torque_limit and torque_noise factors [N m] (default: the peak torque of"
                        " the controller's own run from the task's start)")
    p.set_defaults(func=cmd_robustness)


def _register_compare(sub):
    from ..studies.settings import COMPARE_CONTROLLERS, COMPARE_SIZES, FACTOR_ORDER, factor_label

    p = sub.add_parser("compare", parents=[robot_parent(), goal_parent(), study_parent(),
                                           output_parent("leaderboard.md, leaderboard.json, the charts, kips.npz,"
                                                         " the video and the studies (a rerun resumes)")],
                       help="a leaderboard of kip controllers: performance, robustness and reach",
                       description="Score kip controllers from (65) the way RealAIGym scores swing-ups: time, torque,"
                                   " effort, smoothness and speed of the kip, success under model error, noise,"
                                   " torque noise, delay, pushes and perturbed starts, and reach over a grid of"
                                   " starts. Robustness: " + ", ".join(factor_label(k) for k in FACTOR_ORDER)
                                   + ".")
    p.add_argument("--controllers", default=",".join(COMPARE_CONTROLLERS), metavar="A,B,...",
                   help="built-in names or FILE.py:Class, comma-separated")
    p.add_argument("--torque-limit", type=positive, metavar="T",
                   help="the same torque limit for every controller [N m] (default: vcl's peak torques from the"
                        " task's start, (65))")
    p.add_argument("--trials", type=positive_int,
                   help=f"draws per random robustness factor (default {COMPARE_SIZES['full']['trials']},"
                        f" {COMPARE_SIZES['quick']['trials']} with --quick)")
    p.add_argument("--t-final", type=positive, help=f"duration of each run [s] (default: {TASK_HORIZON})")
    p.add_argument("--grid", type=positive_int,
                   help=f"points per axis of the reach grid over (q1, q2) (default {COMPARE_SIZES['full']['grid']},"
                        f" {COMPARE_SIZES['quick']['grid']} with --quick)")
    p.add_argument("--seed", type=seed, default=0, help="seed of the disturbances")
    p.add_argument("--quick", action="store_true",
                   help="fewer trials, every second level of the sweeps and a coarser reach grid")
    p.add_argument("--no-video", action="store_true", help="skip the side-by-side video")
    p.add_argument("--gl", choices=("auto", "egl", "osmesa"), help="GL backend for the video (default: auto)")
    p.set_defaults(func=cmd_compare)


def _register_atlas(sub):
    from ..studies.settings import ATLAS_MAX_GRID, ATLAS_PARAMETERS, ATLAS_RANGE

    p = sub.add_parser("atlas", parents=[robot_parent(), goal_parent(), study_parent(),
                                         output_parent("atlas.json, atlas.npz, the maps and the finished chunks")],
                       help="which robots can kip: Theorem 1 and the simulated kip over body proportions",
                       description="Scale two parameters of a robot over a log grid of factors and map, for every"
                                   " robot of the family, E_r, constraint (54), deltabar (30), controllability at UDD,"
                                   " kD_min, eta1, eta2 and gains by the rule kD = 1.05 kD_min, kP = 1.05 max(eta1,"
                                   " eta2), kV = kD x (kV/kD of the base); with --simulate, the kip itself. For other"
                                   " chains and the stretched goal, which Theorem 1 does not cover: E_r, kD_min (41) by"
                                   " its definition, controllability at the goal, the merged acrobot's deltabar (30),"
                                   " and kP, kV in the base robot's ratios to kD.")
    p.add_argument("--vary", default="l1,m1", metavar="P1,P2",
                   help=f"two of {', '.join(ATLAS_PARAMETERS)} (on an n-link chain: m1..mn, l1..ln)")
    p.add_argument("--range", default=f"{ATLAS_RANGE[0]:g}:{ATLAS_RANGE[1]:g}", metavar="LOW:HIGH",
                   help="the scale factors' range (log-spaced)")
    p.add_argument("--grid", type=positive_int, default=32, help=f"factors per parameter, 2..{ATLAS_MAX_GRID}")
    p.add_argument("--simulate", action="store_true", help="also run the kip of every robot in MuJoCo")
    p.add_argument("--starts", type=whole_number,
                   help="random starts per robot with --simulate (default 4), besides (65)")
    p.add_argument("--t-final", type=positive,
                   help=f"duration of each simulated kip [s] with --simulate (default: {TASK_HORIZON})")
    p.add_argument("--torque-limit", type=positive, metavar="T",
                   help="saturate each torque of every simulated kip at T [N m] with --simulate (default: none)")
    p.add_argument("--seed", type=seed, help="seed of the random starts with --simulate (default 0)")
    p.set_defaults(func=cmd_atlas)


def _register_bench(sub):
    p = sub.add_parser("bench", parents=[robot_parent(), goal_parent()],
                       help="costs per step: bare mj_step, closed loop, batch, basin, analytic reference",
                       description="Costs measured in one process, reported as ratios of things measured together.")
    p.add_argument("--batch-size", type=positive_int, default=1024, help="rollouts in the batch measurement")
    p.add_argument("--json", action="store_true", help="one JSON object on stdout")
    p.set_defaults(func=cmd_bench)


def _register_compile(sub):
    p = sub.add_parser("compile", help="compile every numba kernel into the cache now (once per install)",
                       description="Compile (or load from the cache) every compiled kernel of the package, once:"
                                   " a fresh install compiles each kernel the first time a process needs it, so"
                                   " processes started together (Dask or pytest workers) would each compile the"
                                   " same ones. Tens of CPU-seconds the first time, about a second when cached.")
    p.add_argument("--json", action="store_true", help="one JSON object on stdout")
    p.set_defaults(func=cmd_compile)


def register(sub, parser_class):
    for add in (_register_basin, _register_robustness, _register_compare, _register_atlas, _register_bench,
                _register_compile):
        add(sub)
