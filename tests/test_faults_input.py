"""Bad input is one line: model features the analytic model lacks, contradictory options, bounded requests, numbers;
outputs written whole or not at all, never through a symbolic link or over a file they did not write.
"""
import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from .faults_shared import GYMNAST, _one_line_error, _variant
from .helpers import cli


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
    ("damping switched off", HIPS, '<joint name="hips" type="hinge" axis="0 1 0" damping="3"/>',
     'damping switched off (flag damper="disable")'),
    ("actuator group disabled", '<motor name="hip" joint="hips" gear="1"/>',
     '<motor name="hip" joint="hips" gear="1" group="2"/>', "actuator 1 in a disabled group"),
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
    if what == "damping switched off":
        text = text.replace('contact="disable"/>', 'contact="disable" damper="disable"/>')
    if what == "actuator group disabled":
        text = text.replace('<option ', '<option actuatorgroupdisable="2" ')
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
     "--integrator does not apply to --engine analytic"),
    ("time step with the analytic engine", ["simulate", "--engine", "analytic", "--dt", "0.002"],
     "--dt does not apply to --engine analytic"),
    ("unknown GL backend in reproduce", ["reproduce", "--gl", "vulkan"], "invalid choice: 'vulkan'"),
    ("--no-switch with another controller", ["simulate", "--no-switch", "--controller", "lqr"], "contradicts"),
    ("gains for a controller without gains", ["simulate", "--controller", "passive", "--kP", "3"],
     "apply to the controllers"),
    ("a GL backend without a video", ["reproduce", "--no-video", "--gl", "egl"], "--no-video skips"),
    ("--fresh without --out", ["basin", "--fresh"], "without --out nothing is kept"),
    ("--kip-duration for a controller without a kip", ["simulate", "--kip-duration", "2"], "--kip-duration applies"),
    ("--starts without --simulate", ["atlas", "--starts", "2"], "--starts applies with --simulate only"),
]


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
    # refused before it is opened: a run that waited on the pipe would never end (no writer), and the timeout would
    # say so; no bound on the clock's seconds here, which a loaded machine stretches
    proc = cli("theory", "--robot", path)
    _one_line_error(proc, "is not a regular file")


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
    start = time.process_time()  # CPU time, which another load on the machine does not stretch
    proc = run(*[a.format(d=tmp_path) for a in args])
    _one_line_error(proc, fragment)
    assert time.process_time() - start < 20
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


def test_a_closed_standard_output_is_written_to_nowhere(tmp_path):
    proc = subprocess.run(f"{sys.executable} -m paa_mj.cli simulate --t-final 0.05 --out {tmp_path / 'run'} >&-",
                          shell=True, capture_output=False, stderr=subprocess.PIPE, text=True, timeout=120)
    assert proc.returncode == 0 and "Traceback" not in proc.stderr
    assert (tmp_path / "run" / "summary.json").is_file()  # the files are still written


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
    # until the encoder has written its first bytes, however long a loaded machine takes to get there
    while proc.poll() is None and not any(p.name.startswith(".kip.mp4") and p.stat().st_size > 0
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
def test_a_study_does_not_overwrite_a_summary_it_did_not_write(command, tmp_path, run, one_panel_figures):
    # what each writes beside summary.json is checked, not its drawing (the atlas's ten maps, 5 CPU-s: test_atlas)
    one_panel_figures("atlas_theory_figure", "basin_figure", "robustness_figure")
    out = tmp_path / "mine"
    out.mkdir()
    (out / "summary.json").write_text('{"my": "notes"}')
    run(*command, "--out", out)
    assert (out / "summary.json").read_text() == '{"my": "notes"}'
