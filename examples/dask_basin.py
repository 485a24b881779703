"""A basin study on a Dask cluster that this script starts itself.

    python examples/dask_basin.py --workers 2 --grid 32 --out out/example_dask_basin
    python examples/dask_basin.py --grid 3 --t-final 1          # seconds
    python examples/dask_basin.py --robot acrobot --goal stretched --grid 16

The scheduler listens on a local TCP port, as a scheduler on another machine would
(``dask scheduler`` there, ``dask worker tcp://HOST:8786`` on each node); the study
only needs its address, and gives the same numbers as ``--scheduler inline``. With
``--out`` it keeps finished chunks: stop it and run it again to resume.
"""
import argparse

from distributed import LocalCluster

from paa_mj.cli import main as paa_mj


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, default=2, help="worker processes")
    parser.add_argument("--robot", default="gymnast", help="a named robot (paa-mj simulate --help) or an MJCF file")
    parser.add_argument("--goal", default="folded", choices=("folded", "stretched"), help="the task's goal")
    parser.add_argument("--grid", default="16", help="points per axis")
    parser.add_argument("--t-final", default="30", help="duration of each run [s]")
    parser.add_argument("--out", default="out/example_dask_basin", help="output folder")
    args = parser.parse_args(argv)

    with LocalCluster(n_workers=args.workers, threads_per_worker=1, host="127.0.0.1", protocol="tcp",
                      dashboard_address=None) as cluster:
        print(f"scheduler at {cluster.scheduler_address}")
        code = paa_mj(["basin", "--robot", args.robot, "--goal", args.goal, "--grid", args.grid, "--t-final", args.t_final, "--chunk", "4",
                       "--scheduler", cluster.scheduler_address, "--out", args.out])
    if code:
        raise SystemExit(code)
    return code


if __name__ == "__main__":
    main()
