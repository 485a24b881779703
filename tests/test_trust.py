"""Nothing lost, nothing confusing: bad input everywhere, atomic files, determinism, long-run energy."""
import hashlib
import subprocess
import sys

import numpy as np
import pytest

from paa_mj.errors import PaaError
from paa_mj.io import write_npz


def _cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "paa_mj.cli", *args], capture_output=True, text=True, cwd=cwd,
                          timeout=300)


@pytest.fixture(scope="module")
def bad_files(tmp_path_factory):
    d = tmp_path_factory.mktemp("bad")
    (d / "malformed.xml").write_text("<mujoco><worldbody><body></mujoco>")
    (d / "acrobot.xml").write_text(
        '<mujoco><worldbody><body><joint type="hinge" axis="0 1 0"/><geom size=".1"/>'
        '<body pos="0 0 1"><joint type="hinge" axis="0 1 0"/><geom size=".1"/></body></body></worldbody>'
        '<actuator><motor joint="1"/></actuator></mujoco>'.replace('joint="1"', 'joint="j2"').replace(
            '<body pos="0 0 1"><joint type="hinge"', '<body pos="0 0 1"><joint name="j2" type="hinge"'))
    (d / "binary.xml").write_bytes(b"\xff\xfe\x00garbage")
    (d / "traj.npz").write_bytes(b"PK\x03\x04 truncated")
    (d / "notes.txt").write_text("hello")
    return d


CASES = [
    # (what, arguments, fragment of the one-line error)
    ("missing model file", ["simulate", "--robot", "{d}/none.xml"], "model file not found"),
    ("unreadable model file", ["check", "--robot", "{d}/binary.xml"], "cannot read model file"),
    ("malformed model file", ["theory", "--robot", "{d}/malformed.xml"], "malformed MJCF"),
    ("model of the wrong shape", ["check", "--robot", "{d}/acrobot.xml"], "contacts (link geoms that collide"),
    ("not a model", ["simulate", "--robot", "{d}/notes.txt"], "malformed MJCF"),
    ("unknown robot name", ["simulate", "--robot", "pendubot"], "unknown robot 'pendubot'"),
    ("non-physical parameters", ["make-model", "--m", "1", "1", "1", "--l", "1", "1", "0", "--out", "{d}/x.xml"], "must be a positive finite number, got 0"),
    ("non-finite initial state", ["simulate", "--x0", "0", "0", "nan", "0", "0", "0"], "must be finite"),
    ("runaway initial speed", ["simulate", "--engine", "analytic", "--x0", "0", "0", "0", "1e4", "0", "0"],
     "initial joint speed 10000 rad/s is above 100 rad/s"),
    ("wrong-length initial state", ["simulate", "--x0", "0", "0", "0"], "--x0 needs 6 numbers for robot gymnast"),
    ("gain below kD_min", ["simulate", "--kD", "4000"], "kD_min = 4503"),
    ("non-positive kV", ["simulate", "--kV", "0"], "--kV: must be a positive finite number, got 0"),
    ("zero final time", ["simulate", "--t-final", "0"], "--t-final: must be a positive finite number"),
    ("negative time step", ["simulate", "--dt", "-0.001"], "--dt: must be a positive finite number"),
    ("unknown integrator", ["simulate", "--integrator", "leapfrog"], "invalid choice: 'leapfrog'"),
    ("unknown GL backend", ["render", "--gl", "metal", "--out", "{d}/v.mp4"], "invalid choice: 'metal'"),
    ("unwritable output folder", ["simulate", "--t-final", "0.01", "--out", "/proc/paa/out"], "cannot create output folder"),
    ("corrupted trajectory", ["render", "--from", "{d}/traj.npz", "--out", "{d}/v.mp4"], "corrupted or foreign trajectory file"),
    ("missing trajectory", ["render", "--from", "{d}/nothing.npz", "--out", "{d}/v.mp4"], "trajectory file not found"),
    ("bad torque limit", ["simulate", "--torque-limit", "-5"], "--torque-limit: must be a positive finite number"),
    ("bad basin axes", ["basin", "--axes", "q1,q9"], "two different coordinates"),
]


def _assert_one_error_line(what, proc, fragment):
    assert proc.returncode == 2, (what, proc.stderr)
    lines = proc.stderr.strip().splitlines()
    assert lines[-1].startswith("paa-mj: error:") and fragment in lines[-1], (what, proc.stderr)
    assert "paa-mj: error: paa-mj" not in lines[-1]  # one prefix, not two
    assert all(line.startswith("paa-mj: ") for line in lines)  # warnings, then one error line
    assert "Traceback" not in proc.stderr


@pytest.mark.parametrize("what, args, fragment", CASES, ids=[c[0] for c in CASES])
def test_bad_input_table(what, args, fragment, bad_files, run):
    """Each case in this process (the same ``main`` the command runs); the next test starts a real one."""
    _assert_one_error_line(what, run(*[a.format(d=bad_files) for a in args]), fragment)


@pytest.mark.parametrize("what, args, fragment", [CASES[2], CASES[16]], ids=[CASES[2][0], CASES[16][0]])
def test_bad_input_from_a_real_command(what, args, fragment, bad_files):
    """The exit code and stderr of a fresh ``python -m paa_mj.cli`` process, not only of ``main``."""
    _assert_one_error_line(what, _cli(*[a.format(d=bad_files) for a in args]), fragment)


def test_files_are_whole_or_absent(tmp_path, monkeypatch):
    target = tmp_path / "data.npz"
    write_npz(target, a=np.arange(3))
    before = target.read_bytes()

    def broken(*args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(np.lib.format, "write_array", broken)
    with pytest.raises(PaaError, match="disk full"):
        write_npz(target, a=np.arange(5))
    assert target.read_bytes() == before  # the old file is untouched
    with pytest.raises(PaaError, match="nothing was written"):
        write_npz(tmp_path / "new.npz", a=np.arange(5))
    assert not (tmp_path / "new.npz").exists()
    assert [p.name for p in tmp_path.iterdir()] == ["data.npz"]  # no temporary left behind


def test_same_command_gives_byte_identical_files(tmp_path, run):
    digests = []
    for name, command in (("a", _cli), ("b", run)):  # a process of its own, then this one
        out = tmp_path / name
        assert command("simulate", "--t-final", "3", "--out", str(out), "--json").returncode == 0
        digests.append({name: hashlib.sha256((out / name).read_bytes()).hexdigest()
                        for name in ("trajectory.npz", "trajectory.csv", "summary.json")})
    assert digests[0] == digests[1]


def test_the_passive_robot_keeps_its_energy_within_the_stated_bounds_over_20_s():
    """The quick form of the claim passive_energy_drift of docs/guarantees.md (tests/claims.py): the same two runs for
    20 s instead of the stated 200 s (under ``pytest -m claims``), each drift below the bound the page states."""
    from .claims import CLAIMS, disagreement, stated

    item = CLAIMS["passive_energy_drift"]
    made = item.make(steps=20_000)
    texts = [text for _, name, text in stated() if name == "passive_energy_drift"]
    assert texts and all(disagreement(item, text, made) is None for text in texts), (texts, made)
    assert all(0 < drift for drift in made)  # measured, not a run that never moved


def test_trajectory_load_rejects_wrong_shapes(tmp_path):
    from paa_mj.sim.trajectory import Trajectory

    path = tmp_path / "t.npz"
    write_npz(path, t=np.arange(3.0), q=np.zeros((3, 2)), qd=np.zeros((3, 3)), tau=np.zeros((3, 2)),
              E_minus_Er=np.zeros(3), V=np.zeros(3), mode=np.zeros(3), switch_time=np.nan, meta="{}")
    with pytest.raises(PaaError, match=r"qd has shape \(3, 3\), expected \(3, 2\)"):
        Trajectory.load(path)


def test_viewer_without_a_display_says_so():
    import os

    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    proc = subprocess.run([sys.executable, "-m", "paa_mj.cli", "view"], capture_output=True, text=True, env=env,
                          timeout=120)
    assert proc.returncode == 2
    assert proc.stderr.strip() == ("paa-mj: error: no display (DISPLAY and WAYLAND_DISPLAY are unset): the viewer"
                                   " needs a screen; use 'paa-mj render' for a video instead")

