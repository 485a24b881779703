"""``paa-mj simulate``, ``render`` and ``view``: one rollout, recorded, filmed or watched."""
from __future__ import annotations

import argparse

from ..errors import PaaError, SimulationDiverged
from .folders import output_lock
from .common import (controller_parent, engine_option, file_path, finish, finite, goal_parent, initial_state, output_parent, physics_parent, positive, positive_int, print_json, robot_parent, spec_from_args,
                     task_from_args)


def run_parent(robot_default="gymnast"):
    """Options of a recorded rollout (simulate, render)."""
    p = argparse.ArgumentParser(add_help=False, parents=[robot_parent(robot_default), goal_parent(),
                                                         controller_parent(), physics_parent()])
    engine_option(p, ("cpu", "analytic"), internal={"cpu": "mujoco"})
    p.add_argument("--x0", type=finite, nargs="+", metavar="X",
                   help="initial q1..qn d1..dn [rad, rad/s], 2n numbers (default: the task's start: hanging at rest,"
                        " (65) for the gymnast: -pi 0 0 0 0 0; at the stretched goal link 1 turned a little off"
                        " hanging, an equilibrium of (40) there; --json states x0)")
    p.add_argument("--no-switch", action="store_true", help="the same as --controller vcl-only")
    p.add_argument("--sample-dt", type=positive, default=0.01, help="recording interval [s], at most --t-final")
    return p


def _check_engine_options(args):
    if args.engine == "analytic":
        given = [name for name, value in (("--dt", args.dt), ("--integrator", args.integrator)) if value is not None]
        if given:
            raise PaaError(f"{' and '.join(given)} {'do' if len(given) > 1 else 'does'} not apply to --engine analytic"
                           " (solve_ivp, continuous-time control); drop "
                           + ("them" if len(given) > 1 else "it") + " or use --engine cpu")
    if args.sample_dt > args.t_final:
        raise PaaError(f"--sample-dt {args.sample_dt:g} s is longer than --t-final {args.t_final:g} s")


def check_duration(t_final, dt):
    """Refuse a run too long to count: ``t_final / dt`` steps overflow a float (the engines count them as one).

    A long run whose steps can be counted is refused by the engine's own time budget, which says
    how long it would take.
    """
    import math

    from ..limits import MAX_SECONDS

    if not math.isfinite(t_final / dt):
        exponent = math.log10(t_final) - math.log10(dt)
        raise PaaError(f"--t-final {t_final:g} s is too long: it would need about 1e+{math.floor(exponent)} physics"
                       f" steps of {dt:g} s, far beyond the limit of {MAX_SECONDS / 86400:g} day of computing;"
                       " lower --t-final")


def run_from_args(args, progress=True):
    """Build the robot and controller from the options and run the rollout (returns robot, trajectory)."""
    from ..model.robot import load_robot
    from ..sim.analytic.engine import simulate_analytic
    from ..sim.rollout import simulate_mujoco

    robot = load_robot("gymnast" if args.robot is None else args.robot)  # an empty --robot is refused
    task = task_from_args(args, robot)  # also --t-final's default, the task's horizon
    _check_engine_options(args)
    # the analytic engine has no time step; its cost is counted at 1 ms as in its own check
    step = args.dt or (1e-3 if args.engine == "analytic" else float(robot.model.opt.timestep))
    check_duration(args.t_final, step)
    spec = spec_from_args(args, robot, task)
    controller = spec.build(robot)
    x0 = initial_state(args, robot, task)
    try:
        if args.engine == "analytic":
            traj = simulate_analytic(robot, controller, x0, args.t_final, task=task, sample_dt=args.sample_dt,
                                     torque_limit=args.torque_limit, progress=progress, partial=True)
        else:
            traj = simulate_mujoco(robot, controller, x0, args.t_final, task=task, dt=args.dt,
                                   integrator=args.integrator, sample_dt=args.sample_dt,
                                   torque_limit=args.torque_limit, progress=progress, partial=True)
    except SimulationDiverged as err:
        if err.trajectory is not None:
            err.trajectory.robot_xml = robot.xml  # what is kept of it names its robot too
        raise
    # the saved file then identifies the robot by its model, not by a name a modified file shares
    traj.robot_xml = robot.xml
    return robot, traj


def cmd_simulate(args):
    with output_lock(args.out, "simulate"):
        try:
            robot, traj = run_from_args(args, progress=not args.json)
        except SimulationDiverged as err:
            if args.json and err.trajectory is not None and len(err.trajectory):
                print_json(err.trajectory.summary())  # what was computed, with its status, as for an interrupt
            if args.out and err.trajectory is not None and len(err.trajectory):
                err.trajectory.save(args.out)
                raise SimulationDiverged(f"{err} (kept {len(err.trajectory)} samples in {args.out})") from None
            raise
        if not len(traj):  # stopped before the first sample: nothing to keep, nothing to summarise
            return finish(True, "stopped before the first sample; nothing written")
        if args.out:
            out = traj.save(args.out)
            if not args.json:
                print(f"wrote {out}/trajectory.npz, trajectory.csv, summary.json")
    summary = traj.summary()
    if args.json:
        print_json(summary)
    else:
        st = summary["switch_time"]
        print(f"robot {summary['robot']}, controller {summary['controller']}, {summary['engine']}"
              f" ({summary['integrator']}, dt = {summary['dt']}), {summary['final_time']:.3f} s")
        if summary.get("gains"):
            print(f"  gains                {_gains_line(robot, traj, summary['gains'])}")
        from ..control.catalog import HANDS_OVER

        if summary.get("controller") not in HANDS_OVER:  # no swing-up to hand over from: no switch to speak of
            print("  switch to balance    none (" + ("the balance (67) from the start)" if st == 0.0 else
                                                   "the controller hands over to no balance)"))
        else:
            print(f"  switch to balance    {'never' if st is None else f'{st:.4f} s'}")
        print(f"  outcome              {summary['outcome']}")
        goal = "UDD" if traj.goal == "folded" and traj.n_links == 3 else f"the {traj.goal} goal"
        # the final state within the task's balance tolerance, tighter than the success region (68) the outcome
        # judges by: a run can hold the goal (success) and still be settling there
        label = f"within {traj.task.balance_tol:g} (rad, rad/s) of {goal}"
        print(f"  {label:<20} {summary['balanced']}")
        print(f"  E - E_r at the end   {summary['E_minus_Er_final']:.6g} J")
        V = summary["V_final"]
        print("  V at the end         " + (f"{V:.6g}" if V is not None and V == V else
                                         "- (V (34) is defined for the energy controllers (40), (12) only)"))
        peaks = summary["max_abs_tau"]
        label = "max " + ", ".join(f"|tau{j}|" for j in traj.driven_joints)
        print(f"  {label:<20} {', '.join(f'{v:.2f}' for v in peaks)} N m")
    return finish(traj.meta.get("interrupted", False), f"stopped at t = {summary['final_time']:.3f} s", args.out,
                  kept="kept what was computed in {out}")


def _gains_line(robot, traj, gains):
    from ..control.gains import gains_origin

    values = ", ".join(f"{k} = {gains[k]:.6g}" for k in ("kD", "kP", "kV"))
    # the family rule taken in place of the stored gains is described once, by the note on stderr
    return f"{values} ({gains_origin(robot.analytic, traj.task, robot.gains, gains, noted=True)})"


def cmd_render(args):
    from pathlib import Path

    from ..view.gl import select_backend

    out = Path(args.out)
    if out.suffix.lower() not in (".mp4", ".gif"):
        raise PaaError(f"--out must end in .mp4 or .gif, got {out.name}")
    if args.from_file:
        defaults = run_parent().parse_args([])
        changed = sorted(f"--{k.replace('_', '-')}" for k, v in vars(defaults).items()
                         if k != "robot" and getattr(args, k) != v)
        if changed:
            raise PaaError(f"--from replays a saved trajectory; the simulation options {', '.join(changed)}"
                           " contradict it")
    robot = traj = None
    if args.from_file:  # a wrong file or robot is named before the GL backends are probed
        from ..sim.trajectory import Trajectory

        traj = Trajectory.load(args.from_file)
        robot = _robot_of(traj, args.from_file, args.robot)
    backend = select_backend(args.gl)  # before anything imports mujoco's GL
    from ..outputs.video import check_fps_for, check_video_request, render_trajectory

    check_fps_for(out, args.fps)  # before the simulation it would waste

    if traj is None:
        robot, traj = run_from_args(args, progress=True)
    check_video_request(traj, args.fps, args.width, args.height, saved=bool(args.from_file))
    render_trajectory(robot, traj, out, fps=args.fps, width=args.width, height=args.height, camera=args.camera,
                      progress=True)
    print(f"wrote {out} ({backend}, {args.fps:g} fps, {args.width}x{args.height})")
    return 0


def _robot_of(traj, path, given):
    """The robot to draw ``traj`` (loaded from ``path``) with: ``--robot`` if given and the same model.

    A file written by ``simulate --out`` holds its robot's MJCF text and sha256: without ``--robot``
    that robot is drawn, and a ``--robot`` of another model is refused (a modified gymnast.xml keeps
    the name gymnast). An older file names its robot only: it is drawn as before, with a warning.
    """
    from ..model.robot import load_robot, robot_from_xml
    from ..provenance import text_sha256
    from .common import note

    saved = traj.meta.get("robot")
    if traj.robot_xml is None:
        chosen = given if given is not None else (saved if saved in ("gymnast", "example2") else "gymnast")
        note(f"warning: {path} does not record its robot's model (written by an older paa-mj): drawn as"
             f" --robot {chosen} without checking that this is the robot simulated")
        robot = load_robot(chosen)
    elif given is None:
        return robot_from_xml(traj.robot_xml, name=saved, source=f"the robot saved in {path}")
    else:
        robot = load_robot(given)
    if saved is not None and saved != robot.name:
        raise PaaError(f"{path} is a trajectory of robot {saved!r}, not of --robot {robot.name}"
                       + ("" if given else ": give --robot PATH.xml, the model it was simulated with"))
    if traj.robot_xml is not None and text_sha256(robot.xml) != traj.robot_sha256:
        raise PaaError(f"{path} is a trajectory of robot {saved!r} as another model than --robot {given} (MJCF"
                       f" sha256 {traj.robot_sha256[:12]}..., not {text_sha256(robot.xml)[:12]}...): give the"
                       " model it was simulated with, or no --robot to draw the one saved in the file")
    return robot


def cmd_view(args):
    """MuJoCo's interactive viewer with the controller running, in real time."""
    import os
    import sys
    import time

    import numpy as np

    if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise PaaError("no display (DISPLAY and WAYLAND_DISPLAY are unset): the viewer needs a screen;"
                       " use 'paa-mj render' for a video instead")
    if os.environ.get("MUJOCO_GL") in ("egl", "osmesa"):
        raise PaaError(f"MUJOCO_GL={os.environ['MUJOCO_GL']} is for offscreen rendering; unset it to open the viewer")
    import mujoco
    import mujoco.viewer

    from ..control.base import torque_of
    from ..model.robot import load_robot
    from ..sim.integrators import mujoco_model_for

    robot = load_robot(args.robot)
    task = task_from_args(args, robot)
    controller = spec_from_args(args, robot, task).build(robot)
    x0 = initial_state(args, robot, task)
    n = robot.params.n_links
    model = mujoco_model_for(robot, args.dt, args.integrator)
    limits = robot.capped_torque_limits(args.torque_limit)
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:] = x0[:n], x0[n:]
    mujoco.mj_forward(model, data)
    _check_glfw()
    try:
        viewer = mujoco.viewer.launch_passive(model, data)
    except Exception as err:  # GLFW failures come as several types
        raise PaaError(f"cannot open the viewer: {' '.join(str(err).split())}") from None
    with viewer:
        start = last_sync = time.perf_counter()
        while viewer.is_running() and data.time < args.t_final:
            tau = torque_of(controller, data.qpos[None].copy(), data.qvel[None].copy(), data.time)[0]
            data.ctrl[:] = np.clip(tau, -limits, limits)
            mujoco.mj_step(model, data)
            ahead = data.time - (time.perf_counter() - start)
            if ahead > 0:
                time.sleep(ahead)
            if time.perf_counter() - last_sync > 1 / 60:  # refresh at about 60 Hz of wall time
                viewer.sync()
                last_sync = time.perf_counter()
    return 0


def _check_glfw():
    """GLFW starts here, or one line: the viewer would start it on its own thread and die there noisily."""
    import warnings

    import glfw

    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        started = glfw.init()
    if not started:
        why = "; ".join(" ".join(str(w.message).split()) for w in seen) or "GLFW could not start"
        raise PaaError(f"cannot open the viewer: {why}")


def register(sub, parser_class):
    p = sub.add_parser("simulate", parents=[run_parent(), output_parent("trajectory.npz, trajectory.csv, summary.json")],
                       help="run a controller from an initial state and record it",
                       description="Run a controller on the robot (MuJoCo, or the exact analytic closed loop)."
                                   " A diverging run stops with exit code 3, keeping what was computed in --out.")
    p.set_defaults(func=cmd_simulate)

    p = sub.add_parser("render", parents=[run_parent(robot_default=None)], help="offscreen video of a rollout (EGL or OSMesa)",
                       description="Render a rollout (or a saved trajectory) to MP4 or GIF, offscreen.")
    p.add_argument("--from", dest="from_file", metavar="TRAJ.npz",
                   help="replay a trajectory saved by 'simulate --out' instead of simulating")
    p.add_argument("--out", type=file_path, required=True, metavar="FILE.mp4|FILE.gif", help="the video file")
    p.add_argument("--fps", type=positive, default=30.0, help="frames per second of the video")
    p.add_argument("--width", type=positive_int, default=640, help="frame width [pixels], 16..4096")
    p.add_argument("--height", type=positive_int, default=480, help="frame height [pixels], 16..4096")
    p.add_argument("--gl", choices=("auto", "egl", "osmesa"), default="auto",
                   help="offscreen GL backend (auto: EGL, then OSMesa)")
    p.add_argument("--camera", default="side", help="a camera of the model")
    p.set_defaults(func=cmd_render)

    p = sub.add_parser("view", parents=[robot_parent(), goal_parent(), controller_parent(), physics_parent()],
                       help="MuJoCo's interactive viewer with the controller running (needs a display)",
                       description="Watch a controller in MuJoCo's viewer, in real time.")
    p.add_argument("--x0", type=finite, nargs="+", metavar="X",
                   help="initial q1..qn d1..dn, 2n numbers (default: hanging at rest, (65) for the gymnast)")
    p.set_defaults(func=cmd_view)
