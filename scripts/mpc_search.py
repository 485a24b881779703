"""The search behind ``mpc``'s defaults (docs/controllers.md): every combination of the options given, each scored on
RealAIGym's acrobot (or ``--robot``: their pendubot for the driven shoulder's defaults; options not given take the
robot's actuation pattern's defaults, ``paa_mj.control.mpc.defaults``) by their performance v2 (the RealAI score and its criteria) and their global v3 test (time up of
60 s, one run per seed: one seed's number moves by seconds with any small change, their mean less), optionally on a
subset of robustness v2 (every Nth run; the share of runs that succeed per criterion).

    .venv/bin/python scripts/mpc_search.py horizon=1.0,1.5 w_angle=1,3,10 [--base '{"w_speed": 0.05}']
        [--seeds 777,1,2] [--robustness-every 3] [--robot realaigym_pendubot] [--goal folded] [--json out.json]

One line per combination, in the order given; the same command prints the same numbers (every run is
deterministic).
"""
from __future__ import annotations

import argparse
import itertools
import json
import sys

import numpy as np


def parse_axis(text):
    name, _, values = text.partition("=")
    if not values:
        raise SystemExit(f"mpc_search: an option is given as name=v1,v2,..., not {text!r}")
    return name, [float(v) for v in values.split(",")]


def performance(robot, task, options):
    from paa_mj.control.mpc import MPCController
    from paa_mj.realaigym import study as rg

    summary, _ = rg.performance_v2(robot, MPCController(robot.analytic, task, robot.torque_limits, **options), task)
    c = summary["criteria"]
    return {k: c[k] for k in ("score_v2", "swingup_time", "energy", "tau_cost", "tau_smoothness", "velocity_cost")}


def global_test(robot, task, options, seeds):
    from paa_mj.control.mpc import MPCController
    from paa_mj.realaigym import study as rg

    ups = [rg.global_v3(robot, MPCController(robot.analytic, task, robot.torque_limits, **options), task,
                        seed=seed)[0]["time_up"] for seed in seeds]
    return {"time_up": dict(zip(map(str, seeds), ups)), "time_up_mean": float(np.mean(ups))}


def robustness_subset(robot, task, options, every, seed=777):
    from paa_mj.control.mpc import MPCController
    from paa_mj.realaigym import scores
    from paa_mj.realaigym import study as rg

    runs = rg.Runs(robot, MPCController(robot.analytic, task, robot.torque_limits, **options))
    T = rg.their_times(rg.T_FINAL)
    cases = rg.robustness_cases(robot)[::every]
    nominal = rg.plant(robot)
    inputs = [rg._case_inputs(runs, robot, nominal, case, T, seed) for case in cases]
    results = runs.run_many([(P, rg.hanging(2), d) for P, d in inputs], T)
    goal = rg.their_goal(robot, task)
    share = {}
    for case, (X, _) in zip(cases, results):
        ok = len(X) == len(T) and scores.final_state_success(X[-1], goal, rg.EPSILON)
        share.setdefault(case[0], []).append(ok)
    return {criterion: float(np.mean(v)) for criterion, v in share.items()}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("axes", nargs="+", help="name=v1,v2,... (options of paa_mj.control.mpc.DEFAULTS)")
    parser.add_argument("--base", default="{}", help="options held fixed, as JSON")
    parser.add_argument("--seeds", default="777,1,2", help="seeds of the global v3 test")
    parser.add_argument("--robustness-every", type=int, default=0, help="every Nth run of robustness v2 (0: none)")
    parser.add_argument("--robot", default="realaigym_acrobot", help="the robot the options are scored on")
    parser.add_argument("--goal", default="stretched", help="the goal the options are scored at")
    parser.add_argument("--json", help="write every line's numbers to this file")
    args = parser.parse_args(argv)

    from paa_mj.model import load_robot
    from paa_mj.task import Task

    robot = load_robot(args.robot)
    task = Task.named(args.goal, robot)
    axes = [parse_axis(a) for a in args.axes]
    base = json.loads(args.base)
    seeds = [int(s) for s in args.seeds.split(",") if s]
    rows = []
    for combo in itertools.product(*[values for _, values in axes]):
        chosen = {name: value for (name, _), value in zip(axes, combo)}
        options = {**base, **chosen}
        row = {"options": chosen, "performance_v2": performance(robot, task, options)}
        if seeds:
            row["global_v3"] = global_test(robot, task, options, seeds)
        if args.robustness_every:
            row["robustness_v2_subset"] = robustness_subset(robot, task, options, args.robustness_every)
        rows.append(row)
        p = row["performance_v2"]
        line = (f"{json.dumps(chosen)}  performance-v2 {p['score_v2']:.4f} (up {p['swingup_time']:.3f} s, "
                f"E {p['energy']:.2f}, tau {p['tau_cost']:.2f}, smooth {p['tau_smoothness']:.4f}, "
                f"vel {p['velocity_cost']:.1f})")
        if seeds:
            g = row["global_v3"]
            line += "  global-v3 " + " ".join(f"{v:.2f}" for v in g["time_up"].values()) + \
                f" mean {g['time_up_mean']:.2f} s"
        if args.robustness_every:
            line += "  robustness " + " ".join(f"{k} {v:.2f}" for k, v in row["robustness_v2_subset"].items())
        print(line, flush=True)
    if args.json:
        with open(args.json + ".part", "w") as f:
            json.dump(rows, f, indent=1)
        import os

        os.replace(args.json + ".part", args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
