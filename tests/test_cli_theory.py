"""`paa-mj theory` and `paa-mj check`, including bad input."""
import json
import subprocess
import sys

import pytest

from paa_mj.cli import main


def run_cli(capsys, *args):
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def test_theory_json_keys(capsys):
    code, out, _ = run_cli(capsys, "theory", "--robot", "gymnast", "--json")
    assert code == 0
    r = json.loads(out)
    for key in ("beta", "E_r", "kD_min", "eta1", "eta2", "constraint_54", "udd_controllable", "lqr_K", "duu_eigenvalues"):
        assert key in r
    assert r["robot"] == "gymnast" and len(r["robot_sha256"]) == 64  # which robot, as every summary says
    assert len(r["beta"]) == 3
    assert set(r["constraint_54"]) >= {"holds", "f_min", "f_max"}
    assert len(r["lqr_K"]) == 2 and all(len(row) == 6 for row in r["lqr_K"])
    assert all(len(e) == 2 for e in r["duu_eigenvalues"])
    assert r["gains"] == {"kD": 4550.0, "kP": 16000.0, "kV": 5000.0}


def test_theory_table_says_when_54_fails(capsys):
    code, out, _ = run_cli(capsys, "theory", "--robot", "example2")
    assert code == 0
    assert "constraint (54)            FAILS" in out


def test_check_json(capsys):
    code, out, _ = run_cli(capsys, "check", "--robot", "gymnast", "--samples", "300", "--seed", "3", "--json")
    assert code == 0
    r = json.loads(out)
    assert r["samples"] == 300 and r["robot"] == "gymnast" and len(r["robot_sha256"]) == 64
    for key in ("max_rel_err_M", "max_rel_err_bias", "max_rel_err_qacc"):
        assert r[key] < 1e-9


def test_make_model_round_trip(capsys, tmp_path):
    path = tmp_path / "robot.xml"
    code, _, _ = run_cli(capsys, "make-model", "--m", "2", "1", "1", "--l", "1", "0.6", "0.6", "--out", str(path),
                         "--kD", "100", "--kP", "300", "--kV", "50")
    assert code == 0
    code, out, _ = run_cli(capsys, "theory", "--robot", str(path), "--json")
    assert code == 0
    assert json.loads(out)["gains"]["kD"] == 100


@pytest.mark.parametrize("args, fragment", [
    (["theory", "--robot", "nosuch"], "unknown robot"),
    (["theory", "--robot", "/nonexistent/robot.xml"], "not found"),
    (["check", "--robot", "gymnast", "--samples", "0"], "--samples"),
    (["theory", "--robot", "gymnast", "--kD", "abc"], "--kD: not a number: 'abc'"),
    (["make-model", "--m", "1", "-1", "1", "--l", "1", "1", "1", "--out", "x.xml"], "--m: must be a positive finite"),
    (["make-model", "--m", "1", "1", "1", "--l", "1", "1", "1", "--lc", "0.5", "2", "0.5", "--J", "1", "1", "1", "--out", "x.xml"], "lc2 = 2"),
    (["frobnicate"], "invalid choice"),
])
def test_bad_input_is_one_line_exit_2(capsys, args, fragment):
    code, out, err = run_cli(capsys, *args)
    assert code == 2
    assert fragment in err
    assert len(err.strip().splitlines()) == 1
    assert "Traceback" not in err


def test_malformed_model_from_a_subprocess_has_no_traceback(tmp_path):
    bad = tmp_path / "bad.xml"
    bad.write_text("<mujoco><worldbody><body></worldbody>")
    proc = subprocess.run([sys.executable, "-m", "paa_mj.cli", "check", "--robot", str(bad)],
                          capture_output=True, text=True)
    assert proc.returncode == 2
    assert proc.stderr.startswith("paa-mj: error: malformed MJCF")
    assert "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1
