"""Runs that go wrong say so: user controllers that misbehave, options without effect, diverging runs, trajectories and
their robot, the Gymnasium env's arguments, environment variables.
"""
import os
import subprocess
import sys

import numpy as np
import pytest

from .faults_shared import PRINTING_AND_FAILING, USER_CONTROLLERS, _one_line_error, _strict, _variant
from .helpers import cli


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
    (["check", "--seed", "-1"], "--seed: must be a whole number in [0, 2^32)"),
    (["robustness", "--seed", "99999999999999999999"], "--seed: must be a whole number in [0, 2^32)"),
    (["theory", "--kD", "1e300", "--kP", "1e300", "--kV", "1e300"], "kD = 1e+300 is above 1e+12"),
    (["simulate", "--x0", "1e300", "0", "0", "0", "0", "0"], "initial angle 1e+300 rad is beyond"),
    (["simulate", "--sample-dt", "0.0015", "--t-final", "1"], "not a whole number of time steps"),
    (["simulate", "--dt", "0.03", "--sample-dt", "0.06", "--t-final", "1"],
     "final time 1 s is not a whole number of time steps (dt = 0.03 s): give 0.99 or 1.02"),
    (["simulate", "--dt", "1", "--t-final", "2"], "time step 1 s is above 0.1 s"),
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
    (["realaigym", "--protocol", "performance-v2", "--seed", "5"], "--seed applies to the protocols robustness-v2"),
    (["roa", "--method", "sos", "--samples", "5"], "--samples applies to --method sampling"),
    (["robustness", "--factors", "noise", "--torque-scale", "5"], "--torque-scale applies to the factors"),
    (["simulate", "--controller", "passive", "--switch", "region"], "--switch applies to the controllers vcl, vc"),
    (["theory", "--kd-budget", "1e300"], "--kd-budget: 1e300 CPU-s is above 86400 (a day)"),
    (["bench", "--batch-size", "100000000000"], "physics steps for 3 batches of 100000000000 rollouts"),
    (["compare", "--quick", "--controllers", "vcl,foo"], "unknown controller 'foo'"),
    (["robustness", "--factors", "torque_limit", "--torque-scale", "1e-30", "--trials", "1", "--t-final", "1"],
     "the torque scale given (--torque-scale) is 1e-30 N m, not a physical torque scale for robot gymnast"),
    (["robustness", "--factors", "torque_noise", "--torque-scale", "1e30", "--trials", "1", "--t-final", "1"],
     "the torque scale must lie in (0, 1e+12] N m"),
    (["robustness", "--factors", "torque_limit", "--torque-limit", "1", "--torque-scale", "1000", "--trials", "2"],
     "the torque_limit levels reach 1000 N m (fractions of the torque scale 1000 N m), above the saturation"),
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


def test_a_folder_of_another_commands_results_is_refused(tmp_path, run, one_panel_figures):
    one_panel_figures("basin_figure")  # the folder's owner is checked, not the figure (test_engine, test_distributed)
    out = tmp_path / "study"
    assert run("basin", "--grid", "2", "--t-final", "0.05", "--scheduler", "inline", "--out", out).returncode == 0
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}
    _one_line_error(run("simulate", "--t-final", "0.05", "--out", out), "holds the results of 'paa-mj basin'")
    assert {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()} == before
    assert run("basin", "--grid", "2", "--t-final", "0.05", "--scheduler", "inline", "--out", out).returncode == 0


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


def _interrupting_engine(monkeypatch):
    """The batch engine as after Ctrl-C: what it ran, marked interrupted."""
    import dataclasses

    from paa_mj.sim import batch

    real = batch.run_engine
    monkeypatch.setattr(batch, "run_engine",
                        lambda *args, **kwargs: dataclasses.replace(real(*args, **kwargs), interrupted=True))


def test_a_batch_cut_short_is_raised_unless_its_caller_keeps_partial_results(monkeypatch):
    """No caller can take an interrupted batch for a whole one: only a study that keeps and resumes asks for it."""
    from paa_mj.model import load_robot
    from paa_mj.sim.batch import simulate_batch

    _interrupting_engine(monkeypatch)
    gymnast = load_robot("gymnast")
    with pytest.raises(KeyboardInterrupt):
        simulate_batch(gymnast, np.zeros((2, 6)), 0.05)
    assert simulate_batch(gymnast, np.zeros((2, 6)), 0.05, partial=True).interrupted


@pytest.mark.parametrize("args", [["gain-search", "--t-final", "0.05"],
                                  ["roa", "--robot", "acrobot", "--method", "sampling", "--samples", "1", "--check", "2"]])
def test_commands_that_ran_batches_stop_on_an_interrupt_instead_of_reporting_it(monkeypatch, capsys, args, tmp_path):
    from paa_mj.cli import main
    from paa_mj.theory import roa

    monkeypatch.setenv("PAA_MJ_CACHE", str(tmp_path))  # the stand-in region is kept here, not in the user's cache

    _interrupting_engine(monkeypatch)
    monkeypatch.setattr(roa, "simulated_level", lambda *a, **k: {"rho": 1.0, "at_top": False, "samples": 1,
                                                                 "seed": 0, "horizon": 1.0})
    code = main(args + ["--json"])
    captured = capsys.readouterr()
    assert code == 130 and "interrupted" in captured.err and captured.out == ""


def test_a_bench_measurement_cut_short_is_no_measurement():
    from dataclasses import dataclass

    from paa_mj.studies.bench import _whole

    @dataclass
    class Run:
        interrupted: bool = False
        meta: dict | None = None

    for cut in (Run(interrupted=True), Run(meta={"interrupted": True}), ({"interrupted": True}, {})):
        with pytest.raises(KeyboardInterrupt):
            _whole(cut)
    whole = ({"interrupted": False}, {})
    assert _whole(Run()) is not None and _whole(whole) is whole and _whole(None) is None


def test_a_single_run_cut_short_is_raised_unless_its_caller_keeps_it():
    """Ctrl-C in a run (here raised by a Python controller at t = 0.1 s, where the engine catches it)."""
    from paa_mj.model import load_robot
    from paa_mj.sim.analytic.engine import simulate_analytic
    from paa_mj.sim.rollout import simulate_mujoco

    class CtrlC:
        def torque(self, q, qd, t):
            if t > 0.1:
                raise KeyboardInterrupt
            return np.zeros(q.shape[:-1] + (2,))

    gymnast = load_robot("gymnast")
    for simulate in (simulate_mujoco, simulate_analytic):
        with pytest.raises(KeyboardInterrupt):
            simulate(gymnast, CtrlC(), None, 1.0)
        kept = simulate(gymnast, CtrlC(), None, 1.0, partial=True)
        assert kept.meta["interrupted"] and kept.meta["status"].startswith("interrupted at t =")
