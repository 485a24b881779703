"""``paa-mj simulate`` and ``paa-mj reproduce``: rollouts and the paper redone."""
from __future__ import annotations

import warnings

from .errors import PaaError


def add_simulation_options(p):
    """Options shared by every command that runs a rollout (simulate, render, view)."""
    p.add_argument("--robot", default="gymnast",
                   help="gymnast (Table 1), example2 (Table 2) or a path to an MJCF file of the same shape")
    p.add_argument("--engine", choices=("mujoco", "analytic"), default="mujoco")
    p.add_argument("--t-final", type=float, default=30.0, help="duration [s] (default 30)")
    p.add_argument("--dt", type=float, help="physics time step [s] (default: the model's, 0.001)")
    p.add_argument("--integrator", help="RK4 (model default), Euler, implicitfast or implicit")
    p.add_argument("--x0", type=float, nargs=6, metavar="X", help="q1 q2 q3 d1 d2 d3 (default (65): -pi 0 0 0 0 0)")
    p.add_argument("--kD", type=float)
    p.add_argument("--kP", type=float)
    p.add_argument("--kV", type=float)
    p.add_argument("--no-switch", action="store_true", help="keep controller (40) all the time (no LQR)")
    p.add_argument("--torque-limit", type=float, help="saturate each torque at this value [N m]")
    p.add_argument("--sample-dt", type=float, default=0.01, help="recording interval [s]")


def controller_from_args(args):
    """The robot, the hybrid controller and the initial state the simulation options describe."""
    from .controllers import SwitchingController
    from .model import load_robot
    from .rollout import X0_HANGING

    robot = load_robot(args.robot)
    gains = robot.resolve_gains(args.kD, args.kP, args.kV)
    if args.torque_limit is not None and not args.torque_limit > 0:
        raise PaaError(f"--torque-limit must be > 0, got {args.torque_limit}")
    controller = SwitchingController.for_model(robot.analytic, **gains, torque_limit=args.torque_limit,
                                               enabled=not args.no_switch)
    return robot, controller, X0_HANGING if args.x0 is None else args.x0


def run_from_args(args, progress=True):
    """Build the robot and controller from the options and run the rollout."""
    from .rollout import simulate_analytic, simulate_mujoco

    robot, controller, x0 = controller_from_args(args)
    if args.engine == "analytic":
        if args.dt is not None or args.integrator is not None:
            warnings.warn("--dt and --integrator do not apply to the analytic engine (continuous-time control)")
        return robot, simulate_analytic(robot, controller, x0, args.t_final, sample_dt=args.sample_dt,
                                        progress=progress)
    return robot, simulate_mujoco(robot, controller, x0, args.t_final, dt=args.dt, integrator=args.integrator,
                                  sample_dt=args.sample_dt, progress=progress)


def cmd_simulate(args):
    from .errors import SimulationDiverged
    from .io import dumps

    try:
        _, traj = run_from_args(args, progress=not args.json)
    except SimulationDiverged as err:
        if args.out and err.trajectory is not None and len(err.trajectory):
            err.trajectory.save(args.out)
            raise SimulationDiverged(f"{err} (kept {len(err.trajectory)} samples in {args.out})") from None
        raise
    if args.out:
        out = traj.save(args.out)
        if not args.json:
            print(f"wrote {out}/trajectory.npz, trajectory.csv, summary.json")
    summary = traj.summary()
    if args.json:
        print(dumps(summary))
    else:
        st = summary["switch_time"]
        print(f"robot {summary['robot']}, {summary['engine']} ({summary['integrator']}, dt = {summary['dt']}),"
              f" {summary['final_time']:.3f} s")
        print(f"  switch to LQR at     {'never' if st is None else f'{st:.4f} s'}")
        print(f"  balanced at UDD      {summary['balanced']}")
        print(f"  E - E_r at the end   {summary['E_minus_Er_final']:.6g} J")
        print(f"  V at the end         {summary['V_final']:.6g}")
        print(f"  max |tau2|, |tau3|   {summary['max_abs_tau'][0]:.2f}, {summary['max_abs_tau'][1]:.2f} N m")
    return 0


def cmd_reproduce(args):
    from .reproduce import reproduce

    gl_backend = None
    if not args.no_video:
        from .gl import select_backend

        try:
            gl_backend = select_backend(args.gl)
        except PaaError as err:
            print(f"paa-mj: warning: no video: {err}")
    report = reproduce(args.out, quick=args.quick, video=gl_backend is not None)
    print(f"report: {report}")
    return 0


def register(sub, parser_class):
    p = sub.add_parser("simulate", help="run the controller from an initial state")
    add_simulation_options(p)
    p.add_argument("--out", help="folder for trajectory.npz, trajectory.csv and summary.json")
    p.add_argument("--json", action="store_true", help="print the summary as one JSON object")
    p.set_defaults(func=cmd_simulate)

    p = sub.add_parser("reproduce", help="redo the paper: simulations, figures 5-14, report, video")
    p.add_argument("--out", default="out/reproduction")
    p.add_argument("--quick", action="store_true", help="shorter discretisation study (for tests)")
    p.add_argument("--no-video", action="store_true")
    p.add_argument("--gl", default="auto", help="GL backend for the video: auto, egl or osmesa")
    p.set_defaults(func=cmd_reproduce)

    register_render(sub)
    register_studies(sub)
    register_view(sub)


def cmd_render(args):
    from .gl import select_backend

    backend = select_backend(args.gl)  # before anything imports mujoco's GL
    from pathlib import Path

    from .model import load_robot
    from .trajectory import Trajectory
    from .video import VIDEO_SUFFIXES, render_trajectory

    out = Path(args.out)
    if out.suffix.lower() not in VIDEO_SUFFIXES:
        raise PaaError(f"--out must end in .mp4 or .gif, got {out.name}")
    if args.from_file:
        robot = load_robot(args.robot)
        traj = Trajectory.load(args.from_file)
    else:
        robot, traj = run_from_args(args, progress=True)
    render_trajectory(robot, traj, out, fps=args.fps, width=args.width, height=args.height, camera=args.camera,
                      progress=True)
    print(f"wrote {out} ({backend}, {args.fps:g} fps, {args.width}x{args.height})")
    return 0


def register_render(sub):
    p = sub.add_parser("render", help="offscreen video of a rollout (EGL or OSMesa)")
    add_simulation_options(p)
    p.add_argument("--from", dest="from_file", metavar="TRAJ.npz", help="replay a saved trajectory instead of simulating")
    p.add_argument("--out", required=True, help="FILE.mp4 or FILE.gif")
    p.add_argument("--fps", type=float, default=30.0)
    p.add_argument("--width", type=int, default=640)
    p.add_argument("--height", type=int, default=480)
    p.add_argument("--gl", default="auto", help="auto (EGL, then OSMesa), egl or osmesa")
    p.add_argument("--camera", default="side")
    p.set_defaults(func=cmd_render)


def cmd_bench(args):
    from .bench import format_bench, run_bench
    from .io import dumps

    result = run_bench(batch_size=args.batch_size, progress=not args.json)
    print(dumps(result) if args.json else format_bench(result))
    return 0


def _scheduler(args):
    """--scheduler: inline, local (default when Dask is installed) or a Dask scheduler address."""
    from .distributed import dask_available

    if args.scheduler is None:
        return "local" if dask_available() else "inline"
    if args.scheduler not in ("inline", "local") and "://" not in args.scheduler:
        raise PaaError(f"--scheduler must be inline, local or an address like tcp://host:8786, got {args.scheduler!r}")
    return args.scheduler


def _add_scheduler(p):
    p.add_argument("--scheduler", help="inline, local (a local Dask cluster; default when Dask is installed) "
                                       "or a Dask scheduler address such as tcp://host:8786")


def register_studies(sub):
    p = sub.add_parser("bench", help="costs per step: bare mj_step, closed loop, batch, analytic reference")
    p.add_argument("--batch-size", type=int, default=1024)
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_bench)

    p = sub.add_parser("basin", help="outcome over a grid of initial states (two coordinates, others zero)")
    p.add_argument("--robot", default="gymnast")
    p.add_argument("--axes", default="q1,q2", help="two of q1 q2 q3 d1 d2 d3 (angles over [-pi, pi], speeds over [-5, 5])")
    p.add_argument("--grid", type=int, default=64, help="points per axis (cells = grid^2)")
    p.add_argument("--t-final", type=float, default=30.0)
    p.add_argument("--kD", type=float)
    p.add_argument("--kP", type=float)
    p.add_argument("--kV", type=float)
    p.add_argument("--out", help="folder for basin.png, basin.npz, summary.json")
    _add_scheduler(p)
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_basin)

    p = sub.add_parser("robustness", help="success rate against noise, torque limits, model error and delay")
    p.add_argument("--robot", default="gymnast")
    p.add_argument("--trials", type=int, default=64, help="random initial states per level")
    p.add_argument("--t-final", type=float, default=30.0)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--model-error", type=float, nargs="+", metavar="PCT",
                   help="controller model errors to test [%%] (default 0 2 5 10)")
    p.add_argument("--out", help="folder for one plot per factor, robustness.npz, summary.json")
    _add_scheduler(p)
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_robustness)


def cmd_basin(args):
    from .io import dumps
    from .model import load_robot
    from .studies import basin, parse_axes, write_basin

    axes = parse_axes(args.axes)
    robot = load_robot(args.robot)
    gains = robot.resolve_gains(args.kD, args.kP, args.kV)
    summary, arrays = basin(robot, axes, args.grid, args.t_final, gains=[gains["kD"], gains["kP"], gains["kV"]],
                            progress=not args.json, scheduler=_scheduler(args))
    if args.out:
        write_basin(args.out, summary, arrays)
    if args.json:
        print(dumps(summary))
    else:
        print(f"{summary['cells']} cells over ({', '.join(summary['axes'])}): {100 * summary['success_fraction']:.1f} %"
              f" balanced, median first switch {summary['median_switch_time']} s"
              + (f"; wrote {args.out}/basin.png, basin.npz, summary.json" if args.out else ""))
    if summary["interrupted"]:
        print(f"paa-mj: interrupted at t = {summary['t_reached']:.3f} s; results so far kept", file=__import__("sys").stderr)
        return 130
    return 0


def cmd_robustness(args):
    from .io import dumps
    from .model import load_robot
    from .studies import robustness, write_robustness

    robot = load_robot(args.robot)
    if not args.t_final > 0:
        raise PaaError(f"--t-final must be > 0, got {args.t_final}")
    summary, arrays = robustness(robot, trials=args.trials, t_final=args.t_final, seed=args.seed,
                                 progress=not args.json, scheduler=_scheduler(args), model_error=args.model_error)
    if args.out:
        write_robustness(args.out, summary, arrays)
    if args.json:
        print(dumps(summary))
    else:
        print(f"robot {summary['robot']}: success rate over {summary['trials']} random starts per level")
        for factor, data in summary["factors"].items():
            cells = ", ".join(f"{'none' if lv['level'] is None else format(lv['level'], 'g')}: "
                              f"{100 * lv['success_rate']:.0f} %" for lv in data["levels"])
            print(f"  {factor:<13} ({data['label']}): {cells}")
    return 130 if summary["interrupted"] else 0


def cmd_view(args):
    """MuJoCo's interactive viewer with the controller running, in real time."""
    import os
    import sys
    import time

    if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise PaaError("no display (DISPLAY and WAYLAND_DISPLAY are unset): the viewer needs a screen;"
                       " use 'paa-mj render' for a video instead")
    if os.environ.get("MUJOCO_GL") in ("egl", "osmesa"):
        raise PaaError(f"MUJOCO_GL={os.environ['MUJOCO_GL']} is for offscreen rendering; unset it to open the viewer")
    import mujoco
    import mujoco.viewer

    from .rollout import mujoco_model_for, validate_run

    robot, controller, x0 = controller_from_args(args)
    x0 = validate_run(x0, args.t_final, args.dt)
    model = mujoco_model_for(robot, args.dt, args.integrator)
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:] = x0[:3], x0[3:]
    mujoco.mj_forward(model, data)
    try:
        viewer = mujoco.viewer.launch_passive(model, data)
    except Exception as err:  # GLFW failures come as several types
        raise PaaError(f"cannot open the viewer: {' '.join(str(err).split())}") from None
    with viewer:
        start = last_sync = time.perf_counter()
        while viewer.is_running() and data.time < args.t_final:
            data.ctrl[:] = controller.torque(data.qpos, data.qvel)
            mujoco.mj_step(model, data)
            ahead = data.time - (time.perf_counter() - start)
            if ahead > 0:
                time.sleep(ahead)
            if time.perf_counter() - last_sync > 1 / 60:  # refresh at about 60 Hz of wall time
                viewer.sync()
                last_sync = time.perf_counter()
    return 0


def register_view(sub):
    p = sub.add_parser("view", help="MuJoCo's interactive viewer with the controller running (needs a display)")
    add_simulation_options(p)
    p.set_defaults(func=cmd_view)
