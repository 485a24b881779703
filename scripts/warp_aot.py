"""Compile the warp engine's kernels for a CUDA architecture on a machine without a GPU.

    python scripts/warp_aot.py [--arch 90]

MuJoCo Warp and this package's device kernels are made when they are first used, and Warp compiles each module
for the device it runs on: about 70 s on a GPU's first run (``scripts/gpu_figures.py`` measured it). Warp's
compiler (NVRTC) is inside ``warp-lang`` and needs no GPU, so this script makes every module that ``--engine
warp`` (the paper's gymnast and controller) and the vector environment use, by running a tiny basin and a step
of the vector environment on Warp's CPU device, then compiles each module that was loaded for ``sm_ARCH``
(CUBIN: what Warp loads where the driver is older than its compiler, as on the machines measured) into Warp's
kernel cache, ``$PAA_MJ_CACHE/warp`` (or ``$WARP_CACHE_PATH``). Copy that folder to the GPU machine's cache: a module whose code is the same there is
loaded, not compiled; any other is compiled there as before. 90 is the H100's and H200's architecture.
"""
from __future__ import annotations

import argparse
import contextlib
import io
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))


def exercise(out: Path):
    """Every kernel of the warp engine and of the vector environment, made and run once on Warp's CPU device."""
    from paa_mj.cli import main
    from paa_mj.envs.vector import GymnastVectorEnv

    with contextlib.redirect_stdout(io.StringIO()):
        code = main(["basin", "--grid", "2", "--t-final", "0.004", "--engine", "warp", "--device", "cpu", "--out",
                     str(out), "--fresh", "--json", "--scheduler", "inline"])
    if code:
        raise SystemExit(f"basin on the CPU device exited {code}")
    env = GymnastVectorEnv(num_envs=2, engine="warp", device="cpu")
    env.reset(seed=0)
    env.step(env.action_space.sample())
    env.close()


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--arch", type=int, default=90, help="the CUDA architecture (90: H100, H200)")
    parser.add_argument("--scratch", type=Path, default=Path("/tmp/paa_mj_warp_aot"))
    args = parser.parse_args()
    from paa_mj.sim.warp.device import load_warp

    wp, _ = load_warp()
    start = time.perf_counter()
    exercise(args.scratch)
    from warp._src.context import user_modules

    loaded = [m for m in user_modules.values() if m.execs]
    compiled = []
    for module in loaded:
        compiled += wp.compile_aot_module(module, arch=args.arch, use_ptx=False)
    print(f"{len(loaded)} modules compiled for sm_{args.arch} ({len(compiled)} files) into"
          f" {wp.config.kernel_cache_dir} in {time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()
