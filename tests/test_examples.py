"""The examples people start from run as written, at a small size."""
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def run(name, *args, cwd):
    proc = subprocess.run([sys.executable, str(EXAMPLES / name), *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return proc


def test_headless_rollout(tmp_path):
    from paa_mj.sim import Trajectory

    proc = run("headless_rollout.py", "--t-final", "2", "--out", tmp_path / "run", cwd=tmp_path)
    assert "success False" in proc.stdout  # two seconds are no kip
    traj = Trajectory.load(tmp_path / "run" / "trajectory.npz")
    assert traj.t[-1] == pytest.approx(2.0) and np.all(np.isfinite(traj.q))
    assert (tmp_path / "run" / "angles.png").stat().st_size > 1000


def test_own_controller_through_simulate_basin_and_compare(tmp_path):
    run("own_controller.py", "--small", "--out", tmp_path / "own", cwd=tmp_path)
    basin = json.loads((tmp_path / "own" / "basin" / "summary.json").read_text())
    assert basin["controller"] == "pd_controller.py:HoldStraight" and basin["cells"] == 9
    board = json.loads((tmp_path / "own" / "compare" / "leaderboard.json").read_text())
    assert set(board["controllers"]) == {"vcl", f"{EXAMPLES / 'pd_controller.py'}:HoldStraight"}


@pytest.mark.parametrize("gl", ["egl", "osmesa"])
def test_offscreen_video(tmp_path, gl):
    from paa_mj.outputs.gl import probe

    why = probe(gl)
    if why is not None:
        pytest.skip(f"{gl} is not available here: {why}")
    run("offscreen_video.py", "--gl", gl, "--t-final", "0.5", "--fps", "10", "--width", "64", "--height", "48",
        "--out", tmp_path / "kip.gif", cwd=tmp_path)
    assert (tmp_path / "kip.gif").stat().st_size > 100


def test_dask_basin_on_a_cluster_the_script_starts(tmp_path):
    pytest.importorskip("distributed")
    run("dask_basin.py", "--workers", "1", "--grid", "2", "--t-final", "0.5", "--out", tmp_path / "basin",
        cwd=tmp_path)
    summary = json.loads((tmp_path / "basin" / "summary.json").read_text())
    assert summary["cells"] == 4 and summary["completed_fraction"] == 1.0
