"""The GPU figures of ``--engine warp``: basins of 30 s kips on a GPU, the CPU engine on the same work, and the
vector environment's steps per second.

    python scripts/gpu_figures.py --out DIR [--budget SECONDS] [--device cuda:0]

Needs a CUDA device and the extra ``gpu`` (``pip install "paa_mj[gpu]"``). Every basin is the command a user
runs (``paa-mj basin ... --json``) in its own process, timed from outside (wall clock and the child's CPU
seconds): imports, kernel loading, the run and the files written, its summary read from its ``summary.json``. In
order:

1. a tiny basin on each engine that compiles its kernels into the caches, or loads them from there (their times
   are stated as ``compile``; ``scripts/warp_aot.py`` compiles the GPU's ahead of time on any machine);
2. the 1024 x 1024 basin of the paper's gymnast (folded goal, ``vcl``, 30 s) on the GPU, stopped where it would
   not leave ``--reserve`` seconds of the budget; a run that is stopped states how far it got (its last progress
   line: the clock of the worlds still running, and seconds simulated summed over the worlds, a stopped world
   counted whole) and a projection of its whole time (its time scaled by the clock's share of the run);
3. the 64 x 64 basin on the CPU engine (every core) and on the GPU: the ratio of their wall-clock times, and how
   far they agree cell by cell (outcome, switch time, final state: MuJoCo Warp is float32);
4. the 256 x 256 basin on the GPU, with the CPU engine's time on it scaled from 64 x 64 by the number of starts;
5. the vector environment (``engine="warp"`` against ``engine="mujoco"`` with a thread per core) with random
   actions: environment steps per second at 4096 and 65536 sub-environments.

Each stage writes ``gpu_figures.json`` in ``--out`` again (beside each basin's folder), so that what ran is kept if
a later stage is cut short; a stage that does not fit in what is left of ``--budget`` is skipped and says so.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import re
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))


def child_seconds():
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def basin(out, name, grid, t_final, engine, device, chunk, timeout=None):
    """One ``paa-mj basin`` in its own process: (summary, wall [s], CPU [s], folder); stopped after ``timeout`` s
    (:class:`Cut`, with its last progress line)."""
    folder = out / name
    cmd = [sys.executable, "-m", "paa_mj.cli", "basin", "--grid", str(grid), "--t-final", str(t_final),
           "--engine", engine, "--chunk", str(chunk), "--out", str(folder), "--fresh", "--scheduler", "inline"]
    if engine == "warp":
        cmd += ["--device", device]
    start, cpu = time.perf_counter(), child_seconds()
    try:
        done = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, timeout=timeout)
    except subprocess.TimeoutExpired as cut:
        err = cut.stderr.decode() if isinstance(cut.stderr, bytes) else (cut.stderr or "")
        lines = [line for line in err.splitlines() if "simulated" in line]
        raise Cut(time.perf_counter() - start, lines[-1] if lines else None) from None
    wall, cpu = time.perf_counter() - start, child_seconds() - cpu
    if done.returncode:
        raise RuntimeError(f"{' '.join(cmd[2:])}: exit {done.returncode}: {done.stderr[-1500:]}")
    summary = json.loads((folder / "summary.json").read_text())
    print(f"  {name}: {wall:.1f} s wall, {cpu:.1f} CPU-s, success {summary['success']:.4f}", flush=True)
    return summary, wall, cpu, folder


class Cut(Exception):
    """A basin stopped at its timeout: the seconds it ran and its last progress line."""

    def __init__(self, wall, last_progress):
        super().__init__(f"cut after {wall:.0f} s")
        self.wall, self.last_progress = wall, last_progress


def agreement(cpu_folder, gpu_folder):
    """How the two engines' basins agree, cell by cell."""
    a, b = np.load(cpu_folder / "basin.npz"), np.load(gpu_folder / "basin.npz")
    same = a["outcome"] == b["outcome"]
    both = np.isfinite(a["switch_time"]) & np.isfinite(b["switch_time"])
    ended = ~a["diverged"] & ~b["diverged"]
    state = np.abs(a["final_state"] - b["final_state"])[ended & same]
    return {"cells": int(same.size), "same_outcome": int(same.sum()),
            "same_success": int((a["success"] == b["success"]).sum()),
            "switch_time_max_abs_diff_s": float(np.max(np.abs(a["switch_time"] - b["switch_time"])[both]))
            if both.any() else None,
            "final_state_max_abs_diff_same_outcome": float(state.max()) if state.size else None,
            "final_state_median_abs_diff_same_outcome": float(np.median(state)) if state.size else None}


def vector_rate(n_envs, engine, device, steps=100):
    """Environment steps per second of the vector environment with random actions (after 5 warm-up steps)."""
    from paa_mj.envs.vector import GymnastVectorEnv

    kwargs = {"engine": engine}
    if engine == "warp":
        kwargs["device"] = device
    else:
        kwargs["num_threads"] = os.cpu_count()
    env = GymnastVectorEnv(num_envs=n_envs, **kwargs)
    env.reset(seed=0)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(8)]
    for k in range(5):
        env.step(actions[k % 8])
    start = time.perf_counter()
    for k in range(steps):
        env.step(actions[k % 8])
    wall = time.perf_counter() - start
    env.close()
    return n_envs * steps / wall


def gpu_name():
    try:
        return subprocess.run(["nvidia-smi", "--query-gpu=name,memory.total,driver_version", "--format=csv,noheader"],
                              capture_output=True, text=True).stdout.strip()
    except OSError:
        return None


class Figures:
    """The stages (module docstring), each adding to one JSON object written after it."""

    def __init__(self, args):
        import mujoco
        import warp

        self.args, self.began, self.cpu_run = args, time.perf_counter(), None
        self.small, self.middle, self.large = (int(g) for g in args.grids.split(","))
        self.data = {"machine": {"gpu": gpu_name(), "cpus": os.cpu_count(), "python": platform.python_version(),
                                 "mujoco": mujoco.__version__, "warp": warp.config.version},
                     "command": " ".join(sys.argv), "skipped": []}

    def save(self):
        path = self.args.out / "gpu_figures.json"
        path.with_suffix(".tmp").write_text(json.dumps(self.data, indent=1) + "\n")
        path.with_suffix(".tmp").replace(path)

    def left(self):
        return self.args.budget - (time.perf_counter() - self.began)

    def basin(self, name, grid, t_final, engine, timeout=None):
        """:func:`basin`, stopped where the budget ends unless ``timeout`` is sooner."""
        device = self.args.device if engine == "warp" else None
        timeout = self.left() - 5 if timeout is None else timeout
        if timeout < 10:
            raise Cut(0.0, "not started")
        return basin(self.args.out, name, grid, t_final, engine, device, max(grid**2, 4), timeout=timeout)

    def compile(self):
        print("compile", flush=True)
        timings = {}
        for engine in ("warp", "mujoco"):
            _, wall, cpu, _ = self.basin(f"compile_{engine}", 2, 0.2, engine)
            timings[engine] = {"wall_s": wall, "cpu_s": cpu}
        self.data["compile"] = timings

    def both_engines(self):
        grid, t = self.small, self.args.t_final
        print(f"{grid} x {grid}, {t} s: CPU engine and GPU", flush=True)
        runs = {engine: self.basin(f"{engine}_small", grid, t, engine) for engine in ("mujoco", "warp")}
        self.cpu_run = runs["mujoco"]
        self.data["basin_small"] = {
            "grid": grid, **{engine: {"wall_s": wall, "cpu_s": cpu, "success": summary["success"]}
                             for engine, (summary, wall, cpu, _) in runs.items()},
            "cpu_over_gpu_wall": runs["mujoco"][1] / runs["warp"][1],
            "agreement": agreement(runs["mujoco"][3], runs["warp"][3])}

    def gpu_middle(self):
        grid, t = self.middle, self.args.t_final
        print(f"{grid} x {grid}, {t} s: GPU", flush=True)
        summary, wall, cpu, _ = self.basin("warp_middle", grid, t, "warp")
        self.data["basin_middle"] = {"grid": grid, "gpu": {"wall_s": wall, "cpu_s": cpu, "success": summary["success"]}}
        if self.cpu_run is not None:
            scale = (grid / self.small) ** 2  # the CPU engine's cost grows with the starts
            self.data["basin_middle"].update(cpu_engine_scaled_cpu_s=self.cpu_run[2] * scale,
                                             cpu_engine_scaled_wall_s=self.cpu_run[1] * scale)

    def vector(self):
        print("vector environment", flush=True)
        rates = self.data.setdefault("vector_env_steps_per_s", {})
        for n in (int(e) for e in self.args.envs.split(",")):
            if self.left() < 60:
                self.data["skipped"].append(f"vector environment at {n}: {self.left():.0f} s left")
                return
            rates[n] = {"warp": vector_rate(n, "warp", self.args.device), "mujoco": vector_rate(n, "mujoco", None)}
            print(f"  {n}: {rates[n]}", flush=True)
            self.save()

    def gpu_large(self):
        grid, t = self.large, self.args.t_final
        room = self.left() - self.args.reserve
        if room < 60:
            self.data["skipped"].append(f"{grid} x {grid} over {t} s: {self.left():.0f} s left")
            return
        print(f"{grid} x {grid}, {t} s: GPU (at most {room:.0f} s)", flush=True)
        try:
            summary, wall, cpu, _ = self.basin("warp_large", grid, t, "warp", timeout=room)
        except Cut as cut:
            print(f"  cut after {cut.wall:.0f} s: {cut.last_progress}", flush=True)
            self.data["basin_large"] = {"grid": grid, "t_final": t, "cut_after_s": cut.wall,
                                        "last_progress": cut.last_progress}
            reached = re.search(r"\(t = ([0-9.]+) s", cut.last_progress or "")
            if reached and float(reached.group(1)) > 0:
                # conservative: the fixed costs (imports, the plan) are scaled with the simulated time too
                self.data["basin_large"]["projected_wall_s"] = cut.wall * t / float(reached.group(1))
            return
        self.data["basin_large"] = {"grid": grid, "t_final": t, "gpu": {"wall_s": wall, "cpu_s": cpu,
                                                                         "success": summary["success"]}}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--budget", type=float, default=540.0, help="seconds for every stage together")
    parser.add_argument("--device", default="cuda:0")
    parser.add_argument("--reserve", type=float, default=240.0,
                        help="seconds of the budget the largest basin leaves to the stages after it")
    parser.add_argument("--t-final", type=float, default=30.0, help="duration of every other basin [s]")
    parser.add_argument("--grids", default="64,256,1024", help="the three grids: both engines, GPU, largest")
    parser.add_argument("--envs", default="4096,65536", help="vector environment sizes")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    figures = Figures(args)
    for stage in (figures.compile, figures.gpu_large, figures.both_engines, figures.gpu_middle, figures.vector):
        try:
            stage()
        except Cut as cut:
            figures.data["skipped"].append(f"{stage.__name__}: cut after {cut.wall:.0f} s ({cut.last_progress})")
        figures.save()
    figures.data["total_wall_s"] = time.perf_counter() - figures.began
    figures.save()
    print(json.dumps(figures.data, indent=1))


if __name__ == "__main__":
    main()
