"""Your own controller, through simulate, basin and compare, without touching the package.

    python examples/own_controller.py               # full sizes (a few minutes)
    python examples/own_controller.py --small       # seconds

The controller is a class in a file (here ``examples/pd_controller.py``): built as
``ClassName(robot)``, it maps states of shape (..., 3) to torques of shape (..., 2).
The same ``FILE.py:Class`` works on every command (``paa-mj simulate --controller
examples/pd_controller.py:HoldStraight``); this script calls the command line
from Python, the way a notebook or a pipeline would.
"""
import argparse
from pathlib import Path

from paa_mj.cli import main as paa_mj

CONTROLLER = f"{Path(__file__).with_name('pd_controller.py')}:HoldStraight"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--small", action="store_true", help="tiny sizes (as the tests run it)")
    parser.add_argument("--out", default="out/example_own_controller", help="output folder")
    args = parser.parse_args(argv)
    t_final, grid = ("2", "3") if args.small else ("30", "16")
    codes = [
        paa_mj(["simulate", "--controller", CONTROLLER, "--t-final", t_final, "--out", f"{args.out}/simulate"]),
        paa_mj(["basin", "--controller", CONTROLLER, "--grid", grid, "--t-final", t_final, "--scheduler", "inline",
                "--out", f"{args.out}/basin"]),
        paa_mj(["compare", "--controllers", f"vcl,{CONTROLLER}", "--scheduler", "inline", "--no-video",
                "--out", f"{args.out}/compare"] + (["--quick", "--trials", "1", "--grid", "2", "--t-final", t_final]
                                                   if args.small else ["--quick"])),
    ]
    if any(codes):
        raise SystemExit(max(codes))
    return codes


if __name__ == "__main__":
    main()
