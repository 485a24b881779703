"""A user's code and files: misbehaving controllers named in one line, corrupted trajectory files, odd model files,
caches.
"""
import os

import numpy as np
import pytest

from paa_mj.model.mjcf import MODEL_DIR

from .faults_shared import GYMNAST, M_GEAR, USER_CONTROLLERS, _made, _one_line_error, _strict
from .helpers import cli


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
    assert "--dt" not in proc.stderr and "a controller whose torque is finite at every state" in proc.stderr
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
