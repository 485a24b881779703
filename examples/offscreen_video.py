"""Offscreen video of the kip through EGL or OSMesa (no display needed).

    python examples/offscreen_video.py --gl egl --out kip.mp4
    python examples/offscreen_video.py --gl osmesa --out kip.gif --t-final 2 --width 160 --height 120
    python examples/offscreen_video.py --robot acrobot --goal stretched --t-final 25 --out acrobot.mp4

The backend is chosen before MuJoCo makes any GL context (``select_backend``); ``auto``
tries EGL, then OSMesa. EGL uses the GPU's driver where there is one (NVIDIA), else Mesa.
"""
import argparse

from paa_mj.view.gl import select_backend


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--gl", choices=("auto", "egl", "osmesa"), default="auto")
    parser.add_argument("--robot", default="gymnast", help="a named robot (paa-mj simulate --help) or an MJCF file")
    parser.add_argument("--goal", default="folded", choices=("folded", "stretched"), help="the task's goal")
    parser.add_argument("--t-final", type=float, default=30.0, help="duration of the kip [s]")
    parser.add_argument("--fps", type=float, default=30.0)
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--height", type=int, default=480)
    parser.add_argument("--out", default="out/example_kip.mp4", help="an .mp4 or .gif file")
    args = parser.parse_args(argv)

    backend = select_backend(args.gl)  # first: MuJoCo reads the backend once, when it loads
    from paa_mj.model import load_robot
    from paa_mj.outputs.video import render_trajectory
    from paa_mj.sim import simulate_mujoco

    robot = load_robot(args.robot)
    traj = simulate_mujoco(robot, "vcl", t_final=args.t_final, task=args.goal)  # from the task's start
    path = render_trajectory(robot, traj, args.out, fps=args.fps, width=args.width, height=args.height)
    print(f"rendered {args.t_final:g} s of {robot.name}'s swing-up to the {args.goal} goal through {backend} into {path}")
    return path


if __name__ == "__main__":
    main()
