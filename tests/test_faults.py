"""Nothing lost, nothing wrong in silence: model validation, contradictory options, bounded requests, faults."""
import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from paa_mj.model.mjcf import MODEL_DIR

from .helpers import cli

GYMNAST = (MODEL_DIR / "gymnast.xml").read_text()


class Result:
    def __init__(self, returncode, stdout, stderr):
        self.returncode, self.stdout, self.stderr = returncode, stdout, stderr


@pytest.fixture
def run(capsys, monkeypatch):
    """``paa-mj ARGS`` in this process (fast), as a completed process."""
    from paa_mj.cli import main

    def call(*args, cwd=None):
        if cwd is not None:
            monkeypatch.chdir(cwd)
        code = main([str(a) for a in args])
        out, err = capsys.readouterr()
        return Result(code, out, err)

    return call


def _one_line_error(proc, fragment, code=2):
    assert proc.returncode == code, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert lines and lines[-1].startswith("paa-mj: error:") and fragment in lines[-1], proc.stderr
    assert "Traceback" not in proc.stderr


def _variant(old, new):
    assert old in GYMNAST, old
    return GYMNAST.replace(old, new, 1)


HIPS = '<joint name="hips" type="hinge" axis="0 1 0"/>'
FEATURES = [
    ("joint range", HIPS, '<joint name="hips" type="hinge" axis="0 1 0" range="-1 1"/>', "joint ranges"),
    ("damping", HIPS, '<joint name="hips" type="hinge" axis="0 1 0" damping="0.5"/>', "joint damping"),
    ("armature", HIPS, '<joint name="hips" type="hinge" axis="0 1 0" armature="0.1"/>', "armature"),
    ("friction loss", HIPS, '<joint name="hips" type="hinge" axis="0 1 0" frictionloss="0.2"/>', "friction loss"),
    ("stiffness", HIPS, '<joint name="hips" type="hinge" axis="0 1 0" stiffness="3"/>', "joint stiffness"),
    ("weaker gravity", 'gravity="0 0 -9.81"', 'gravity="0 0 -5"', "gravity [0.0, 0.0, -5.0]"),
    ("sideways gravity", 'gravity="0 0 -9.81"', 'gravity="0 -9.81 0"', "gravity"),
    ("density", 'integrator="RK4"', 'integrator="RK4" density="1.2"', "a medium"),
    ("viscosity", 'integrator="RK4"', 'integrator="RK4" viscosity="0.01"', "a medium"),
    ("gravcomp", '<body name="link2" pos="0 0 0.58">', '<body name="link2" pos="0 0 0.58" gravcomp="1">',
     "gravity compensation"),
    ("contacts", 'material="legs" contype="0" conaffinity="0"', 'material="legs" contype="1" conaffinity="1"',
     "contacts"),
    ("extra actuator", '<motor name="hip" joint="hips" gear="1"/>',
     '<motor name="hip" joint="hips" gear="1"/>\n    <motor name="hands" joint="hands" gear="1"/>', "3 actuators"),
    ("gear", '<motor name="hip" joint="hips" gear="1"/>', '<motor name="hip" joint="hips" gear="2"/>', "gear 2"),
    ("position servo", '<motor name="hip" joint="hips" gear="1"/>', '<position name="hip" joint="hips" kp="10"/>',
     "not a <motor>"),
    ("asymmetric ctrlrange", '<motor name="hip" joint="hips" gear="1"/>',
     '<motor name="hip" joint="hips" gear="1" ctrlrange="-1 2"/>', "ctrlrange [-1, 2]"),
    ("NaN time step", 'timestep="0.001"', 'timestep="nan"', "timestep"),
    ("negative time step", 'timestep="0.001"', 'timestep="-0.001"', "timestep"),
    ("absurd mass", '<inertial pos="0 0 0.31" mass="5.4"', '<inertial pos="0 0 0.31" mass="1e308"',
     "plausible range"),
    ("actuation disabled", 'contact="disable"', 'contact="disable" actuation="disable"', "actuation disabled"),
    ("sleeping bodies", 'contact="disable"', 'contact="disable" sleep="enable"', "sleeping bodies"),
    ("joint reference angle", HIPS, '<joint name="hips" type="hinge" axis="0 1 0" ref="0.5"/>',
     "joint reference angles"),
    ("NaN stored gain", 'data="4550.0 16000.0 5000.0"', 'data="nan 16000 5000"', "paa_gains kD = nan"),
    ("negative stored gain", 'data="4550.0 16000.0 5000.0"', 'data="4550 -16000 5000"', "paa_gains kP = -16000"),
    ("tendon", "</actuator>", '</actuator>\n  <tendon><fixed name="t"><joint joint="hips" coef="1"/></fixed></tendon>',
     "tendons"),
]


@pytest.mark.parametrize("what, old, new, fragment", FEATURES, ids=[f[0] for f in FEATURES])
def test_model_features_the_paper_lacks_are_refused_by_name(what, old, new, fragment, tmp_path, run):
    path = tmp_path / "robot.xml"
    text = _variant(old, new)
    if what == "contacts":
        text = text.replace('<flag energy="enable" contact="disable"/>', '<flag energy="enable"/>')
    path.write_text(text)
    _one_line_error(run("theory", "--robot", path), fragment)


def test_ctrlrange_is_the_torque_limit_everywhere(tmp_path, capsys):
    from paa_mj.cli import main

    path = tmp_path / "limited.xml"
    path.write_text(_variant('<motor name="shoulder" joint="shoulders" gear="1"/>',
                             '<motor name="shoulder" joint="shoulders" gear="1" ctrlrange="-60 60"/>'))
    assert main(["simulate", "--robot", str(path), "--t-final", "2", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["torque_limit"] == [60.0, float("inf")] or summary["torque_limit"][0] == 60.0
    assert summary["max_abs_tau"][0] == pytest.approx(60.0)  # saturated, and the summary says so
    assert main(["simulate", "--robot", str(path), "--engine", "analytic", "--t-final", "1", "--json"]) == 0
    analytic = json.loads(capsys.readouterr().out)
    assert analytic["max_abs_tau"][0] <= 60.0 + 1e-12 and analytic["torque_limit"][0] == 60.0
    assert main(["simulate", "--robot", str(path), "--torque-limit", "30", "--t-final", "1", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["max_abs_tau"][0] == pytest.approx(30.0)  # the smaller limit


def test_make_model_escapes_what_it_writes(tmp_path, run):
    clean, dirty = tmp_path / "clean.xml", tmp_path / "dirty.xml"
    args = ["make-model", "--m", "2", "1", "1", "--l", "1", "0.6", "0.6", "--kD", "100", "--kP", "300", "--kV", "50"]
    assert run(*args, "--out", clean).returncode == 0
    injection = '--><worldbody><body name="x"><geom size="1"/></body></worldbody><!--'
    proc = run(*args, "--title", injection, "--name", 'evil" model="x', "--out", dirty)
    assert proc.returncode == 0, proc.stderr
    import mujoco

    a, b = mujoco.MjModel.from_xml_path(str(clean)), mujoco.MjModel.from_xml_path(str(dirty))
    assert (a.nbody, a.ngeom) == (b.nbody, b.ngeom)  # nothing was injected
    assert b.names.split(b"\0", 1)[0].decode() == 'evil" model="x'
    assert run("theory", "--robot", dirty, "--json").returncode == 0


CONTRADICTIONS = [
    ("render --from with simulate options", ["render", "--from", "{traj}", "--t-final", "5", "--out", "{d}/v.mp4"],
     "contradict it"),
    ("render --from with another robot", ["render", "--from", "{traj}", "--robot", "example2", "--out", "{d}/v.mp4"],
     "trajectory of robot 'gymnast'"),
    ("sample interval longer than the run", ["simulate", "--sample-dt", "5", "--t-final", "1"],
     "--sample-dt 5 s is longer than --t-final 1 s"),
    ("integrator with the analytic engine", ["simulate", "--engine", "analytic", "--integrator", "Euler"],
     "--integrator do not apply to --engine analytic"),
    ("time step with the analytic engine", ["simulate", "--engine", "analytic", "--dt", "0.002"],
     "--dt do not apply to --engine analytic"),
    ("unknown GL backend in reproduce", ["reproduce", "--gl", "vulkan"], "invalid choice: 'vulkan'"),
    ("--no-switch with another controller", ["simulate", "--no-switch", "--controller", "lqr"], "contradicts"),
    ("gains for a controller without gains", ["simulate", "--controller", "passive", "--kP", "3"],
     "apply to the controllers"),
    ("a GL backend without a video", ["reproduce", "--no-video", "--gl", "egl"], "--no-video skips"),
    ("--fresh without --out", ["basin", "--fresh"], "without --out nothing is kept"),
    ("--kip-duration for a controller without a kip", ["simulate", "--kip-duration", "2"], "--kip-duration applies"),
    ("--starts without --simulate", ["atlas", "--starts", "2"], "--starts applies with --simulate only"),
]


@pytest.fixture(scope="module")
def saved_trajectory(tmp_path_factory):
    d = tmp_path_factory.mktemp("traj")
    assert cli("simulate", "--t-final", "0.3", "--out", d).returncode == 0
    return d / "trajectory.npz"


@pytest.mark.parametrize("what, args, fragment", CONTRADICTIONS, ids=[c[0] for c in CONTRADICTIONS])
def test_contradictory_options_are_refused(what, args, fragment, saved_trajectory, tmp_path, run):
    proc = run(*[a.format(traj=saved_trajectory, d=tmp_path) for a in args])
    _one_line_error(proc, fragment)
    assert not (tmp_path / "v.mp4").exists()


def test_includes_resolve_against_the_model_folder(tmp_path):
    folder = tmp_path / "robot"
    (folder / "parts").mkdir(parents=True)
    start, end = GYMNAST.index("  <actuator>"), GYMNAST.index("  </actuator>") + len("  </actuator>\n")
    (folder / "parts" / "motors.xml").write_text("<mujoco>\n" + GYMNAST[start:end] + "</mujoco>\n")
    (folder / "main.xml").write_text(GYMNAST[:start] + '  <include file="parts/motors.xml"/>\n' + GYMNAST[end:])
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    proc = cli("simulate", "--robot", folder / "main.xml", "--t-final", "0.2", "--json", cwd=elsewhere)
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["max_abs_tau"][0] > 0


@pytest.mark.parametrize("where", ["model", "include"])
def test_a_fifo_is_refused_not_waited_on(tmp_path, where):
    fifo = tmp_path / "pipe.xml"
    os.mkfifo(fifo)
    path = fifo
    if where == "include":
        path = tmp_path / "main.xml"
        path.write_text(GYMNAST.replace("</mujoco>", '<include file="pipe.xml"/>\n</mujoco>'))
    start = time.time()
    proc = cli("theory", "--robot", path, timeout=60)
    _one_line_error(proc, "is not a regular file")
    assert time.time() - start < 30


BOUNDED = [
    ("steps of one run", ["simulate", "--t-final", "1e9"], "would need 1e+12 physics steps"),
    ("a basin too large", ["basin", "--grid", "2000", "--t-final", "1000", "--scheduler", "inline"], "would need"),
    ("too many trials", ["robustness", "--trials", "100000", "--scheduler", "inline"], "would need"),
    ("cross-check samples", ["check", "--samples", "1000000000000"], "GiB of cross-check samples"),
    ("frames of a video", ["render", "--t-final", "1", "--fps", "1000000", "--out", "{d}/v.mp4"], "would need 1000001 frames"),
    ("frame size", ["render", "--width", "100000", "--t-final", "0.1", "--out", "{d}/v.mp4"], "--width must be"),
    ("delay line", ["robustness", "--trials", "1", "--model-error", "1e400"], "finite"),
]


@pytest.mark.parametrize("what, args, fragment", BOUNDED, ids=[b[0] for b in BOUNDED])
def test_oversized_requests_are_refused_within_seconds(what, args, fragment, tmp_path, run):
    start = time.time()
    proc = run(*[a.format(d=tmp_path) for a in args])
    _one_line_error(proc, fragment)
    assert time.time() - start < 20
    assert not (tmp_path / "v.mp4").exists()


NUMBERS = [
    ["simulate", "--t-final", "nan"], ["simulate", "--t-final", "inf"], ["simulate", "--t-final", "-1"],
    ["simulate", "--dt", "nan"], ["simulate", "--dt", "0"], ["simulate", "--sample-dt", "-0.01"],
    ["simulate", "--torque-limit", "inf"], ["simulate", "--kD", "nan"], ["simulate", "--kP", "-5"],
    ["simulate", "--x0", "0", "0", "nan", "0", "0", "0"], ["simulate", "--x0", "0", "0", "inf", "0", "0", "0"],
    ["render", "--fps", "nan", "--out", "v.mp4"], ["render", "--fps", "-30", "--out", "v.mp4"],
    ["basin", "--grid", "-3"], ["basin", "--t-final", "nan"], ["robustness", "--trials", "0"],
    ["robustness", "--model-error", "nan"], ["robustness", "--model-error", "-2"], ["check", "--samples", "-1"],
    ["make-model", "--m", "1", "nan", "1", "--l", "1", "1", "1", "--out", "x.xml"],
    ["make-model", "--m", "1", "1", "1", "--l", "1", "inf", "1", "--out", "x.xml"],
]


@pytest.mark.parametrize("args", NUMBERS, ids=[" ".join(a) for a in NUMBERS])
def test_nan_inf_and_negative_numbers_are_one_line(args, tmp_path, run):
    proc = run(*args, cwd=tmp_path)
    _one_line_error(proc, "")
    assert not list(tmp_path.iterdir())


def test_corrupted_trajectory_times(tmp_path, run):
    from paa_mj.io import write_npz

    path = tmp_path / "t.npz"
    write_npz(path, t=np.array([0.0, 1e9]), q=np.zeros((2, 3)), qd=np.zeros((2, 3)), tau=np.zeros((2, 2)),
              E_minus_Er=np.zeros(2), V=np.zeros(2), mode=np.zeros(2, np.int8), switch_time=np.nan,
              meta='{"robot": "gymnast"}')
    _one_line_error(run("render", "--from", path, "--out", tmp_path / "v.mp4"), "frames")
    write_npz(path, t=np.array([0.0, 2.0, 1.0]), q=np.zeros((3, 3)), qd=np.zeros((3, 3)), tau=np.zeros((3, 2)),
              E_minus_Er=np.zeros(3), V=np.zeros(3), mode=np.zeros(3, np.int8), switch_time=np.nan, meta="{}")
    _one_line_error(run("render", "--from", path, "--out", tmp_path / "v.mp4"), "not increasing")


def test_a_closed_pipe_ends_quietly():
    proc = subprocess.run(f"{sys.executable} -m paa_mj.cli theory | head -1", shell=True, capture_output=True,
                          text=True, timeout=120)
    assert proc.stdout.startswith("Theory of Liu & Xin")
    assert "Traceback" not in proc.stderr and "BrokenPipe" not in proc.stderr


@pytest.fixture
def tiny_filesystem(tmp_path):
    if os.geteuid() != 0:
        pytest.skip("mounting a small tmpfs needs root")
    mount = tmp_path / "full"
    mount.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=160k", "tmpfs", str(mount)],
                      capture_output=True).returncode != 0:
        pytest.skip("cannot mount a tmpfs here")
    yield mount
    subprocess.run(["umount", str(mount)], capture_output=True)


def test_a_full_disk_leaves_no_partial_set(tiny_filesystem, run):
    out = tiny_filesystem / "run"
    proc = run("simulate", "--t-final", "20", "--out", out, "--json")
    _one_line_error(proc, "No space left on device")
    assert not out.exists() or not list(out.iterdir())  # npz, csv and json: all or none


def test_render_interrupted_while_encoding_leaves_no_file(tmp_path, saved_trajectory):
    from paa_mj.outputs.gl import probe

    if probe("egl") and probe("osmesa"):
        pytest.skip("no offscreen GL backend")
    assert cli("simulate", "--t-final", "20", "--out", tmp_path / "run").returncode == 0
    out = tmp_path / "video"
    out.mkdir()
    proc = subprocess.Popen([sys.executable, "-m", "paa_mj.cli", "render", "--from", str(tmp_path / "run" /
                             "trajectory.npz"), "--fps", "30", "--width", "320", "--height", "240", "--out",
                             str(out / "kip.mp4")], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 120
    while time.time() < deadline and not any(p.name.startswith(".kip.mp4") and p.stat().st_size > 0
                                             for p in out.iterdir()):
        time.sleep(0.05)
    proc.send_signal(signal.SIGTERM)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 143, stderr
    assert "Traceback" not in stderr and len(stderr.strip().splitlines()) == 1
    assert list(out.iterdir()) == []


def test_ctrl_c_while_a_set_is_written_saves_the_set_then_stops(tmp_path):
    """The interruption arrives between two files of a set: the set is written whole, then Ctrl-C acts."""
    import os
    import signal

    from paa_mj.io import write_set

    def first(path):
        path.write_text("first")
        os.kill(os.getpid(), signal.SIGINT)

    with pytest.raises(KeyboardInterrupt):
        write_set(tmp_path / "set", {"a.txt": first, "b.txt": lambda path: path.write_text("second")})
    assert sorted(p.name for p in (tmp_path / "set").iterdir()) == ["a.txt", "b.txt"]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


@pytest.mark.parametrize("kind", ["fifo", "symlink", "folder"])
def test_an_output_path_that_is_not_a_regular_file_is_refused(kind, tmp_path, run):
    import os

    target = tmp_path / "model.xml"
    if kind == "fifo":
        os.mkfifo(target)
    elif kind == "symlink":
        (tmp_path / "real.xml").write_text("")
        target.symlink_to(tmp_path / "real.xml")
    else:
        target.mkdir()
    _one_line_error(run("make-model", "--m", 1, 1, 1, "--l", 1, 1, 1, "--out", target),
                    "symbolic link" if kind == "symlink" else "is not a regular file")
    assert (tmp_path / "real.xml").read_text() == "" if kind == "symlink" else True


USER_CONTROLLERS = '''
import sys
import numpy as np


class _Zero:
    def __init__(self, robot=None):
        pass

    def torque(self, q, qd, t=0.0):
        return np.zeros(np.shape(q)[:-1] + (2,))


class ResetFails(_Zero):
    def reset(self):
        raise RuntimeError("reset boom")


class ModeNotInteger(_Zero):
    mode = "banana"


class ModeFails(_Zero):
    @property
    def mode(self):
        raise RuntimeError("mode boom")


class Exits(_Zero):
    def torque(self, q, qd, t=0.0):
        sys.exit(0)
'''


@pytest.mark.parametrize("name, fragment", [
    ("ResetFails", "ResetFails.reset failed: RuntimeError: reset boom"),
    ("ModeNotInteger", "ModeNotInteger.mode must be an integer"),
    ("ModeFails", "ModeFails.mode failed: RuntimeError: mode boom"),
    ("Exits", "Exits.torque failed: SystemExit"),
])
@pytest.mark.parametrize("engine", ["mujoco", "analytic"])
def test_a_user_controller_that_misbehaves_is_one_line(name, fragment, engine, tmp_path, run):
    (tmp_path / "mine.py").write_text(USER_CONTROLLERS)
    _one_line_error(run("simulate", "--engine", engine, "--controller", f"{tmp_path}/mine.py:{name}",
                        "--t-final", "0.1"), fragment)


CONTRADICTIONS_AND_RANGES = [
    (["atlas", "--grid", "2", "--t-final", "5"], "--t-final applies with --simulate only"),
    (["atlas", "--grid", "2", "--seed", "3", "--starts", "1"], "--starts, --seed apply with --simulate only"),
    (["check", "--seed", "-1"], "--seed: must be in [0, 2^63)"),
    (["robustness", "--seed", "99999999999999999999"], "--seed: must be in [0, 2^63)"),
    (["theory", "--kD", "1e300", "--kP", "1e300", "--kV", "1e300"], "kD = 1e+300 is above 1e+12"),
    (["simulate", "--x0", "1e300", "0", "0", "0", "0", "0"], "initial angle 1e+300 rad is beyond"),
    (["simulate", "--sample-dt", "0.0015", "--t-final", "1"], "not a whole number of time steps"),
    (["simulate", "--t-final", "1", "--out", ""], "--out: an empty path names no folder"),
    (["render", "--out", "clip.gif/"], "names a folder"),
    (["make-model", "--m", "1", "1", "1", "--l", "1", "1", "1", "--name", "a\nb", "--out", "x.xml"],
     "control characters"),
    (["make-model", "--m", "1", "1", "1", "--l", "1", "1", "1", "--kD", "1", "--kP", "1", "--kV", "1", "--out", "x.xml"],
     "kD = 1 is not above kD_min = 53.4"),
    (["render", "--t-final", "1", "--fps", "200", "--out", "clip.gif"], "a GIF plays between"),
    (["render", "--t-final", "1", "--fps", "0.001", "--out", "clip.gif"], "a GIF plays between"),
    (["robustness", "--factors=", "--trials", "2"], "no robustness factor given"),
    (["robustness", "--factors", "model_error", "--model-error", "99.9", "--trials", "2"], "must lie in [0, 90]"),
    (["robustness", "--factors", "torque_limit", "--controller", "passive", "--trials", "2", "--t-final", "1",
      "--scheduler", "inline"], "passive uses no torque there"),
    (["simulate", "--controller", "trajopt-effort", "--kip-duration", "1e6", "--t-final", "1"],
     "a kip duration must be in (0, 120] s"),
]


@pytest.mark.parametrize("args, fragment", CONTRADICTIONS_AND_RANGES, ids=[" ".join(c[0][:2]) + "-" + str(i)
                                                                        for i, c in enumerate(CONTRADICTIONS_AND_RANGES)])
def test_options_out_of_range_or_without_effect_are_refused(args, fragment, tmp_path, run):
    _one_line_error(run(*args, cwd=tmp_path), fragment)
    assert not list(tmp_path.iterdir())


def test_the_analytic_engine_stops_on_a_law_that_jumps_instead_of_chasing_it(run):
    # LQR (67) from the hanging state: the wrapped angle q1 = -pi jumps, and so does the unbounded torque
    _one_line_error(run("simulate", "--engine", "analytic", "--controller", "lqr", "--t-final", "1"),
                    "the integrator's step fell below", code=3)


def test_a_full_standard_output_is_one_line(tmp_path):
    if not os.path.exists("/dev/full"):
        pytest.skip("no /dev/full here")
    with open("/dev/full", "w") as full:
        proc = subprocess.run([sys.executable, "-m", "paa_mj.cli", "theory"], stdout=full, stderr=subprocess.PIPE,
                              text=True, timeout=120)
    assert proc.returncode == 2 and proc.stderr.strip() == "paa-mj: error: cannot write the output: No space left" \
        " on device", proc.stderr


def test_mujoco_warnings_leave_no_log_file_and_no_console_lines(tmp_path, run):
    (tmp_path / "mine.py").write_text(USER_CONTROLLERS + '''

class Kick(_Zero):
    def torque(self, q, qd, t=0.0):
        return np.full(np.shape(q)[:-1] + (2,), 1e12)
''')
    proc = cli("simulate", "--controller", f"{tmp_path}/mine.py:Kick", "--t-final", "0.1", cwd=tmp_path)
    _one_line_error(proc, "MuJoCo warned of an unstable simulation", code=3)
    assert proc.stderr.count("\n") == 1 and "WARNING" not in proc.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine.py"]


def test_a_folder_of_another_commands_results_is_refused(tmp_path, run):
    out = tmp_path / "study"
    assert run("basin", "--grid", "2", "--t-final", "0.05", "--scheduler", "inline", "--out", out).returncode == 0
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}
    _one_line_error(run("simulate", "--t-final", "0.05", "--out", out), "holds the results of 'paa-mj basin'")
    assert {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()} == before
    assert run("basin", "--grid", "2", "--t-final", "0.05", "--scheduler", "inline", "--out", out).returncode == 0


PRINTING_AND_FAILING = USER_CONTROLLERS + '''

class Chatty(_Zero):
    def __init__(self, robot=None):
        print("hello from __init__")

    def torque(self, q, qd, t=0.0):
        print("tick", t)
        return np.zeros(np.shape(q)[:-1] + (2,))


class LateNaN(_Zero):
    def torque(self, q, qd, t=0.0):
        return np.full(np.shape(q)[:-1] + (2,), np.nan if t > 0.05 else 0.0)


class Damped(_Zero):
    def torque(self, q, qd, t=0.0):
        return -10.0 * qd[..., 1:]
'''


def _strict(text):
    def refuse(constant):
        raise ValueError(f"{constant} is not JSON")
    return json.loads(text, parse_constant=refuse)


def test_json_is_strict_and_alone_on_stdout(tmp_path, run):
    (tmp_path / "mine.py").write_text(PRINTING_AND_FAILING)
    proc = run("simulate", "--controller", f"{tmp_path}/mine.py:Chatty", "--t-final", "0.05", "--json")
    assert proc.returncode == 0, proc.stderr
    summary = _strict(proc.stdout)  # one object: the controller's prints went to stderr
    assert summary["V_final"] is None  # no energy law: V is undefined, written as null rather than NaN
    assert "hello from __init__" in proc.stderr and "tick" in proc.stderr


@pytest.mark.parametrize("engine", ["mujoco", "analytic"])
def test_a_diverged_run_prints_what_it_computed_as_json(engine, tmp_path, run):
    (tmp_path / "mine.py").write_text(PRINTING_AND_FAILING)
    proc = run("simulate", "--engine", engine, "--controller", f"{tmp_path}/mine.py:LateNaN", "--t-final", "1",
               "--json")
    _one_line_error(proc, "the controller returned a non-finite torque", code=3)
    summary = _strict(proc.stdout)
    assert summary["status"].startswith("diverged at t = 0.0") and summary["final_time"] < 0.06


def test_a_file_that_is_not_a_trajectory_is_named_so(tmp_path, run):
    (tmp_path / "summary.json").write_text("{}")
    _one_line_error(run("render", "--from", tmp_path / "summary.json", "--out", tmp_path / "v.gif"),
                    "not an .npz archive")


def test_two_controllers_that_would_share_result_files_are_refused(tmp_path, run):
    for folder in ("a", "b"):
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "mine.py").write_text(PRINTING_AND_FAILING)
    _one_line_error(run("compare", "--controllers", f"{tmp_path}/a/mine.py:Damped,{tmp_path}/b/mine.py:Damped",
                        "--quick", "--scheduler", "inline"), "would share the name mine_py_Damped")


def test_a_diverging_kip_is_no_torque_scale(gymnast):
    from paa_mj.errors import PaaError
    from paa_mj.sim.batch import kip_peak_torques

    class Kick:
        def torque(self, q, qd, t=0.0):
            return np.full(np.shape(q)[:-1] + (2,), 1e12)

    with pytest.raises(PaaError, match=r"the kip of Kick from \(65\) diverged at t = "):
        kip_peak_torques(gymnast, Kick(), t_final=1.0)


def test_a_chunk_that_saw_the_interrupt_is_kept_and_the_study_stops():
    from paa_mj.studies.runner import map_chunks

    calls = []

    def task(shared, payload):
        calls.append(payload)
        return {"value": payload, "interrupted": payload == 1}  # the signal came as chunk 1 ended

    finished, interrupted = map_chunks(task, [0, 1, 2, 3])
    assert interrupted and calls == [0, 1] and finished == {0: {"value": 0}, 1: {"value": 1}}


# --- issue 17: silent wrong answers ---

INPUT_WRITERS = USER_CONTROLLERS + '''

class Reads(_Zero):
    def torque(self, q, qd, t=0.0):
        return -50.0 * q[..., 1:] - 10.0 * qd[..., 1:]


class Writes(Reads):
    def torque(self, q, qd, t=0.0):
        tau = super().torque(q, qd, t)
        q[...] = 0.0  # a controller that scribbles on its inputs must not move the robot
        qd[...] = 0.0
        return tau


class Complex(Reads):
    def torque(self, q, qd, t=0.0):
        return super().torque(q, qd, t) + 1j


class Boolean(_Zero):
    def torque(self, q, qd, t=0.0):
        return np.ones(np.shape(q)[:-1] + (2,), bool)


class ModeTwo(Reads):
    mode = 2
'''


@pytest.fixture
def input_writers(tmp_path):
    import importlib.util

    (tmp_path / "writers.py").write_text(INPUT_WRITERS)
    spec = importlib.util.spec_from_file_location("writers_issue17", tmp_path / "writers.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("engine", ["mujoco", "analytic"])
def test_a_controller_that_writes_into_its_inputs_does_not_move_the_robot(engine, gymnast, input_writers):
    from paa_mj.sim import simulate_analytic, simulate_mujoco

    x0 = np.array([-3.0, 0.5, 0.2, 0.0, 0.0, 0.0])
    simulate = simulate_mujoco if engine == "mujoco" else simulate_analytic
    reads = simulate(gymnast, input_writers.Reads(), x0, t_final=0.2)
    writes = simulate(gymnast, input_writers.Writes(), x0, t_final=0.2)
    np.testing.assert_array_equal(writes.q, reads.q)
    np.testing.assert_array_equal(writes.qd, reads.qd)
    np.testing.assert_array_equal(writes.tau, reads.tau)
    assert np.abs(reads.q[-1]).max() > 1  # not the zeros the writer leaves in its copies


@pytest.mark.parametrize("name, fragment", [
    ("Complex", "Complex.torque returned complex128 torques; it must return real numbers"),
    ("Boolean", "Boolean.torque returned bool torques; it must return real numbers"),
    ("ModeTwo", "ModeTwo.mode must be 0 (swing-up) or 1 (balance), got 2"),
])
@pytest.mark.parametrize("engine", ["mujoco", "analytic"])
def test_complex_or_boolean_torques_and_a_mode_of_2_are_refused(name, fragment, engine, tmp_path, run):
    (tmp_path / "mine.py").write_text(INPUT_WRITERS)
    _one_line_error(run("simulate", "--engine", engine, "--controller", f"{tmp_path}/mine.py:{name}",
                        "--t-final", "0.05"), fragment)


@pytest.fixture
def modified_gymnast_run(tmp_path, run):
    """A run of a gymnast.xml with another mass of link 1, saved: the file keeps the name gymnast."""
    path = tmp_path / "heavier.xml"
    path.write_text(_variant('<inertial pos="0 0 0.31" mass="5.4"', '<inertial pos="0 0 0.31" mass="5.0"'))
    out = tmp_path / "run"
    assert run("simulate", "--robot", path, "--t-final", "0.1", "--out", out).returncode == 0
    return path, out / "trajectory.npz"


def test_render_from_refuses_a_trajectory_of_another_model_of_the_same_name(modified_gymnast_run, tmp_path, run):
    path, traj = modified_gymnast_run
    _one_line_error(run("render", "--from", traj, "--robot", "gymnast", "--out", tmp_path / "v.gif"),
                    "is a trajectory of robot 'gymnast' as another model than --robot gymnast (MJCF sha256")
    assert not (tmp_path / "v.gif").exists()


def test_a_trajectory_file_carries_its_robot_byte_for_byte_the_same(modified_gymnast_run, tmp_path, run):
    import hashlib

    from paa_mj.cli.simulate import _robot_of
    from paa_mj.sim.trajectory import Trajectory

    path, traj_path = modified_gymnast_run
    traj = Trajectory.load(traj_path)
    with np.load(traj_path) as z:
        assert str(z["robot_sha256"]) == hashlib.sha256(path.read_bytes()).hexdigest() == traj.robot_sha256
    assert _robot_of(traj, traj_path, None).params.m[0] == 5.0  # without --robot: the robot in the file
    assert _robot_of(traj, traj_path, str(path)).params.m[0] == 5.0
    again = tmp_path / "again"
    assert run("simulate", "--robot", path, "--t-final", "0.1", "--out", again).returncode == 0
    assert (again / "trajectory.npz").read_bytes() == traj_path.read_bytes()


def test_an_old_trajectory_without_its_robot_is_drawn_with_a_warning(saved_trajectory, tmp_path, run):
    from paa_mj.io import write_npz

    with np.load(saved_trajectory) as z:
        old = {name: z[name] for name in z.files if name not in ("robot_sha256", "robot_mjcf")}
    path = tmp_path / "old.npz"
    write_npz(path, **old)
    proc = run("render", "--from", path, "--robot", "example2", "--out", tmp_path / "v.gif")
    _one_line_error(proc, "is a trajectory of robot 'gymnast', not of --robot example2")
    warning, = proc.stderr.strip().splitlines()[:-1]
    assert warning.startswith("paa-mj: warning:") and "does not record its robot's model" in warning


BAD_ENV_ARGS = [
    (dict(torque_limit=-5.0), "torque_limit must be a positive finite number"),
    (dict(torque_limit=float("nan")), "torque_limit must be a positive finite number"),
    (dict(frame_skip=0), "frame_skip must be in [1, 1000000]"),
    (dict(frame_skip=-2), "frame_skip must be in [1, 1000000]"),
    (dict(frame_skip=1.5), "frame_skip must be a whole number"),
    (dict(max_episode_seconds=float("nan")), "max_episode_seconds must be a positive finite number"),
    (dict(max_episode_seconds=1e-6), "shorter than one environment step"),
    (dict(init_noise=float("nan")), "init_noise must be a finite number >= 0"),
    (dict(init_noise=-0.1), "init_noise must be a finite number >= 0"),
    (dict(width=0), "width must be in [16, 4096]"),
    (dict(normalize_actions="no"), "normalize_actions must be True or False"),
]


@pytest.mark.parametrize("kwargs, fragment", BAD_ENV_ARGS, ids=[str(a[0]) for a in BAD_ENV_ARGS])
def test_the_gym_env_refuses_arguments_it_would_misread(kwargs, fragment):
    pytest.importorskip("gymnasium")
    from paa_mj.gym_env import GymnastKipEnv

    with pytest.raises(ValueError) as caught:
        GymnastKipEnv(**kwargs)
    assert fragment in str(caught.value) and "\n" not in str(caught.value)


def test_the_gym_env_clips_at_the_models_actuator_ranges(tmp_path):
    pytest.importorskip("gymnasium")
    from paa_mj.gym_env import GymnastKipEnv

    path = tmp_path / "limited.xml"
    path.write_text(_variant('<motor name="shoulder" joint="shoulders" gear="1"/>',
                             '<motor name="shoulder" joint="shoulders" gear="1" ctrlrange="-60 60"/>'))
    env = GymnastKipEnv(robot=str(path), torque_limit=100.0)
    np.testing.assert_array_equal(env.torque_limits, [60.0, 100.0])
    np.testing.assert_array_equal(env.action_space.high, [60.0, 100.0])
    env.reset(seed=0)
    env.step(np.array([500.0, -500.0], np.float32))
    np.testing.assert_array_equal(env.data.ctrl, [60.0, -100.0])
    normalised = GymnastKipEnv(robot=str(path), normalize_actions=True)
    np.testing.assert_allclose(normalised.action_to_torque([1.0, -1.0]), [60.0, -normalised.torque_limit])


@pytest.mark.parametrize("variable, value, fragment", [
    ("MUJOCO_GL", "invalid", "MUJOCO_GL='invalid' is not a GL backend MuJoCo knows"),
    ("NUMBA_NUM_THREADS", "0", "NUMBA_NUM_THREADS='0' must be a whole number >= 1"),
    ("NUMBA_NUM_THREADS", "abc", "NUMBA_NUM_THREADS='abc' must be a whole number >= 1"),
])
def test_an_environment_that_breaks_mujoco_or_numba_is_one_line(variable, value, fragment, tmp_path):
    proc = cli("simulate", "--t-final", "0.1", cwd=tmp_path, env=dict(os.environ, **{variable: value}), timeout=60)
    _one_line_error(proc, fragment)
    assert proc.stderr.count("\n") == 1


@pytest.mark.parametrize("engine", ["mujoco", "analytic"])
def test_a_final_time_too_long_to_count_says_what_it_would_need(engine, run):
    _one_line_error(run("simulate", "--engine", engine, "--t-final", "1e308"),
                    "--t-final 1e+308 s is too long: it would need about 1e+311 physics steps")


def test_a_full_disk_while_taking_the_output_lock_is_one_line_and_leaves_no_lock(tmp_path, run, monkeypatch):
    import builtins
    import errno

    import paa_mj.io

    class FullDisk:
        """A file on a full disk: its text stays in the buffer, flushing it fails."""

        def __init__(self, handle):
            self._handle = handle

        def __getattr__(self, name):
            return getattr(self._handle, name)

        def flush(self):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    def full_open(path, *args, **kwargs):
        handle = builtins.open(path, *args, **kwargs)
        return FullDisk(handle) if str(path).endswith(".paa-mj.lock") else handle

    monkeypatch.setattr(paa_mj.io, "open", full_open, raising=False)
    out = tmp_path / "run"
    _one_line_error(run("simulate", "--t-final", "0.05", "--out", out),
                    f"cannot lock output folder {out}: No space left on device")
    assert list(out.iterdir()) == []  # no stale lock


def test_a_gear_with_other_components_names_them(tmp_path, run):
    path = tmp_path / "robot.xml"
    path.write_text(_variant('<motor name="hip" joint="hips" gear="1"/>',
                             '<motor name="hip" joint="hips" gear="1 0 0 0 0 0.5"/>'))
    _one_line_error(run("theory", "--robot", path), 'actuator 1 gear "1 0 0 0 0 0.5": gear component 6 = 0.5 must be 0')


@pytest.mark.parametrize("args", [["basin", "--grid", "١٠"], ["simulate", "--t-final", "０.1"],
                                  ["check", "--seed", "٣"], ["simulate", "--x0", "-٣", "0", "0", "0", "0", "0"]],
                         ids=["arabic-indic grid", "full-width t-final", "arabic-indic seed", "x0"])
def test_numbers_in_other_scripts_than_ascii_are_refused(args, tmp_path, run):
    _one_line_error(run(*args, cwd=tmp_path), "write numbers with the ASCII digits 0-9")
    assert not list(tmp_path.iterdir())


def test_loading_a_robot_from_python_leaves_no_mujoco_log(tmp_path, monkeypatch):
    from paa_mj.errors import PaaError
    from paa_mj.model import load_robot

    path = tmp_path / "robot.xml"
    path.write_text(_variant('<inertial pos="0 0 0.31" mass="5.4"', '<inertial pos="0 0 0.31" mass="nan"'))
    monkeypatch.chdir(tmp_path)
    with pytest.raises(PaaError, match="malformed MJCF"):
        load_robot(path)  # MuJoCo's compiler warns of the NaN before it refuses the mass
    assert sorted(p.name for p in tmp_path.iterdir()) == ["robot.xml"]


def test_simulate_does_not_overwrite_a_summary_it_did_not_write(tmp_path, run):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "summary.json").write_text('{"my": "notes"}')
    _one_line_error(run("simulate", "--t-final", "0.05", "--out", out),
                    "holds summary.json, not the results of a 'paa-mj simulate'")
    assert sorted(p.name for p in out.iterdir()) == ["summary.json"]
    assert (out / "summary.json").read_text() == '{"my": "notes"}'
    assert run("simulate", "--t-final", "0.05", "--out", tmp_path / "own").returncode == 0
    assert run("simulate", "--t-final", "0.05", "--out", tmp_path / "own").returncode == 0  # its own: replaced
