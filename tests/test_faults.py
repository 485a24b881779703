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
    ("friction loss", HIPS, '<joint name="hips" type="hinge" axis="0 1 0" frictionloss="0.2"/>', "friction loss"),
    ("stiffness", HIPS, '<joint name="hips" type="hinge" axis="0 1 0" stiffness="3"/>', "joint stiffness"),
    ("gravity upwards", 'gravity="0 0 -9.81"', 'gravity="0 0 5"', "gravity [0.0, 0.0, 5.0]"),
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
    from paa_mj.cli import main

    d = tmp_path_factory.mktemp("traj")
    assert main(["simulate", "--t-final", "0.3", "--out", str(d)]) == 0  # in this process: no start-up to pay
    return d / "trajectory.npz"


@pytest.mark.parametrize("what, args, fragment", CONTRADICTIONS, ids=[c[0] for c in CONTRADICTIONS])
def test_contradictory_options_are_refused(what, args, fragment, saved_trajectory, tmp_path, run):
    proc = run(*[a.format(traj=saved_trajectory, d=tmp_path) for a in args])
    _one_line_error(proc, fragment)
    assert not (tmp_path / "v.mp4").exists()


def test_includes_resolve_against_the_model_folder(tmp_path, run):
    folder = tmp_path / "robot"
    (folder / "parts").mkdir(parents=True)
    start, end = GYMNAST.index("  <actuator>"), GYMNAST.index("  </actuator>") + len("  </actuator>\n")
    (folder / "parts" / "motors.xml").write_text("<mujoco>\n" + GYMNAST[start:end] + "</mujoco>\n")
    (folder / "main.xml").write_text(GYMNAST[:start] + '  <include file="parts/motors.xml"/>\n' + GYMNAST[end:])
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    proc = run("simulate", "--robot", folder / "main.xml", "--t-final", "0.2", "--json", cwd=elsewhere)
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


def test_render_interrupted_while_encoding_leaves_no_file(tmp_path, saved_trajectory, run):
    from paa_mj.view.gl import probe

    if probe("egl") and probe("osmesa"):
        pytest.skip("no offscreen GL backend")
    assert run("simulate", "--t-final", "20", "--out", tmp_path / "run").returncode == 0  # only the render is timed
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

    # as in a terminal, even when this test runs where SIGINT is ignored (a background job)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(KeyboardInterrupt):
            write_set(tmp_path / "set", {"a.txt": first, "b.txt": lambda path: path.write_text("second")})
        assert sorted(p.name for p in (tmp_path / "set").iterdir()) == ["a.txt", "b.txt"]
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    finally:
        signal.signal(signal.SIGINT, previous)


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
      "--scheduler", "inline"], "is 0 N m, not a physical torque scale for robot gymnast"),
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
    from paa_mj.task import Task

    class Kick:
        def torque(self, q, qd, t=0.0):
            return np.full(np.shape(q)[:-1] + (2,), 1e12)

    with pytest.raises(PaaError, match=r"the run of Kick from the folded task's start diverged at t = "):
        kip_peak_torques(gymnast, Kick(), Task.named("folded", gymnast), t_final=1.0)


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
    from paa_mj.envs import GymnastKipEnv

    with pytest.raises(ValueError) as caught:
        GymnastKipEnv(**kwargs)
    assert fragment in str(caught.value) and "\n" not in str(caught.value)


def test_the_gym_env_clips_at_the_models_actuator_ranges(tmp_path):
    pytest.importorskip("gymnasium")
    from paa_mj.envs import GymnastKipEnv

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


# --- issue 17: second adversarial pass ---
#
# Every table below is a set of distinct cases; each asserts something that could fail: the exit code and the
# one line on stderr with its key words, no traceback, a strict JSON object alone on stdout, or a consistency
# property of what was computed.

def _made(text, old, new):
    """``text`` (make-model's MJCF) with ``old`` replaced by ``new`` once (all occurrences when old starts with *)."""
    if old.startswith("*"):
        assert old[1:] in text, old
        return text.replace(old[1:], new)
    if old == "PAA_GAINS":
        import re

        return re.sub(r'<numeric name="paa_gains" data="[^"]*"/>', new, text)
    assert old in text, old
    return text.replace(old, new, 1)


@pytest.fixture(scope="module")
def made_xml(tmp_path_factory):
    """The MJCF text that 'paa-mj make-model' writes for a small robot: the base of the model variants below."""
    import contextlib
    import io

    from paa_mj.cli import main

    path = tmp_path_factory.mktemp("made") / "robot.xml"
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        assert main(["make-model", "--m", "2", "1", "1", "--l", "1", "0.6", "0.6", "--out", str(path)]) == 0
    return path.read_text()


M_HIPS = '<joint name="hips" type="hinge" axis="0 1 0"/>'
M_HANDS = '<joint name="hands" type="hinge" axis="0 1 0"/>'
M_HIP = '<motor name="hip" joint="hips" gear="1"/>'
M_MOTORS = '<motor name="shoulder" joint="shoulders" gear="1"/>\n    <motor name="hip" joint="hips" gear="1"/>'
M_GEAR = 'joint="hips" gear="1"'
M_LINK1 = '<inertial pos="0 0 0.5" mass="2.0"'

REFUSED_MODELS = [
    ("slide joint", M_HIPS, '<joint name="hips" type="slide" axis="0 1 0"/>', "found 3 joints with 3 DoF"),
    ("ball joint", M_HIPS, '<joint name="hips" type="ball"/>', "found 3 joints with 5 DoF"),
    ("free joint for the hands", M_HANDS, '<freejoint name="hands"/>', "found 3 joints with 8 DoF"),
    ("a fourth joint", M_HIPS, M_HIPS + '<joint name="hips2" type="hinge" axis="0 1 0"/>', "found 4 joints"),
    ("a joint removed", M_HIPS, "", "unknown transmission target 'hips'"),
    ("hinge axis along x", M_HIPS, '<joint name="hips" type="hinge" axis="1 0 0"/>', "hinge axes must be the same"),
    ("one hinge axis reversed", M_HIPS, '<joint name="hips" type="hinge" axis="0 -1 0"/>',
     "hinge axes must be the same"),
    ("vertical hinge axes", '*axis="0 1 0"', 'axis="0 0 1"', "hinge axes must be horizontal"),
    ("no actuators", M_MOTORS, "", "0 actuators"),
    ("one actuator", M_HIP, "", "1 actuators"),
    ("motors swapped", M_MOTORS, M_MOTORS.split("\n    ")[1] + "\n    " + M_MOTORS.split("\n    ")[0],
     "motors must drive joints 2..3 in that order"),
    ("a motor on the hands", 'joint="shoulders" gear="1"', 'joint="hands" gear="1"', "found joints [1, 3]"),
    ("gear -1", M_GEAR, 'joint="hips" gear="-1"', "actuator 1 gear -1 (the model needs gear 1)"),
    ("gear 0", M_GEAR, 'joint="hips" gear="0"', "actuator 1 gear 0 (the model needs gear 1)"),
    ("gear NaN", M_GEAR, 'joint="hips" gear="nan"', "actuator 1 gear nan (the model needs gear 1)"),
    ("ctrlrange inverted", M_GEAR, M_GEAR + ' ctrlrange="5 -5"', "actuator 1 ctrlrange [5, -5] is not a range"),
    ("ctrlrange NaN", M_GEAR, M_GEAR + ' ctrlrange="nan nan"', "actuator 1 ctrlrange [nan, nan] is not a range"),
    ("forcerange inverted", M_GEAR, M_GEAR + ' forcerange="5 -5"', "actuator 1 forcerange [5, -5] is not a range"),
    ("actuatorfrcrange inverted", M_HIPS, M_HIPS.replace("/>", ' actuatorfrcrange="7 -7"/>'),
     "joint 3 actuatorfrcrange [7, -7] is not a range"),
    ("ctrlrange limited and inverted", M_GEAR, M_GEAR + ' ctrllimited="true" ctrlrange="5 -5"',
     "invalid control range"),
    ("ctrlrange infinite", M_GEAR, M_GEAR + ' ctrlrange="-inf inf"', "ctrlrange [-inf, inf]"),
    ("forcerange asymmetric", M_GEAR, M_GEAR + ' forcerange="-5 6"', "forcerange [-5, 6]"),
    ("actuatorfrcrange asymmetric", M_HIPS, M_HIPS.replace("/>", ' actuatorfrcrange="-7 8"/>'),
     "actuatorfrcrange [-7, 8]"),
    ("general actuator with a bias", M_HIP, '<general name="hip" joint="hips" gainprm="1" biastype="affine"'
     ' biasprm="0 0 -1"/>', "is not a <motor>"),
    ("general actuator of gain 2", M_HIP, '<general name="hip" joint="hips" gainprm="2"/>', "is not a <motor>"),
    ("filter dynamics", M_HIP, '<general name="hip" joint="hips" dyntype="filter" dynprm="0.1"/>',
     "is not a <motor>"),
    ("integrator dynamics", M_HIP, '<general name="hip" joint="hips" dyntype="integrator" gainprm="1"/>',
     "is not a <motor>"),
    ("velocity servo", M_HIP, '<velocity name="hip" joint="hips" kv="1"/>', "is not a <motor>"),
    ("damper", M_HIP, '<damper name="hip" joint="hips" kv="1" ctrlrange="0 1"/>', "is not a <motor>"),
    ("a motor on a site", M_HIP, '<motor name="hip" site="feet" gear="1 0 0 0 0 0"/>', "must act on a joint"),
    ("time step 1 s", 'timestep="0.001"', 'timestep="1"', "timestep = 1 s must lie in (0, 0.1]"),
    ("infinite time step", 'timestep="0.001"', 'timestep="inf"', "timestep = inf s"),
    ("unknown integrator", 'integrator="RK4"', 'integrator="leapfrog"', "invalid keyword: 'leapfrog'"),
    ("no gravity", 'gravity="0 0 -9.81"', 'gravity="0 0 0"', "gravity [0.0, 0.0, 0.0]"),
    ("gravity upwards", 'gravity="0 0 -9.81"', 'gravity="0 0 9.81"', "gravity [0.0, 0.0, 9.81]"),
    ("NaN gravity", 'gravity="0 0 -9.81"', 'gravity="0 0 nan"', "gravity [0.0, 0.0, nan]"),
    ("gravity switched off", 'contact="disable"', 'contact="disable" gravity="disable"', "gravity disabled"),
    ("a flag MuJoCo lacks", 'contact="disable"', 'contact="disable" passive="disable"',
     "unrecognized attribute: 'passive'"),
    ("negative damping", M_HIPS, M_HIPS.replace("/>", ' damping="-1"/>'), "joint damping [0.0, 0.0, -1.0]"),
    ("NaN armature", M_HIPS, M_HIPS.replace("/>", ' armature="nan"/>'), "armature [0.0, 0.0, nan]"),
    ("a hinge off its body's origin", M_HIPS, M_HIPS.replace("/>", ' pos="0 0 0.1"/>'),
     "each hinge must sit at its body's origin"),
    ("a rotated link", '<body name="link3" pos="0 0 0.6">', '<body name="link3" pos="0 0 0.6" euler="0 0.1 0">',
     "link bodies must not be rotated"),
    ("link 1 rotated by a quaternion", '<body name="link1">', '<body name="link1" quat="0.9 0 0.1 0">',
     "link bodies must not be rotated"),
    ("a link bent sideways", '<body name="link3" pos="0 0 0.6">', '<body name="link3" pos="0.01 0 0.6">',
     "link 2 must point straight up"),
    ("hands off the bar", '<body name="link1">', '<body name="link1" pos="0 0 0.1">',
     "link 1 must hang from the bar at the world origin"),
    ("hands in front of the bar", '<body name="link1">', '<body name="link1" pos="0.2 0 0">',
     "link 1 must hang from the bar at the world origin"),
    ("zero mass", 'mass="2.0"', 'mass="0"', "mass and inertia of moving bodies"),
    ("negative mass", 'mass="2.0"', 'mass="-2.0"', "mass and inertia of moving bodies"),
    ("mass 1e-9 kg", 'mass="2.0"', 'mass="1e-9"', "m1 = 1e-09 lies outside the plausible range"),
    ("centre of mass beyond the link", M_LINK1, '<inertial pos="0 0 1.5" mass="2.0"', "lc1 = 1.5 must lie in [0, l1]"),
    ("centre of mass above the bar", M_LINK1, '<inertial pos="0 0 -0.5" mass="2.0"',
     "centre of mass must lie on the link"),
    ("centre of mass beside the link", M_LINK1, '<inertial pos="0.1 0 0.5" mass="2.0"',
     "centre of mass must lie on the link"),
    ("inertia against the triangle inequality", 'diaginertia="0.16666666666666666 0.16666666666666666'
     ' 0.0016666666666666666"', 'fullinertia="0.1666 0.1666 0.0016 0.01 0 0"', "inertia must satisfy A + B >= C"),
    ("a fourth body", '<site name="feet"', '<body name="toe" pos="0 0 0.6"><inertial pos="0 0 0" mass="0.1"'
     ' diaginertia="0.001 0.001 0.001"/></body><site name="feet"', "one hinge joint per link (4), found 3 joints"),
    ("a mocap body", '<camera name="side"', '<body name="x" mocap="true" pos="0 0 -1"><geom size="0.1"'
     ' contype="0" conaffinity="0"/></body><camera name="side"', "found 4 bodies"),
    ("a weld", "</actuator>", '</actuator><equality><weld body1="link3"/></equality>', "1 equality constraints"),
    ("coupled joints", "</actuator>", '</actuator><equality><joint joint1="hips" joint2="shoulders"/></equality>',
     "1 equality constraints"),
    ("a contact pair", "</actuator>", '</actuator><contact><pair geom1="legs" geom2="floor"/></contact>',
     "1 explicit contact pairs"),
    ("stored gains of 2 values", "PAA_GAINS", '<numeric name="paa_gains" data="45 120"/>',
     "paa_gains numeric needs 3 values"),
    ("infinite stored gain", "PAA_GAINS", '<numeric name="paa_gains" data="inf 120 45"/>', "paa_gains kD = inf"),
    ("stored gains of 1e300", "PAA_GAINS", '<numeric name="paa_gains" data="1e300 1e300 1e300"/>',
     "is above 1e+12"),
    ("feet above the hips", '<site name="feet" pos="0 0 0.6"', '<site name="feet" pos="0 0 -0.6"',
     "l3 = -0.6 must be > 0"),
    ("feet nearer than the centre of mass", '<site name="feet" pos="0 0 0.6"', '<site name="feet" pos="0 0 0.1"',
     "lc3 = 0.3 must lie in [0, l3]"),
]


@pytest.mark.parametrize("what, old, new, fragment", REFUSED_MODELS, ids=[m[0] for m in REFUSED_MODELS])
def test_made_models_edited_out_of_shape_are_refused_in_one_line(what, old, new, fragment, made_xml, tmp_path,
                                                                   run):
    path = tmp_path / "robot.xml"
    path.write_text(_made(made_xml, old, new))
    proc = run("simulate", "--robot", path, "--t-final", "0.05", "--json", cwd=tmp_path)
    _one_line_error(proc, fragment)
    assert proc.stdout == ""
    assert sorted(p.name for p in tmp_path.iterdir()) == ["robot.xml"]  # no MUJOCO_LOG.TXT for NaN in the file


ACCEPTED_MODELS = [
    ("hinge axis of length 2", M_HIPS, '<joint name="hips" type="hinge" axis="0 2 0"/>', {"check": True}),
    ("hands moved along the bar", '<body name="link1">', '<body name="link1" pos="0 0.5 0">', {"check": True}),
    ("link 3 weighed from its geom", '<inertial pos="0 0 0.3" mass="1.0" diaginertia="0.03 0.03 0.0003"/>\n'
     '          <geom name="legs"', '<geom name="legs"', {"check": True}),
    ("no feet site", '<site name="feet" pos="0 0 0.6" size="0.044" rgba="1 1 0 1" group="2"/>', "",
     {"check": True}),
    ("energy flag off", 'energy="enable"', 'energy="disable"', {"check": True}),
    ("a keyframe and a sensor", "</actuator>", '</actuator><keyframe><key qpos="1 2 3"/></keyframe><sensor>'
     '<jointpos joint="hips"/></sensor>', {"check": True}),
    ("ctrlrange 0 0 (none)", M_GEAR, M_GEAR + ' ctrlrange="0 0"', {"torque_limit": None}),
    ("ctrllimited false with a range", M_GEAR, M_GEAR + ' ctrllimited="false" ctrlrange="-5 5"',
     {"torque_limit": None}),
    ("symmetric ctrlrange", M_GEAR, M_GEAR + ' ctrlrange="-0.5 0.5"', {"torque_limit": [None, 0.5]}),
    ("symmetric forcerange", M_GEAR, M_GEAR + ' forcerange="-0.4 0.4"', {"torque_limit": [None, 0.4]}),
    ("symmetric actuatorfrcrange", M_HIPS, M_HIPS.replace("/>", ' actuatorfrcrange="-0.3 0.3"/>'),
     {"torque_limit": [None, 0.3]}),
    ("Euler in the file", 'integrator="RK4"', 'integrator="Euler"', {"integrator": "Euler"}),
    ("implicitfast in the file", 'integrator="RK4"', 'integrator="implicitfast"', {"integrator": "implicitfast"}),
    ("time step 2 ms in the file", 'timestep="0.001"', 'timestep="0.002"', {"dt": 0.002}),
]


@pytest.mark.parametrize("what, old, new, expect", ACCEPTED_MODELS, ids=[m[0] for m in ACCEPTED_MODELS])
def test_made_models_edited_within_the_shape_run_as_written(what, old, new, expect, made_xml, tmp_path, run):
    path = tmp_path / "robot.xml"
    path.write_text(_made(made_xml, old, new))
    if expect.get("check"):
        proc = run("check", "--robot", path, "--samples", "20", "--json")
        assert proc.returncode == 0, proc.stderr
        errors = _strict(proc.stdout)
        assert all(errors[k] < 1e-9 for k in errors if k.startswith("max_rel_err")), errors  # the paper's equations
        return
    proc = run("simulate", "--robot", path, "--controller", "vcl-only", "--t-final", "0.3", "--json")
    assert proc.returncode == 0, proc.stderr
    summary = _strict(proc.stdout)
    for key, value in expect.items():
        assert summary[key] == value, (key, summary[key])
    if "torque_limit" in expect and expect["torque_limit"] is not None:
        assert summary["max_abs_tau"][1] <= expect["torque_limit"][1]  # the file's limit is applied
        assert summary["max_abs_tau"][1] == pytest.approx(expect["torque_limit"][1])  # and reached (saturated)


BAD_OPTIONS = [
    # simulate: numbers
    (["simulate", "--t-final", "1e-9"], "--sample-dt 0.01 s is longer than --t-final 1e-09 s"),
    (["simulate", "--t-final", "-1e3"], "argument --t-final: must be a positive finite number, got -1e3"),
    (["simulate", "--t-final", "-inf"], "argument --t-final: must be a positive finite number, got -inf"),
    (["simulate", "--t-final", "infinity"], "must be a positive finite number, got infinity"),
    (["simulate", "--t-final", "1_0"], "write numbers without underscores"),
    (["simulate", "--dt", "1e-300", "--t-final", "0.1"], "would need about 1e+299 physics steps"),
    (["simulate", "--dt", "1", "--t-final", "0.5"], "shorter than one time step (1 s)"),
    (["simulate", "--dt", "0.0007", "--t-final", "0.1"], "not a whole number of time steps (dt = 0.0007 s)"),
    (["simulate", "--torque-limit", "-0"], "argument --torque-limit: must be a positive finite number, got -0"),
    (["simulate", "--torque-limit", "-1E2"], "argument --torque-limit: must be a positive finite number, got -1E2"),
    (["simulate", "--torque-limit", "0x10"], "not a number: '0x10'"),
    (["simulate", "--torque-limit", "1e"], "not a number: '1e'"),
    (["simulate", "--torque-limit", ""], "not a number: ''"),
    (["simulate", "--kD", "1e-300"], "gain kD = 1e-300 is not above kD_min"),
    (["simulate", "--kD", "1e20"], "gain kD = 1e+20 is above 1e+12"),
    (["simulate", "--kV", "-1e3"], "argument --kV: must be a positive finite number, got -1e3"),
    (["simulate", "--kip-duration", "nan", "--controller", "trajopt-effort"], "argument --kip-duration"),
    (["simulate", "--kip-duration", "0"], "argument --kip-duration: must be a positive finite number, got 0"),
    (["simulate", "--x0", "0", "0", "0", "0", "0"], "--x0 needs 6 numbers for robot gymnast (q1 q2 q3 d1 d2 d3), got 5"),
    (["simulate", "--x0", "0", "0", "0", "0", "0", "0", "0"], "--x0 needs 6 numbers for robot gymnast (q1 q2 q3 d1 d2 d3), got 7"),
    (["simulate", "--x0", "0", "0", "0", "1e3", "0", "0"], "initial joint speed 1000 rad/s is above 100 rad/s"),
    (["simulate", "--x0", "-1e5", "0", "0", "0", "0", "0"], "initial angle 100000 rad is beyond 10000 rad"),
    (["simulate", "--x0", "0", "0", "0", "-1e-3", "0", "-inf"], "argument --x0: must be finite, got -inf"),
    # simulate: names, paths and contradictions
    (["simulate", "--controller", ""], "unknown controller ''"),
    (["simulate", "--controller", "VCL"], "unknown controller 'VCL'"),
    (["simulate", "--controller", "vcl "], "unknown controller 'vcl '"),
    (["simulate", "--controller", "mine.py"], "unknown controller 'mine.py'"),
    (["simulate", "--controller", ":Damped"], "unknown controller ':Damped'"),
    (["simulate", "--controller", "mine.py:"], "controller file not found"),
    (["simulate", "--controller", "nowhere/mine.py:Damped"], "controller file not found: /"),
    (["simulate", "--robot", ""], "unknown robot '' (an empty name)"),
    (["simulate", "--robot", " "], "unknown robot ' ' (an empty name)"),
    (["simulate", "--robot", "GYMNAST"], "unknown robot 'GYMNAST'"),
    (["simulate", "--robot", "gymnast.xml"], "model file not found: gymnast.xml"),
    (["simulate", "--robot", "/dev/null"], "model file is not a regular file: /dev/null"),
    (["simulate", "--robot", "/etc/hostname.xml"], "model file not found"),
    (["simulate", "--robot", "/"], "model file is not a regular file: /"),
    (["simulate", "--integrator", "rk4"], "invalid choice: 'rk4'"),
    (["simulate", "--engine", "exact"], "invalid choice: 'exact'"),
    (["simulate", "--engine", "analytic", "--dt", "0.001"], "--dt do not apply to --engine analytic"),
    (["simulate", "--controller", "passive", "--no-switch"], "it contradicts --controller passive"),
    (["simulate", "--controller", "lqr", "--kD", "5000"], "apply to the controllers vcl, vcl-only, vc, vc-only"),
    (["simulate", "--out", " "], "--out: an empty path names no folder"),
    # check, theory, make-model
    (["check", "--samples", "0"], "argument --samples: must be >= 1, got 0"),
    (["check", "--samples", "1e3"], "not a whole number: '1e3'"),
    (["check", "--seed", "1.5"], "not a whole number: '1.5'"),
    (["check", "--seed", "0x10"], "not a whole number: '0x10'"),
    (["check", "--seed", "-1e3"], "argument --seed: not a whole number: '-1e3'"),
    (["theory", "--kD", "0"], "argument --kD: must be a positive finite number, got 0"),
    (["theory", "--kP", "-1e3"], "argument --kP: must be a positive finite number, got -1e3"),
    (["theory", "--robot", "example2", "--kD", "nan"], "argument --kD: must be a positive finite number, got nan"),
    (["make-model", "--m", "1", "1", "--l", "1", "1", "1", "--out", "x.xml"], "--m needs 3 values (one per link) for --links 3, got 2"),
    (["make-model", "--m", "1", "1", "1", "--l", "1", "1", "1"], "the following arguments are required: --out"),
    (["make-model", "--m", "1", "1", "1", "--l", "1", "1", "1", "--lc", "0.5", "0.5", "0.5", "--out", "x.xml"],
     "give --J with --lc"),
    (["make-model", "--m", "1", "1", "1", "--l", "1", "1", "1", "--J", "1", "1", "1", "--out", "x.xml"],
     "give --lc with --J"),
    (["make-model", "--m", "1", "1", "1", "--l", "1", "1", "1", "--lc", "2", "0.5", "0.5", "--J", "1", "1", "1",
      "--out", "x.xml"], "lc1 = 2 must lie in [0, l1] = [0, 1]"),
    (["make-model", "--m", "1", "1", "1", "--l", "1", "1", "1", "--lc", "-1e-3", "0.5", "0.5", "--J", "1", "1", "1",
      "--out", "x.xml"], "lc1 = -0.001 must lie in [0, l1]"),
    (["make-model", "--m", "1e7", "1", "1", "--l", "1", "1", "1", "--out", "x.xml"],
     "m1 = 1e+07 lies outside the plausible range"),
    (["make-model", "--m", "1", "1", "1", "--l", "1e-5", "1", "1", "--out", "x.xml"],
     "l1 = 1e-05 lies outside the plausible range"),
    (["make-model", "--m", "1", "1", "1", "--l", "1", "1", "1", "--J", "0", "1", "1", "--lc", "0", "0", "0",
      "--out", "x.xml"], "argument --J: must be a positive finite number, got 0"),
    (["make-model", "--m", "1", "1", "1", "--l", "1", "1", "1", "--kD", "100", "--out", "x.xml"],
     "give all three of --kD --kP --kV"),
    (["make-model", "--m", "1", "1", "1", "--l", "1", "1", "1", "--title", "\x00", "--out", "x.xml"],
     "has control characters"),
    (["make-model", "--m", "1", "1", "1", "--l", "1", "1", "1", "--out", "/proc/x.xml"], "cannot write /proc/x.xml"),
    (["make-model", "--m", "1", "1", "1", "--l", "1", "1", "1", "--out", "sub/"], "names a folder"),
    # render and view
    (["render", "--out", "v.avi"], "--out must end in .mp4 or .gif, got v.avi"),
    (["render", "--out", "video"], "--out must end in .mp4 or .gif, got video"),
    (["render", "--width", "15", "--out", "v.gif"], "--width must be an integer in [16, 4096], got 15"),
    (["render", "--height", "4097", "--out", "v.gif"], "--height must be an integer in [16, 4096], got 4097"),
    (["render", "--width", "0", "--out", "v.gif"], "argument --width: must be >= 1, got 0"),
    (["render", "--fps", "-1e1", "--out", "v.gif"], "argument --fps: must be a positive finite number, got -1e1"),
    (["render", "--from", "nowhere.npz", "--out", "v.gif"], "trajectory file not found: nowhere.npz"),
    (["render", "--from", "/", "--out", "v.gif"], "trajectory file is not a regular file: /"),
    (["render", "--gl", "vulkan", "--out", "v.gif"], "invalid choice: 'vulkan'"),
    (["view", "--t-final", "nan"], "argument --t-final: must be a positive finite number, got nan"),
    (["view", "--x0", "0", "0", "0", "0", "0", "nan"], "argument --x0: must be finite, got nan"),
    (["view", "--integrator", "leapfrog"], "invalid choice: 'leapfrog'"),
    # basin
    (["basin", "--grid", "1"], "--grid must be an integer in [2, 2048], got 1"),
    (["basin", "--grid", "2049"], "--grid must be an integer in [2, 2048], got 2049"),
    (["basin", "--grid", "2.5"], "argument --grid: not a whole number: '2.5'"),
    (["basin", "--axes", "q1"], "--axes needs two different coordinates"),
    (["basin", "--axes", "q1,q1"], "--axes needs two different coordinates"),
    (["basin", "--axes", "q1,q4"], "--axes needs two different coordinates"),
    (["basin", "--axes", "Q1,q2"], "--axes needs two different coordinates"),
    (["basin", "--axes", "q1,q2,q3"], "--axes needs two different coordinates"),
    (["basin", "--chunk", "0"], "argument --chunk: must be >= 1, got 0"),
    (["basin", "--scheduler", "bogus"], "--scheduler must be inline, local or an address"),
    (["basin", "--scheduler", ""], "--scheduler must be inline, local or an address"),
    (["basin", "--scheduler", "tcp://"], "give tcp://HOST:PORT with a port in 1..65535"),
    (["basin", "--scheduler", "tcp://host:0"], "give tcp://HOST:PORT with a port in 1..65535"),
    (["basin", "--scheduler", "tcp://host:99999"], "give tcp://HOST:PORT with a port in 1..65535"),
    (["basin", "--scheduler", "udp://host:1"], "only tcp:// scheduler addresses are supported"),
    (["basin", "--torque-limit", "nan"], "argument --torque-limit: must be a positive finite number, got nan"),
    (["basin", "--controller", "passive", "--kD", "5000", "--scheduler", "inline"],
     "apply to the controllers vcl, vcl-only, vc, vc-only, not to passive"),
    (["basin", "--torque-limit", "-1e3"], "argument --torque-limit: must be a positive finite number"),
    # robustness
    (["robustness", "--factors", "bogus"], "unknown robustness factor(s) ['bogus']"),
    (["robustness", "--factors", ",,,"], "no robustness factor given"),
    (["robustness", "--start", "upside"], "invalid choice: 'upside'"),
    (["robustness", "--factors", "noise", "--model-error", "5"], "levels given for model_error"),
    (["robustness", "--trials", "1e3"], "argument --trials: not a whole number: '1e3'"),
    (["robustness", "--model-error", "inf"], "argument --model-error: must be a finite number >= 0, got inf"),
    (["robustness", "--kip-duration", "2", "--scheduler", "inline"], "--kip-duration applies to the controllers"),
    # compare
    (["compare", "--controllers", ""], "--controllers needs at least one controller"),
    (["compare", "--controllers", ",,"], "--controllers needs at least one controller"),
    (["compare", "--controllers", "bogus", "--scheduler", "inline"], "unknown controller 'bogus'"),
    (["compare", "--trials", "0"], "argument --trials: must be >= 1, got 0"),
    (["compare", "--t-final", "nan"], "argument --t-final: must be a positive finite number, got nan"),
    (["compare", "--torque-limit", "-3"], "argument --torque-limit"),
    (["compare", "--gl", "egl"], "which is only made with --out"),
    (["compare", "--gl", "egl", "--no-video"], "which --no-video skips"),
    # atlas
    (["atlas", "--vary", "l1"], "--vary needs two different parameters"),
    (["atlas", "--vary", "l1,l1"], "--vary needs two different parameters"),
    (["atlas", "--vary", "l4,m1"], "--vary needs two different parameters"),
    (["atlas", "--vary", "J1,m1"], "--vary needs two different parameters"),
    (["atlas", "--range", "4:0.25"], "--range must be LOW:HIGH with 0 < LOW < HIGH, got '4:0.25'"),
    (["atlas", "--range", "0:4"], "--range must be LOW:HIGH with 0 < LOW < HIGH, got '0:4'"),
    (["atlas", "--range", "1:1"], "--range must be LOW:HIGH with 0 < LOW < HIGH"),
    (["atlas", "--range", "nan:4"], "--range must be LOW:HIGH with 0 < LOW < HIGH"),
    (["atlas", "--range", "1:inf"], "--range must be LOW:HIGH with 0 < LOW < HIGH"),
    (["atlas", "--range", "abc"], "--range must be LOW:HIGH, two positive factors, got 'abc'"),
    (["atlas", "--range", "1:2:3"], "--range must be LOW:HIGH, two positive factors"),
    (["atlas", "--grid", "257"], "--grid must be an integer in [2, 256], got 257"),
    (["atlas", "--simulate", "--starts", "-1"], "--starts must be >= 0, got -1"),
    (["atlas", "--simulate", "--starts", "10001", "--scheduler", "inline"], "--starts must be an integer in [0, 10000]"),
    (["atlas", "--torque-limit", "5"], "--torque-limit applies with --simulate only"),
    (["atlas", "--seed", "1"], "--seed applies with --simulate only"),
    (["atlas", "--range", "1e-300:1e300", "--grid", "2", "--scheduler", "inline"], "--range"),
    # bench, reproduce
    (["bench", "--batch-size", "0"], "argument --batch-size: must be >= 1, got 0"),
    (["bench", "--batch-size", "1e99"], "argument --batch-size: not a whole number: '1e99'"),
    (["reproduce", "--out", ""], "argument --out: an empty path names no folder"),
    (["reproduce", "--gl", "osmesa", "--no-video"], "--no-video skips"),
]


def _bad_option_id(case):
    args = case.values[0] if hasattr(case, "values") else case[0]
    return " ".join(a if a.isprintable() else repr(a) for a in args)[:70] or "empty"


@pytest.mark.parametrize("args, fragment", BAD_OPTIONS, ids=[_bad_option_id(c) for c in BAD_OPTIONS])
def test_bad_options_of_every_command_are_one_line(args, fragment, tmp_path, monkeypatch, run):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    proc = run(*args, cwd=tmp_path)
    _one_line_error(proc, fragment)
    assert proc.stdout == ""
    assert not list(tmp_path.iterdir())  # nothing written, not even a lock or a log


def test_compare_refuses_a_reach_grid_before_any_rollout(monkeypatch, tmp_path, run):
    import paa_mj.studies.compare as compare

    def no_work(*args, **kwargs):
        raise AssertionError("a kip was simulated before --grid 1 was refused")

    monkeypatch.setattr(compare, "performance", no_work)
    proc = run("compare", "--controllers", "vcl", "--grid", "1", "--trials", "1", "--t-final", "0.1",
               "--torque-limit", "5", "--scheduler", "inline", "--no-video", cwd=tmp_path)
    _one_line_error(proc, "--grid must be an integer in [2,")


def test_the_viewer_without_a_display_is_one_line_whatever_else_is_wrong(monkeypatch, run):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    proc = run("view", "--controller", "trajopt", "--kP", "1")
    _one_line_error(proc, "no display (DISPLAY and WAYLAND_DISPLAY are unset)")
    assert proc.stdout == ""


@pytest.mark.parametrize("env", [{"DISPLAY": ":99"}, {"DISPLAY": ":0", "MUJOCO_GL": "egl"}],
                         ids=["display that does not answer", "offscreen backend forced"])
def test_the_viewer_that_cannot_open_is_one_line(env, tmp_path):
    inherited = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM")}
    proc = cli("view", "--t-final", "0.05", cwd=tmp_path, env={**inherited, **env}, timeout=120)
    _one_line_error(proc, "cannot open the viewer" if env.get("DISPLAY") == ":99" else "unset it to open the viewer")
    assert list(tmp_path.iterdir()) == []


MISBEHAVING = USER_CONTROLLERS + '''
import time


def _zeros(q):
    return np.zeros(np.shape(q)[:-1] + (2,))


class ExitsInInit:
    def __init__(self, robot):
        sys.exit(0)


class NoRobotArgument:
    def __init__(self):
        pass

    def torque(self, q, qd, t=0.0):
        return _zeros(q)


class NoTorque:
    def __init__(self, robot):
        pass


class TorqueNotCallable(_Zero):
    torque = 5.0


class TorqueWithoutTime(_Zero):
    def torque(self, q, qd):
        return _zeros(q)


class RaisesMultiLine(_Zero):
    def torque(self, q, qd, t=0.0):
        raise KeyError("first line\\nsecond line")


class ReturnsNone(_Zero):
    def torque(self, q, qd, t=0.0):
        return None


class ReturnsScalar(_Zero):
    def torque(self, q, qd, t=0.0):
        return 0.0


class ReturnsFlat(_Zero):
    def torque(self, q, qd, t=0.0):
        return np.zeros(2)


class ReturnsThree(_Zero):
    def torque(self, q, qd, t=0.0):
        return np.zeros(np.shape(q)[:-1] + (3,))


class ReturnsTransposed(_Zero):
    def torque(self, q, qd, t=0.0):
        return _zeros(q).T


class ReturnsText(_Zero):
    def torque(self, q, qd, t=0.0):
        return np.full(np.shape(q)[:-1] + (2,), "1")


class ReturnsGenerator(_Zero):
    def torque(self, q, qd, t=0.0):
        return (x for x in (0.0, 0.0))


class ShapeChangesLater(_Zero):
    def torque(self, q, qd, t=0.0):
        return _zeros(q) if t < 0.02 else np.zeros(2)


class ModeFloat(_Zero):
    mode = 1.0


class ModeNone(_Zero):
    mode = None


class ModeMinusOne(_Zero):
    mode = -1


class ModeOfThree(_Zero):
    mode = np.array([0, 1, 0])


class ModeText(_Zero):
    mode = "1"


class ResetExits(_Zero):
    def reset(self):
        sys.exit(3)


class NotAClass:
    pass


not_callable = 5.0


class Infinite(_Zero):
    def torque(self, q, qd, t=0.0):
        return np.full(np.shape(q)[:-1] + (2,), np.inf)


class MinusInfinite(_Zero):
    def torque(self, q, qd, t=0.0):
        return np.full(np.shape(q)[:-1] + (2,), -np.inf)


class NaNAtOnce(_Zero):
    def torque(self, q, qd, t=0.0):
        return np.full(np.shape(q)[:-1] + (2,), np.nan)


class AsList(_Zero):
    def torque(self, q, qd, t=0.0):
        return (-20.0 * q[..., 1:] - 5.0 * qd[..., 1:]).tolist()


class AsFloat32(_Zero):
    def torque(self, q, qd, t=0.0):
        return (-20.0 * q[..., 1:] - 5.0 * qd[..., 1:]).astype(np.float32)


class AsInt(_Zero):
    def torque(self, q, qd, t=0.0):
        return np.full(np.shape(q)[:-1] + (2,), 3, dtype=np.int64)


class Huge(_Zero):
    def torque(self, q, qd, t=0.0):
        return np.full(np.shape(q)[:-1] + (2,), 1e300)


class Sleepy(_Zero):
    def torque(self, q, qd, t=0.0):
        time.sleep(0.0002)
        return _zeros(q)


class ModeNumpy(_Zero):
    mode = np.int64(0)


class ResetNotCallable(_Zero):
    reset = 5


class Reference:
    """The baseline of the robot-changing controllers below: constant torques."""

    def __init__(self, robot):
        pass

    def torque(self, q, qd, t=0.0):
        return np.full(np.shape(q)[:-1] + (2,), 1e6)


class ZeroesGravity(Reference):
    def __init__(self, robot):
        robot.model.opt.gravity[:] = 0.0


class LiftsTheLimits(Reference):
    def __init__(self, robot):
        robot.torque_limits[:] = np.inf


class ChangesTheTimeStep(Reference):
    def __init__(self, robot):
        robot.model.opt.timestep = 0.01


class ChangesTheMasses(Reference):
    def __init__(self, robot):
        robot.params.m[:] = 100.0
        robot.gains["kD"] = 1.0
'''

MISBEHAVING_REFUSED = [
    ("ExitsInInit", "controller mine.py:ExitsInInit(robot) failed: SystemExit: 0"),
    ("NoRobotArgument", "controller mine.py:NoRobotArgument(robot) failed: TypeError"),
    ("NoTorque", "controller mine.py:NoTorque has no method torque(q, qd, t)"),
    ("TorqueNotCallable", "controller mine.py:TorqueNotCallable has no method torque(q, qd, t)"),
    ("TorqueWithoutTime", "controller mine.py:TorqueWithoutTime.torque failed: TypeError"),
    ("RaisesMultiLine", "controller mine.py:RaisesMultiLine.torque failed: KeyError: 'first line\\nsecond line'"),
    ("ReturnsNone", "ReturnsNone.torque returned object torques"),
    ("ReturnsScalar", "ReturnsScalar.torque returned shape () for states of shape (1, 3)"),
    ("ReturnsFlat", "ReturnsFlat.torque returned shape (2,) for states of shape (1, 3); it must return (1, 2)"),
    ("ReturnsThree", "ReturnsThree.torque returned shape (1, 3)"),
    ("ReturnsTransposed", "ReturnsTransposed.torque returned shape (2, 1)"),
    ("ReturnsText", "ReturnsText.torque returned <U1 torques"),
    ("ReturnsGenerator", "ReturnsGenerator.torque returned object torques"),
    ("ShapeChangesLater", "ShapeChangesLater.torque returned shape (2,)"),
    ("ModeFloat", "ModeFloat.mode must be an integer or one integer per state"),
    ("ModeNone", "ModeNone.mode must be an integer or one integer per state"),
    ("ModeMinusOne", "ModeMinusOne.mode must be 0 (swing-up) or 1 (balance), got -1"),
    ("ModeOfThree", "ModeOfThree.mode must be an integer or one integer per state (shape (1,)), got int64 of shape"),
    ("ModeText", "ModeText.mode must be an integer or one integer per state"),
    ("ResetExits", "controller mine.py:ResetExits.reset failed: SystemExit: 3"),
    ("NotAClass", "controller mine.py:NotAClass(robot) failed: TypeError"),
    ("not_callable", "has no class 'not_callable'"),
    ("Missing", "has no class 'Missing'"),
]


@pytest.mark.parametrize("engine", ["mujoco", "analytic"])
@pytest.mark.parametrize("name, fragment", MISBEHAVING_REFUSED, ids=[c[0] for c in MISBEHAVING_REFUSED])
def test_a_misbehaving_user_controller_is_named_in_one_line(name, fragment, engine, tmp_path, run):
    (tmp_path / "mine.py").write_text(MISBEHAVING)
    proc = run("simulate", "--engine", engine, "--controller", f"{tmp_path}/mine.py:{name}", "--t-final", "0.05",
               "--json", "--out", tmp_path / "run")
    _one_line_error(proc, fragment)
    assert proc.stdout == ""
    assert not (tmp_path / "run").exists() or not list((tmp_path / "run").iterdir())


@pytest.mark.parametrize("source, fragment", [
    ("import sys\nsys.exit(0)\n", "cannot load controller file"),
    ("def broken(:\n", "cannot load controller file"),
    ("raise RuntimeError('at import')\n", "RuntimeError: at import"),
    ("import no_such_module_here\n", "ModuleNotFoundError"),
    ("\x00", "cannot load controller file"),
], ids=["sys.exit at import", "syntax error", "raises at import", "missing import", "NUL byte"])
def test_a_controller_file_that_fails_to_load_is_one_line(source, fragment, tmp_path, run):
    (tmp_path / "mine.py").write_text(source)
    proc = run("simulate", "--controller", f"{tmp_path}/mine.py:Damped", "--t-final", "0.05", "--json")
    _one_line_error(proc, fragment)
    assert proc.stdout == ""


@pytest.mark.parametrize("engine", ["mujoco", "analytic"])
@pytest.mark.parametrize("name", ["Infinite", "MinusInfinite", "NaNAtOnce"])
def test_a_non_finite_torque_is_a_divergence_even_under_a_torque_limit(name, engine, tmp_path, run):
    """Clipping inf to the limit would run a controller that failed as if it had asked for the limit."""
    (tmp_path / "mine.py").write_text(MISBEHAVING)
    proc = run("simulate", "--engine", engine, "--controller", f"{tmp_path}/mine.py:{name}", "--t-final", "0.05",
               "--torque-limit", "5", "--json", "--out", tmp_path / "run")
    _one_line_error(proc, "the controller returned a non-finite torque", code=3)
    summary = _strict(proc.stdout)  # what was computed (the start), printed all the same
    assert summary["status"].startswith("diverged at t = 0.0000 s") and summary["balanced"] is False
    assert summary["success"] is False if "success" in summary else True
    assert (tmp_path / "run" / "trajectory.npz").exists()  # and kept


ACCEPTED_CONTROLLERS = [("AsList", None), ("AsFloat32", None), ("AsInt", None), ("Huge", 5.0), ("Sleepy", None),
                        ("ModeNumpy", None), ("ResetNotCallable", None)]


@pytest.mark.parametrize("engine", ["mujoco", "analytic"])
@pytest.mark.parametrize("name, limit", ACCEPTED_CONTROLLERS, ids=[c[0] for c in ACCEPTED_CONTROLLERS])
def test_a_user_controller_of_another_numeric_type_runs_and_is_limited(name, limit, engine, tmp_path, run):
    (tmp_path / "mine.py").write_text(MISBEHAVING)
    args = ["simulate", "--engine", engine, "--controller", f"{tmp_path}/mine.py:{name}", "--t-final", "0.1",
            "--x0", "-2.5", "0.4", "0.2", "0", "0", "0", "--json"]
    proc = run(*args, *(["--torque-limit", limit] if limit else []))
    assert proc.returncode == 0, proc.stderr
    summary = _strict(proc.stdout)
    assert summary["status"] == "ok" and summary["samples"] == 11
    if limit:
        assert max(summary["max_abs_tau"]) == pytest.approx(limit) and summary["torque_limit"] == [limit, limit]
    assert run(*args, *(["--torque-limit", limit] if limit else [])).stdout == proc.stdout  # the same again


@pytest.mark.parametrize("engine", ["mujoco", "analytic"])
@pytest.mark.parametrize("name", ["ZeroesGravity", "LiftsTheLimits", "ChangesTheTimeStep", "ChangesTheMasses"])
def test_a_controller_that_changes_its_robot_does_not_change_the_robot_simulated(name, engine, made_xml, tmp_path,
                                                                                  run):
    """The robot handed to ``ClassName(robot)`` is the controller's own copy."""
    (tmp_path / "mine.py").write_text(MISBEHAVING)
    robot = tmp_path / "limited.xml"
    robot.write_text(_made(_made(made_xml, M_GEAR, M_GEAR + ' ctrlrange="-3 3"'), 'joint="shoulders" gear="1"',
                           'joint="shoulders" gear="1" ctrlrange="-3 3"'))
    common = ["simulate", "--robot", robot, "--engine", engine, "--t-final", "0.2", "--x0", "-2", "0.5", "0", "0",
              "0", "0", "--json"]
    reference = _strict(run(*common, "--controller", f"{tmp_path}/mine.py:Reference").stdout)
    proc = run(*common, "--controller", f"{tmp_path}/mine.py:{name}")
    assert proc.returncode == 0, proc.stderr
    summary = _strict(proc.stdout)
    assert summary["max_abs_tau"] == reference["max_abs_tau"] == [3.0, 3.0]  # the model's ctrlrange still holds
    assert summary["final_state"] == reference["final_state"] and summary["dt"] == reference["dt"]


def _trajectory_variant(saved, path, **changes):
    """A copy of the trajectory file ``saved`` with arrays replaced (None: removed), written to ``path``."""
    from paa_mj.io import write_npz

    with np.load(saved) as z:
        arrays = {name: z[name] for name in z.files}
    for name, value in changes.items():
        if value is None:
            arrays.pop(name, None)
        else:
            arrays[name] = value
    write_npz(path, **arrays)
    return path


def _sha(text):
    import hashlib

    return np.asarray(hashlib.sha256(text.encode()).hexdigest())


CORRUPT_TRAJECTORIES = [
    ("meta a JSON list", dict(meta=np.asarray("[1, 2]")), "its meta is not a JSON object naming its robot"),
    ("meta null", dict(meta=np.asarray("null")), "its meta is not a JSON object naming its robot"),
    ("robot named by a number", dict(meta=np.asarray('{"robot": 5}')), "its meta is not a JSON object naming"),
    ("meta not JSON", dict(meta=np.asarray("{not json")), "JSONDecodeError"),
    ("meta missing", dict(meta=None), "KeyError: 'meta is not a file in the archive'"),
    ("q missing", dict(q=None), "KeyError: 'q is not a file in the archive'"),
    ("complex angles", dict(q="complex"), "q holds complex128 values, not real numbers"),
    ("text torques", dict(tau="text"), "tau holds <U"),
    ("modes of 7", dict(mode="seven"), "a controller mode is not 0 (swing-up) or 1 (balance)"),
    ("fractional modes", dict(mode="half"), "a controller mode is not 0 (swing-up) or 1 (balance)"),
    ("a NaN time", dict(t="nan"), "empty or non-finite samples"),
    ("angles of two columns", dict(q="two"), "qd has shape (31, 3), expected (31, 2)"),
    ("switch times as an array", dict(switch_time=np.array([1.0, 2.0])), "TypeError"),
    ("switch time as text", dict(switch_time=np.asarray("abc")), "could not convert string to float"),
    ("robot sha256 of another text", dict(robot_sha256=np.asarray("0" * 64)), "does not match its sha256"),
    ("robot MJCF not UTF-8", dict(robot_mjcf=np.frombuffer(b"\xff\xfe", np.uint8)), "UnicodeDecodeError"),
    ("robot MJCF without its sha256", dict(robot_sha256=None), "robot_sha256 is not a file in the archive"),
    ("robot sha256 without its MJCF", dict(robot_mjcf=None), "robot_mjcf is not a file in the archive"),
    ("a consistent robot that is no gymnast", dict(robot_mjcf=np.frombuffer(b"<mujoco/>", np.uint8),
                                                   robot_sha256=_sha("<mujoco/>")), "is not a planar chain on the bar"),
]


@pytest.mark.parametrize("what, changes, fragment", CORRUPT_TRAJECTORIES, ids=[c[0] for c in CORRUPT_TRAJECTORIES])
def test_a_corrupted_trajectory_file_is_one_line_before_any_rendering(what, changes, fragment, saved_trajectory,
                                                                       tmp_path, monkeypatch, run):
    import paa_mj.view.gl as gl

    def no_gl(*args, **kwargs):
        raise AssertionError("the GL backends were probed for a file that is no trajectory")

    monkeypatch.setattr(gl, "select_backend", no_gl)
    with np.load(saved_trajectory) as z:
        n, q, mode = len(z["t"]), z["q"], z["mode"]
        derived = {"complex": q.astype(complex), "text": np.full((n, 2), "1"), "seven": np.full(n, 7, np.int8),
                   "half": mode + 0.5, "nan": np.r_[z["t"][:-1], np.nan], "two": q[:, :2]}
    changes = {k: derived[v] if isinstance(v, str) and v in derived else v for k, v in changes.items()}
    path = _trajectory_variant(saved_trajectory, tmp_path / "t.npz", **changes)
    proc = run("render", "--from", path, "--out", tmp_path / "v.gif")
    _one_line_error(proc, fragment)
    assert not (tmp_path / "v.gif").exists()


@pytest.mark.parametrize("what", ["truncated", "empty", "pickled objects", "a zip of junk", "a folder"])
def test_a_file_that_is_no_trajectory_archive_is_one_line(what, saved_trajectory, tmp_path, run):
    import zipfile

    path = tmp_path / "t.npz"
    if what == "truncated":
        data = saved_trajectory.read_bytes()
        path.write_bytes(data[:len(data) // 2])
    elif what == "empty":
        path.write_bytes(b"")
    elif what == "pickled objects":
        np.savez(path, t=np.array([object()], dtype=object))
    elif what == "a zip of junk":
        with zipfile.ZipFile(path, "w") as archive:
            archive.writestr("t.npy", b"junk")
    else:
        path.mkdir()
    fragment = {"truncated": "not an .npz archive", "empty": "not an .npz archive",
                "pickled objects": "Object arrays cannot be loaded", "a zip of junk": "corrupted or foreign",
                "a folder": "trajectory file is not a regular file"}[what]
    _one_line_error(run("render", "--from", path, "--out", tmp_path / "v.gif"), fragment)


def test_a_trajectory_of_example2_is_not_drawn_as_the_gymnast(tmp_path, run):
    assert run("simulate", "--robot", "example2", "--t-final", "0.1", "--out", tmp_path / "ex2").returncode == 0
    _one_line_error(run("render", "--from", tmp_path / "ex2" / "trajectory.npz", "--robot", "gymnast", "--out",
                        tmp_path / "v.gif"), "is a trajectory of robot 'example2', not of --robot gymnast")


def test_outputs_below_a_regular_file_are_one_line(tmp_path, run):
    blocker = tmp_path / "afile"
    blocker.write_text("x")
    cases = [
        (["simulate", "--t-final", "0.05", "--out", blocker / "sub"], "cannot create output folder"),
        (["simulate", "--t-final", "0.05", "--out", blocker], "cannot create output folder"),
        (["basin", "--grid", "2", "--t-final", "0.05", "--scheduler", "inline", "--out", blocker],
         "cannot create output folder"),
        (["make-model", "--m", "1", "1", "1", "--l", "1", "1", "1", "--out", blocker / "x.xml"],
         "cannot create output folder"),
        (["render", "--t-final", "0.05", "--out", blocker / "x.gif"], "cannot create output folder"),
    ]
    for args, fragment in cases:
        _one_line_error(run(*args), fragment)
    assert blocker.read_text() == "x" and sorted(p.name for p in tmp_path.iterdir()) == ["afile"]


@pytest.mark.parametrize("kind", ["summary.json", "trajectory.csv", "dangling"])
def test_a_symbolic_link_among_the_result_files_is_refused_and_its_target_untouched(kind, tmp_path, run):
    out = tmp_path / "run"
    assert run("simulate", "--t-final", "0.05", "--out", out).returncode == 0
    victim = tmp_path / "victim.txt"
    if kind != "dangling":
        victim.write_text("victim")
    (out / ("summary.json" if kind == "dangling" else kind)).unlink()
    (out / ("summary.json" if kind == "dangling" else kind)).symlink_to(victim)
    _one_line_error(run("simulate", "--t-final", "0.05", "--out", out), "is a symbolic link")
    assert (victim.read_text() == "victim") if kind != "dangling" else not victim.exists()


def test_a_folder_reached_through_a_symbolic_link_is_written_and_keeps_other_files(tmp_path, run):
    real = tmp_path / "real"
    real.mkdir()
    (real / "notes.txt").write_text("mine")
    (tmp_path / "link").symlink_to(real)
    assert run("simulate", "--t-final", "0.05", "--out", tmp_path / "link").returncode == 0
    assert sorted(p.name for p in real.iterdir()) == ["notes.txt", "summary.json", "trajectory.csv",
                                                      "trajectory.npz"]
    assert (real / "notes.txt").read_text() == "mine"


@pytest.mark.parametrize("command", [
    ["basin", "--grid", "2", "--t-final", "0.05", "--scheduler", "inline"],
    ["robustness", "--trials", "1", "--t-final", "0.05", "--factors", "noise", "--scheduler", "inline"],
    ["atlas", "--grid", "2", "--scheduler", "inline"],
    ["simulate", "--t-final", "0.05"],
], ids=["basin", "robustness", "atlas", "simulate"])
def test_a_study_does_not_overwrite_a_summary_it_did_not_write(command, tmp_path, run):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "summary.json").write_text('{"my": "notes"}')
    run(*command, "--out", out)
    assert (out / "summary.json").read_text() == '{"my": "notes"}'


@pytest.mark.parametrize("name", ["ró bot é.xml", "UPPER.XML", "no_suffix", "link.xml"])
def test_a_model_file_under_an_odd_name_loads(name, tmp_path, run):
    path = tmp_path / name
    if name == "link.xml":
        path.symlink_to(MODEL_DIR / "gymnast.xml")
    else:
        path.write_text(GYMNAST)
    proc = run("simulate", "--robot", path, "--t-final", "0.05", "--json")
    assert proc.returncode == 0, proc.stderr
    assert _strict(proc.stdout)["final_state"] == _strict(run("simulate", "--t-final", "0.05", "--json").stdout)[
        "final_state"]


MODEL_FILES = [
    ("latin-1 text", lambda folder: GYMNAST.replace("Three-link", "Three-link \xe9").encode("latin-1"),
     "cannot read model file"),
    ("an include of a missing file", lambda folder: GYMNAST.replace("</mujoco>", '<include file="missing.xml"/>'
                                                                    "</mujoco>"), "included file not found"),
    ("an include of a folder", lambda folder: GYMNAST.replace("</mujoco>", '<include file="."/></mujoco>'),
     "included file is not a regular file"),
    ("an include of itself", lambda folder: GYMNAST.replace("</mujoco>", '<include file="robot.xml"/></mujoco>'),
     "includes nested more than 16 deep"),
    ("an include without a file", lambda folder: GYMNAST.replace("</mujoco>", '<include file=""/></mujoco>'),
     "<include> without a file attribute"),
    ("empty", lambda folder: "", "malformed MJCF"),
    ("not XML", lambda folder: "hello", "malformed MJCF"),
    ("another MuJoCo model", lambda folder: '<mujoco><worldbody><body><joint/><geom size="1"/></body></worldbody>'
                                            "</mujoco>", "is not a planar chain on the bar (the gymnast's family): needs a chain of 2 to 64 bodies"),
    ("a URDF", lambda folder: '<robot name="urdf"/>', "is not a planar chain on the bar"),
]


@pytest.mark.parametrize("what, content, fragment", MODEL_FILES, ids=[m[0] for m in MODEL_FILES])
def test_a_model_file_that_is_not_a_gymnast_is_one_line(what, content, fragment, tmp_path, run):
    path = tmp_path / "robot.xml"
    data = content(tmp_path)
    path.write_bytes(data) if isinstance(data, bytes) else path.write_text(data)
    _one_line_error(run("theory", "--robot", path, "--json", cwd=tmp_path), fragment)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["robot.xml"]


@pytest.mark.parametrize("variable, value, ok", [
    ("NUMBA_NUM_THREADS", "1.5", False), ("NUMBA_NUM_THREADS", "", False), ("NUMBA_NUM_THREADS", "-2", False),
    ("MUJOCO_GL", "EGL", True),
], ids=["threads 1.5", "threads empty", "threads -2", "MUJOCO_GL upper case"])
def test_environment_variables_are_read_as_the_libraries_read_them(variable, value, ok, tmp_path, run,
                                                                   monkeypatch):
    if variable == "MUJOCO_GL":  # MuJoCo reads it once, on import: a fresh process
        proc = cli("simulate", "--t-final", "0.05", "--json", cwd=tmp_path, env={**os.environ, variable: value},
                   timeout=120)
    else:  # read by the command before numba loads (test_an_environment_that_breaks_... runs that in a process)
        monkeypatch.setenv(variable, value)
        proc = run("simulate", "--t-final", "0.05", "--json", cwd=tmp_path)
    if ok:
        assert proc.returncode == 0, proc.stderr
        assert _strict(proc.stdout)["final_time"] == 0.05
    else:
        _one_line_error(proc, f"the environment variable {variable}={value!r} must be a whole number >= 1")
    assert list(tmp_path.iterdir()) == []


def test_a_cache_that_is_a_file_costs_a_solve_and_nothing_else(tmp_path, monkeypatch, gymnast):
    from paa_mj.control.trajopt import solve_kip

    blocker = tmp_path / "cache"
    blocker.write_text("not a folder")
    monkeypatch.setenv("PAA_MJ_CACHE", str(blocker))
    from paa_mj.model.states import Q_UDD

    udd = np.concatenate([Q_UDD, np.zeros(3)])
    start = udd + [0.05, -0.05, 0.02, 0.0, 0.1, 0.0]
    kip = solve_kip(gymnast.analytic, [300.0, 150.0], "min-effort", duration=1.0, intervals=20, x0=start)
    again = solve_kip(gymnast.analytic, [300.0, 150.0], "min-effort", duration=1.0, intervals=20, x0=start)
    np.testing.assert_array_equal(kip.u, again.u)  # solved twice, the same
    assert blocker.read_text() == "not a folder" and sorted(p.name for p in tmp_path.iterdir()) == ["cache"]


def _one_json_object(proc):
    """stdout is exactly one strict JSON object on one line."""
    assert proc.stdout.endswith("\n") and proc.stdout.count("\n") == 1, proc.stdout[:300]
    value = _strict(proc.stdout)
    assert isinstance(value, dict)
    return value


CHATTY = USER_CONTROLLERS + '''

class Chatty(_Zero):
    def __init__(self, robot=None):
        print("built", robot.name)

    def torque(self, q, qd, t=0.0):
        print("torque at", t, "for", len(q), "states")
        sys.stdout.flush()
        return -10.0 * (q[..., 1:] - 0.3)
'''

JSON_COMMANDS = [
    ["theory", "--json"],
    ["theory", "--robot", "example2", "--kP", "1", "--json"],
    ["theory", "--robot", "example2", "--kD", "40", "--json"],
    ["check", "--samples", "3", "--json"],
    ["simulate", "--t-final", "0.05", "--json"],
    ["simulate", "--engine", "analytic", "--t-final", "0.05", "--json"],
    ["simulate", "--controller", "{chatty}", "--t-final", "0.05", "--json", "--out", "{d}/run"],
    ["simulate", "--controller", "{chatty}", "--engine", "analytic", "--t-final", "0.05", "--json"],
    ["basin", "--grid", "2", "--t-final", "0.05", "--scheduler", "inline", "--json"],
    ["basin", "--grid", "2", "--t-final", "0.05", "--scheduler", "inline", "--json", "--controller", "{chatty}"],
    ["robustness", "--trials", "1", "--t-final", "0.05", "--scheduler", "inline", "--factors", "noise", "--json"],
    ["robustness", "--trials", "1", "--t-final", "0.05", "--scheduler", "inline", "--factors", "delay", "--json",
     "--controller", "{chatty}"],
    ["atlas", "--grid", "2", "--scheduler", "inline", "--json"],
    ["atlas", "--grid", "2", "--scheduler", "inline", "--json", "--simulate", "--starts", "0", "--t-final", "0.05"],
    ["compare", "--controllers", "vcl,{chatty}", "--trials", "1", "--grid", "2", "--t-final", "0.1",
     "--torque-limit", "50", "--scheduler", "inline", "--no-video", "--json"],
]


@pytest.mark.parametrize("args", JSON_COMMANDS, ids=[" ".join(a[:3]) + f"-{i}" for i, a in enumerate(JSON_COMMANDS)])
def test_json_output_of_every_command_is_one_strict_object(args, tmp_path, run):
    (tmp_path / "chatty.py").write_text(CHATTY)
    proc = run(*[a.format(chatty=f"{tmp_path}/chatty.py:Chatty", d=tmp_path) for a in args])
    assert proc.returncode == 0, proc.stderr
    _one_json_object(proc)
    assert "Traceback" not in proc.stderr
    if any("chatty" in a for a in args):
        assert "torque at" in proc.stderr  # the controller's prints went to stderr


def _peaks(value, path=""):
    """Every peak torque reported anywhere in a JSON value: (path, [tau2, tau3])."""
    if isinstance(value, dict):
        for key, item in value.items():
            if key in ("max_abs_tau", "max_tau") and isinstance(item, list):
                yield f"{path}/{key}", item
            else:
                yield from _peaks(item, f"{path}/{key}")
    elif isinstance(value, list):
        for i, item in enumerate(value):
            yield from _peaks(item, f"{path}[{i}]")


LIMITED_RUNS = [
    ["simulate", "--t-final", "0.5"],
    ["simulate", "--controller", "vc", "--t-final", "0.5"],
    ["simulate", "--controller", "vcl-only", "--t-final", "0.5", "--dt", "0.002", "--integrator", "Euler"],
    ["simulate", "--controller", "lqr", "--t-final", "0.5", "--x0", "0.2", "-2.9", "0.1", "0", "0", "0"],
    ["simulate", "--engine", "analytic", "--t-final", "0.3"],
    ["simulate", "--engine", "analytic", "--controller", "vc-only", "--t-final", "0.3"],
    ["simulate", "--engine", "analytic", "--controller", "lqr", "--t-final", "0.3", "--x0", "0.2", "-2.9", "0.1",
     "0", "0", "0"],
    ["basin", "--grid", "2", "--t-final", "0.3", "--scheduler", "inline"],
    ["basin", "--grid", "2", "--t-final", "0.3", "--scheduler", "inline", "--controller", "lqr", "--axes", "d1,d2"],
    ["robustness", "--trials", "2", "--t-final", "0.3", "--scheduler", "inline", "--factors",
     "noise,torque_limit,model_error,delay,torque_noise,pushes,initial_state"],
    ["atlas", "--grid", "2", "--scheduler", "inline", "--simulate", "--starts", "1", "--t-final", "0.3"],
    ["compare", "--controllers", "vcl,lqr", "--trials", "1", "--grid", "2", "--t-final", "0.3", "--scheduler",
     "inline", "--no-video"],
]


@pytest.mark.parametrize("args", LIMITED_RUNS, ids=[" ".join(a[:4]) + f"-{i}" for i, a in enumerate(LIMITED_RUNS)])
def test_no_reported_torque_exceeds_the_torque_limit_given(args, run):
    limit = 7.0
    proc = run(*args, "--torque-limit", limit, "--json")
    assert proc.returncode == 0, proc.stderr
    summary = _one_json_object(proc)
    peaks = list(_peaks(summary))
    assert peaks, "no peak torque reported"
    for where, peak in peaks:
        assert all(p is not None and p <= limit + 1e-9 for p in peak), (where, peak)
    assert any(max(peak) == pytest.approx(limit) for _, peak in peaks)  # saturated somewhere: the limit is applied


def test_a_studys_counts_add_up(run):
    basin = _strict(run("basin", "--grid", "3", "--t-final", "0.2", "--scheduler", "inline", "--json").stdout)
    assert basin["cells"] == 9 and sum(basin["outcomes"].values()) == 9 and basin["completed_fraction"] == 1.0
    assert basin["success"] <= 1.0 - basin["diverged_fraction"]
    rob = _strict(run("robustness", "--trials", "3", "--t-final", "0.1", "--scheduler", "inline", "--factors",
                      "noise,delay,torque_limit", "--start", "hanging", "--json").stdout)
    levels = [level for factor in rob["factors"].values() for level in factor["levels"]]
    assert sum(level["trials"] for level in levels) == rob["runs"]  # no more trials claimed than were run
    assert all(level["trials"] <= rob["trials"] and (level["trials"] == 1 or level["random"]) for level in levels)
    atlas = _strict(run("atlas", "--grid", "3", "--scheduler", "inline", "--simulate", "--starts", "1", "--t-final",
                        "0.1", "--json").stdout)
    assert atlas["counts"]["robots"] == 9 == len(atlas["robots"])
    outcomes = ("balanced", "switched, not balanced", "never switched, stuck at DUU", "never switched", "diverged")
    assert sum(atlas["counts"][name] for name in outcomes) == 9


@pytest.mark.parametrize("args", [
    ["theory", "--robot", "example2", "--json"],
    ["check", "--samples", "7", "--seed", "5", "--json"],
    ["simulate", "--controller", "{damped}", "--t-final", "0.3", "--json"],
    ["simulate", "--controller", "{damped}", "--engine", "analytic", "--t-final", "0.1", "--json"],
    ["basin", "--grid", "2", "--t-final", "0.2", "--scheduler", "inline", "--json", "--controller", "{damped}"],
    ["robustness", "--trials", "2", "--t-final", "0.2", "--scheduler", "inline", "--factors",
     "noise,torque_noise,pushes", "--seed", "3", "--json"],
    ["atlas", "--grid", "2", "--scheduler", "inline", "--json", "--simulate", "--starts", "1", "--t-final", "0.2"],
], ids=["theory", "check", "simulate python controller", "analytic python controller", "basin python controller",
        "robustness noise", "atlas simulate"])
def test_the_same_command_twice_gives_the_same_numbers(args, tmp_path, run):
    (tmp_path / "mine.py").write_text(PRINTING_AND_FAILING)
    args = [a.format(damped=f"{tmp_path}/mine.py:Damped") for a in args]
    first, second = run(*args), run(*args)
    assert first.returncode == second.returncode == 0, first.stderr
    assert first.stdout == second.stdout


def test_simulate_options_are_honoured_not_ignored(run):
    base = _strict(run("simulate", "--t-final", "0.2", "--json").stdout)
    cases = {
        ("--dt", "0.002"): lambda s: s["dt"] == 0.002,
        ("--integrator", "Euler"): lambda s: s["integrator"] == "Euler",
        ("--integrator", "implicit"): lambda s: s["integrator"] == "implicit",
        ("--sample-dt", "0.05"): lambda s: s["samples"] == 5 and s["sample_dt"] == 0.05,
        ("--kD", "5000"): lambda s: s["gains"] == {"kD": 5000.0, "kP": 16000.0, "kV": 5000.0},
        ("--kP", "17000", "--kV", "4000"): lambda s: s["gains"] == {"kD": 4550.0, "kP": 17000.0, "kV": 4000.0},
        ("--no-switch",): lambda s: s["controller"] == "vcl-only" and s["switch_time"] is None,
        ("--x0", "-3", "0.1", "0", "0", "0", "0"): lambda s: s["x0"] == [-3.0, 0.1, 0.0, 0.0, 0.0, 0.0],
        ("--torque-limit", "20"): lambda s: s["torque_limit"] == [20.0, 20.0],
    }
    for option, holds in cases.items():
        summary = _strict(run("simulate", "--t-final", "0.2", "--json", *option).stdout)
        assert holds(summary), (option, summary)
        if option[0] not in ("--sample-dt", "--no-switch"):  # vcl-only swings up exactly as vcl before any switch
            assert summary["final_state"] != base["final_state"], option  # and the run is not the default's


def test_analytic_and_study_options_are_honoured(run):
    analytic = _strict(run("simulate", "--engine", "analytic", "--t-final", "0.2", "--sample-dt", "0.04",
                           "--json").stdout)
    assert analytic["samples"] == 6 and analytic["sample_dt"] == 0.04
    theory = _strict(run("theory", "--kD", "4600", "--kP", "16500", "--kV", "5100", "--json").stdout)
    assert theory["gains"] == {"kD": 4600.0, "kP": 16500.0, "kV": 5100.0}
    check = [_strict(run("check", "--samples", "4", "--seed", str(s), "--json").stdout) for s in (1, 2)]
    assert [c["seed"] for c in check] == [1, 2] and all(c["samples"] == 4 for c in check)
    basin = _strict(run("basin", "--grid", "2", "--t-final", "0.05", "--scheduler", "inline", "--axes", "d1,d3",
                        "--json").stdout)
    assert basin["axes"] == ["d1", "d3"]
    rob = _strict(run("robustness", "--trials", "1", "--t-final", "0.05", "--scheduler", "inline", "--factors",
                      "delay", "--start", "hanging", "--seed", "4", "--json").stdout)
    assert rob["start"] == "hanging" and rob["seed"] == 4 and list(rob["factors"]) == ["delay"]
    atlas = _strict(run("atlas", "--grid", "2", "--scheduler", "inline", "--vary", "m2,l3", "--range", "0.5:2",
                        "--json").stdout)
    assert atlas["vary"] == ["m2", "l3"] and atlas["factors"][0] == [0.5, 2.0]


def test_a_robustness_seed_changes_the_draws(gymnast):
    from paa_mj.studies.robustness import robustness

    draws = [robustness(gymnast, trials=3, t_final=0.05, seed=seed, factors=["noise"])[1]["x0"] for seed in (0, 1)]
    assert draws[0].shape == draws[1].shape == (12, 6) and not np.array_equal(draws[0], draws[1])


def test_the_files_of_simulate_agree_with_its_json(tmp_path, run):
    from paa_mj.sim.trajectory import Trajectory

    proc = run("simulate", "--t-final", "0.3", "--json", "--out", tmp_path / "run")
    summary = _one_json_object(proc)
    assert json.loads((tmp_path / "run" / "summary.json").read_text()) == summary
    rows = (tmp_path / "run" / "trajectory.csv").read_text().strip().splitlines()
    traj = Trajectory.load(tmp_path / "run" / "trajectory.npz")
    assert len(rows) - 1 == summary["samples"] == len(traj) == 31
    assert traj.summary()["max_abs_tau"] == summary["max_abs_tau"]
    assert np.concatenate([traj.q[-1], traj.qd[-1]]).tolist() == summary["final_state"]


@pytest.mark.parametrize("engine", ["mujoco", "analytic"])
def test_a_diverged_run_reports_no_success_and_keeps_its_samples(engine, tmp_path, run):
    (tmp_path / "mine.py").write_text(PRINTING_AND_FAILING)
    proc = run("simulate", "--engine", engine, "--controller", f"{tmp_path}/mine.py:LateNaN", "--t-final", "1",
               "--x0", "0", "-3.14", "0", "0", "0", "0", "--json", "--out", tmp_path / "run")
    _one_line_error(proc, "non-finite torque", code=3)
    summary = _one_json_object(proc)
    assert summary["balanced"] is False and summary.get("success", False) is False
    assert summary["status"].startswith("diverged")
    kept = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert kept == summary and kept["samples"] >= 5


def test_the_peak_torque_of_a_run_does_not_depend_on_the_recording_interval(run):
    fine = _strict(run("simulate", "--t-final", "2", "--sample-dt", "0.001", "--json").stdout)
    coarse = _strict(run("simulate", "--t-final", "2", "--sample-dt", "0.1", "--json").stdout)
    assert coarse["max_abs_tau"] == pytest.approx(fine["max_abs_tau"], rel=1e-9)  # 456.4 against 512.5 N m


@pytest.mark.parametrize("command", [
    ["simulate", "--t-final", "0.2"],
    ["basin", "--grid", "2", "--t-final", "0.2", "--scheduler", "inline"],
    ["robustness", "--trials", "1", "--t-final", "0.2", "--scheduler", "inline", "--factors", "noise"],
], ids=["simulate", "basin", "robustness"])
def test_the_torque_limit_reported_is_the_one_applied(command, made_xml, tmp_path, run):
    robot = tmp_path / "limited.xml"
    robot.write_text(_made(_made(made_xml, M_GEAR, M_GEAR + ' ctrlrange="-0.3 0.3"'), 'joint="shoulders" gear="1"',
                           'joint="shoulders" gear="1" ctrlrange="-0.3 0.3"'))
    summary = _strict(run(*command, "--robot", robot, "--torque-limit", "7", "--json").stdout)
    assert summary["torque_limit"] == [0.3, 0.3] and max(summary["max_abs_tau"]) <= 0.3


def _api_cases(gymnast):
    """The Python calls of the table below, by name: each must raise PaaError with one line naming the problem."""
    from paa_mj.control import make_controller
    from paa_mj.control.registry import ControllerSpec
    from paa_mj.control.trajopt import solve_kip
    from paa_mj.model import load_robot
    from paa_mj.sim import simulate_mujoco
    from paa_mj.sim.analytic import simulate_analytic

    am, x0 = gymnast.analytic, np.array([-np.pi, 0, 0, 0, 0, 0])

    def analytic(**options):
        return lambda: simulate_analytic(gymnast, "passive", x0, 0.05, **options)

    def kip(**options):
        return lambda: solve_kip(am, options.pop("bound", [300.0, 150.0]), options.pop("objective", "min-effort"),
                                 **{"duration": 1.0, "intervals": 8, "use_cache": False, **options})

    return {
        "load_robot('')": lambda: load_robot(""),
        "load_robot(None)": lambda: load_robot(None),
        "load_robot(5)": lambda: load_robot(5),
        "make_controller unknown gain name": lambda: make_controller("vcl", gymnast, gains={"kX": 1.0}),
        "make_controller gain as text": lambda: make_controller("vcl", gymnast, gains={"kD": "5000"}),
        "make_controller gain True": lambda: make_controller("vcl", gymnast, gains={"kD": True}),
        "make_controller gains a list": lambda: make_controller("vcl", gymnast, gains=[5000.0]),
        "make_controller name 5": lambda: make_controller(5, gymnast),
        "make_controller name None": lambda: make_controller(None, gymnast),
        "make_controller robot None": lambda: make_controller("vcl", None),
        "make_controller robot a name": lambda: make_controller("vcl", "gymnast", gains={"kD": 5000.0}),
        "make_controller limit as text": lambda: make_controller("trajopt", gymnast, limit="abc"),
        "make_controller limit of 3 values": lambda: make_controller("trajopt", gymnast, limit=(1.0, 2.0, 3.0)),
        "make_controller limit negative": lambda: make_controller("trajopt", gymnast, limit=-1.0),
        "make_controller unknown option": lambda: make_controller("trajopt", gymnast, bogus=1),
        "ControllerSpec 4 gains": lambda: ControllerSpec("vcl", gains=(5000.0, 16000.0, 5000.0, 1.0)),
        "ControllerSpec 2 gains": lambda: ControllerSpec("vcl", gains=(5000.0, 16000.0)),
        "ControllerSpec gains as text": lambda: ControllerSpec("vcl", gains=("a", "b", "c")),
        "ControllerSpec one gain": lambda: ControllerSpec("vcl", gains=5000.0),
        "ControllerSpec options not pairs": lambda: ControllerSpec("trajopt", options=("limit",)),
        "ControllerSpec believed a name": lambda: ControllerSpec("vcl", believed="gymnast"),
        "ControllerSpec check as text": lambda: ControllerSpec("vcl", check="no"),
        "ControllerSpec name None": lambda: ControllerSpec(None),
        "ControllerSpec built for no robot": lambda: ControllerSpec("vcl").build(None),
        "simulate_mujoco of a robot name": lambda: simulate_mujoco("gymnast", "passive", x0, 0.05),
        "analytic rtol NaN (hung)": analytic(rtol=float("nan")),
        "analytic atol NaN (hung)": analytic(atol=float("nan")),
        "analytic rtol inf (hung)": analytic(rtol=float("inf")),
        "analytic rtol negative": analytic(rtol=-1.0),
        "analytic event resolution 0": analytic(event_resolution=0.0),
        "analytic event resolution NaN": analytic(event_resolution=float("nan")),
        "analytic event resolution negative": analytic(event_resolution=-1.0),
        "analytic event resolution 1e-300": analytic(event_resolution=1e-300),
        "analytic torque limit of 3 values": analytic(torque_limit=[1.0, 2.0, 3.0]),
        "analytic torque limit as text": analytic(torque_limit="abc"),
        "analytic method unknown": analytic(method="Euler"),
        "solve_kip bounds of 3 values": kip(bound=[1.0, 2.0, 3.0]),
        "solve_kip bounds as text": kip(bound="abc"),
        "solve_kip x0 of 5 values": kip(x0=np.zeros(5)),
        "solve_kip x0 NaN": kip(x0=[np.nan] * 6),
        "solve_kip x0 as text": kip(x0="abc"),
        "solve_kip xN of 7 values": kip(xN=np.zeros(7)),
        "solve_kip max_iter negative": kip(max_iter=-5),
        "solve_kip max_iter 1.5": kip(max_iter=1.5),
        "solve_kip duration as text": kip(duration="1"),
        "solve_kip of a Robot": lambda: solve_kip(gymnast, [300.0, 150.0]),
        "solve_kip objective None": kip(objective=None),
    }


API_FRAGMENTS = {
    "load_robot('')": "unknown robot '' (an empty name)", "load_robot(None)": "unknown robot None",
    "load_robot(5)": "unknown robot 5",
    "make_controller unknown gain name": "gains must be a dict with some of kD, kP, kV",
    "make_controller gain as text": "gain kD must be a number, got '5000'",
    "make_controller gain True": "gain kD must be a number, got True",
    "make_controller gains a list": "gains must be a dict with some of kD, kP, kV",
    "make_controller name 5": "a controller is named by a string",
    "make_controller name None": "a controller is named by a string",
    "make_controller robot None": "controllers are built for a robot of load_robot(), got NoneType",
    "make_controller robot a name": "controllers are built for a robot of load_robot(), got str",
    "make_controller limit as text": "the option limit must be a torque limit",
    "make_controller limit of 3 values": "the option limit needs one number or one per motor (2)",
    "make_controller limit negative": "torque bounds of the kip must be finite and > 0",
    "make_controller unknown option": "option(s) bogus do not apply to the controller trajopt",
    "ControllerSpec 4 gains": "gains must be three numbers (kD, kP, kV)",
    "ControllerSpec 2 gains": "gains must be three numbers (kD, kP, kV)",
    "ControllerSpec gains as text": "gains must be three numbers (kD, kP, kV)",
    "ControllerSpec one gain": "gains must be three numbers (kD, kP, kV)",
    "ControllerSpec options not pairs": "options must be (name, value) pairs",
    "ControllerSpec believed a name": "believed must be the RobotParams",
    "ControllerSpec check as text": "check must be True or False, got 'no'",
    "ControllerSpec name None": "a controller is named by a string",
    "ControllerSpec built for no robot": "controllers are built for a robot of load_robot()",
    "simulate_mujoco of a robot name": "controllers are built for a robot of load_robot(), got str",
    "analytic rtol NaN (hung)": "rtol must be a positive finite number, got nan",
    "analytic atol NaN (hung)": "atol must be a positive finite number, got nan",
    "analytic rtol inf (hung)": "rtol must be a positive finite number, got inf",
    "analytic rtol negative": "rtol must be a positive finite number, got -1",
    "analytic event resolution 0": "event_resolution must be a positive finite number, got 0",
    "analytic event resolution NaN": "event_resolution must be a positive finite number, got nan",
    "analytic event resolution negative": "event_resolution must be a positive finite number",
    "analytic event resolution 1e-300": "event_resolution 1e-300 s is below 1e-09 s",
    "analytic torque limit of 3 values": "torque limit must be one number or one per motor (2)",
    "analytic torque limit as text": "torque limit must be one number or one per motor (2)",
    "analytic method unknown": "unknown method 'Euler'",
    "solve_kip bounds of 3 values": "torque bounds of the kip are one number or two (T2, T3)",
    "solve_kip bounds as text": "torque bounds of the kip must be real numbers",
    "solve_kip x0 of 5 values": "the kip's x0 must be 6 finite numbers",
    "solve_kip x0 NaN": "the kip's x0 must be 6 finite numbers",
    "solve_kip x0 as text": "the kip's initial state x0 must be real numbers",
    "solve_kip xN of 7 values": "the kip's xN must be 6 finite numbers",
    "solve_kip max_iter negative": "max_iter must be a whole number >= 0",
    "solve_kip max_iter 1.5": "max_iter must be a whole number >= 0",
    "solve_kip duration as text": "the kip duration must be real numbers",
    "solve_kip of a Robot": "solve_kip needs the robot's AnalyticModel (robot.analytic), got Robot",
    "solve_kip objective None": "unknown objective None",
}


@pytest.mark.parametrize("name", list(API_FRAGMENTS))
def test_the_python_api_refuses_bad_arguments_with_one_paa_error(name, gymnast):
    from paa_mj.errors import PaaError

    def hung(signum, frame):
        raise TimeoutError(f"{name}: still running after 20 s")

    call = _api_cases(gymnast)[name]
    previous = signal.signal(signal.SIGALRM, hung)  # a NaN tolerance used to keep SciPy stepping for ever
    signal.alarm(20)
    try:
        with pytest.raises(PaaError) as caught:
            call()
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    message = str(caught.value)
    assert API_FRAGMENTS[name] in message and "\n" not in message, message


def _api_refusal_cases(gymnast):
    from paa_mj.sim import Disturbances, simulate_batch, simulate_mujoco
    from paa_mj.studies.atlas import atlas
    from paa_mj.studies.basin import basin
    from paa_mj.studies.robustness import robustness

    x = np.tile([-np.pi, 0, 0, 0, 0, 0], (3, 1))
    return {
        "simulate_batch rollout_ids shorter than the batch": lambda: simulate_batch(
            gymnast, x, 0.05, disturbances=Disturbances(noise_std=0.01, rollout_ids=[7])),
        "simulate_batch plants that are names": lambda: simulate_batch(gymnast, x[:2], 0.05, plants=["a", "b"]),
        "simulate_mujoco x0 as text": lambda: simulate_mujoco(gymnast, "passive", "abc", 0.05),
        "simulate_mujoco seed 2**70": lambda: simulate_mujoco(
            gymnast, "passive", x[0], 0.05, disturbances=Disturbances(noise_std=0.01, seed=2**70)),
        "basin over one axis twice": lambda: basin(gymnast, (0, 0), 2, 0.05),
        "basin chunk 0": lambda: basin(gymnast, (0, 1), 2, 0.05, chunk=0),
        "basin scheduler unknown": lambda: basin(gymnast, (0, 1), 2, 0.05, scheduler="bogus"),
        "robustness seed -1": lambda: robustness(gymnast, trials=1, t_final=0.05, factors=["noise"], seed=-1),
        "atlas of unknown parameters": lambda: atlas(gymnast, vary=("x", "y"), grid=2),
        "atlas range from 0": lambda: atlas(gymnast, factor_range=(0.0, 2.0), grid=2),
    }


#: Python calls that once failed with another exception than PaaError, or not at all.
API_REFUSALS = (
    "simulate_batch rollout_ids shorter than the batch",
    "simulate_batch plants that are names",
    "simulate_mujoco x0 as text",
    "simulate_mujoco seed 2**70",
    "basin over one axis twice",
    "basin chunk 0",
    "basin scheduler unknown",
    "robustness seed -1",
    "atlas of unknown parameters",
    "atlas range from 0",
)


@pytest.mark.parametrize("name", list(API_REFUSALS), ids=list(API_REFUSALS))
def test_the_simulation_and_study_functions_refuse_bad_arguments_with_one_paa_error(name, gymnast):
    from paa_mj.errors import PaaError

    with pytest.raises(PaaError):
        _api_refusal_cases(gymnast)[name]()


BAD_GYM_CALLS = [
    ("max_episode_seconds 1e308", dict(max_episode_seconds=1e308), None, "is too long"),
    ("torque_limit 1e308", dict(torque_limit=1e308), None, "torque_limit must be a positive finite number"),
    ("torque_limit True", dict(torque_limit=True), None, "torque_limit must be a number, got True"),
    ("torque_limit a list", dict(torque_limit=[1, 2]), None, "torque_limit must be a number"),
    ("frame_skip as text", dict(frame_skip="2"), None, "frame_skip must be a number"),
    ("width True", dict(width=True), None, "width must be a whole number"),
    ("height 4096.5", dict(height=4096.5), None, "height must be a whole number"),
    ("render_mode human", dict(render_mode="human"), None, "render_mode must be None or 'rgb_array'"),
    ("reset options a list", {}, ("reset", dict(options=[1, 2])), "options must be a dict"),
    ("reset option misspelt", {}, ("reset", dict(options={"x_0": [0.0] * 6})), "unknown reset option(s) x_0"),
    ("reset x0 as text", {}, ("reset", dict(options={"x0": "abc"})), "options['x0'] must be 6 finite numbers"),
    ("reset x0 complex", {}, ("reset", dict(options={"x0": [1j, 0, 0, 0, 0, 0]})), "must be 6 finite numbers"),
    ("reset x0 of 5 values", {}, ("reset", dict(options={"x0": [0.0] * 5})), "must be 6 finite numbers"),
    ("action a scalar", {}, ("step", 5.0), "an action is two real numbers [tau2, tau3], shape (2,), got shape ()"),
    ("action of one value", {}, ("step", [5.0]), "got shape (1,)"),
    ("action of three values", {}, ("step", [5.0, 1.0, 2.0]), "got shape (3,)"),
    ("action a column", {}, ("step", [[5.0], [1.0]]), "got shape (2, 1)"),
    ("action a row", {}, ("step", [[5.0, 1.0]]), "got shape (1, 2)"),
    ("action NaN", {}, ("step", [np.nan, 0.0]), "an action must be finite"),
    ("action inf", {}, ("step", [np.inf, 0.0]), "an action must be finite"),
    ("action as text", {}, ("step", ["a", "b"]), "an action is two real numbers"),
    ("action complex", {}, ("step", [1j, 0.0]), "an action is two real numbers"),
    ("action booleans", {}, ("step", [True, False]), "an action is two real numbers"),
]


@pytest.mark.parametrize("what, kwargs, call, fragment", BAD_GYM_CALLS, ids=[c[0] for c in BAD_GYM_CALLS])
def test_the_gym_env_refuses_what_it_would_misread_second_pass(what, kwargs, call, fragment):
    pytest.importorskip("gymnasium")
    from paa_mj.envs import GymnastKipEnv

    with pytest.raises(ValueError) as caught:
        env = GymnastKipEnv(**kwargs)
        env.reset(seed=0)
        before = env.data.qpos.copy()
        if call[0] == "reset":
            env.reset(seed=0, **call[1])
        else:
            env.step(call[1])
    assert fragment in str(caught.value) and "\n" not in str(caught.value), str(caught.value)
    if call is not None:
        np.testing.assert_array_equal(env.data.qpos, before)  # nothing was stepped or reset


def test_the_gym_env_still_takes_float32_and_integer_actions():
    pytest.importorskip("gymnasium")
    from paa_mj.envs import GymnastKipEnv

    env = GymnastKipEnv(init_noise=0.0)
    env.reset(seed=0)
    env.step(np.array([3, -2]))
    np.testing.assert_array_equal(env.data.ctrl, [3.0, -2.0])
    env.step(np.array([1.5, 0.5], np.float32))
    np.testing.assert_array_equal(env.data.ctrl, [1.5, 0.5])


@pytest.mark.parametrize("how", ["torques beyond MuJoCo's range", "a start beyond MuJoCo's range"])
def test_a_diverging_gym_step_leaves_no_mujoco_log_and_prints_nothing(how, tmp_path, monkeypatch, capfd):
    pytest.importorskip("gymnasium")
    from paa_mj.envs import GymnastKipEnv

    monkeypatch.chdir(tmp_path)
    env = GymnastKipEnv(torque_limit=1e12)
    if how.startswith("torques"):
        env.reset(seed=0)
        _, reward, terminated, truncated, info = env.step(np.array([1e12, -1e12]))
    else:
        env.reset(seed=0, options={"x0": [0, 0, 0, 1e11, 0, 0]})
        _, reward, terminated, truncated, info = env.step(np.zeros(2))
    assert terminated and not truncated and info["diverged"] and reward == -10.0
    out, err = capfd.readouterr()
    assert "WARNING" not in out + err
    assert list(tmp_path.iterdir()) == []  # no MUJOCO_LOG.TXT where the agent runs
