"""Held-out edges of issue 47's kinds, found by an adversarial pass after they were closed: a folder is a study's by
what its files hold, not by their names; a robot at the edge of the plausible parameters is refused before any run by
the studies that perturb it (robustness's model error, the leaderboard's sweep, the atlas's range)."""
import json
from types import SimpleNamespace

import pytest

from paa_mj.errors import PaaError
from paa_mj.model.params import RobotParams


def _one_line(result, fragment):
    assert result.returncode == 2 and "Traceback" not in result.stderr, result.stderr
    lines = [line for line in result.stderr.strip().splitlines() if "compiled kernels" not in line]
    assert len(lines) == 1 and fragment in lines[0], result.stderr


def test_a_user_s_files_named_like_a_study_s_are_nobody_s(tmp_path):
    from paa_mj.cli.folders import folder_owner, output_lock

    out = tmp_path / "mine"
    out.mkdir()
    (out / "report.md").write_text("# my own report\n")  # reproduce's names, not its files
    (out / "results.json").write_text('{"mine": 1}')
    assert folder_owner(out) is None
    with output_lock(str(out), "basin", fresh=True):  # --fresh removes another study's files only
        pass
    assert (out / "report.md").read_text() == "# my own report\n" and (out / "results.json").exists()

    other = tmp_path / "other"
    other.mkdir()
    (other / "realaigym.json").write_text('{"a": 1}')
    for fresh in (False, True):
        with pytest.raises(PaaError, match="holds realaigym.json, not the results of a 'paa-mj realaigym'"):
            with output_lock(str(other), "realaigym", "realaigym --protocol performance-v2", fresh=fresh):
                pass
    assert (other / "realaigym.json").read_text() == '{"a": 1}'

    theirs = tmp_path / "theirs"  # a folder of an older version (no manifest): still known by what it holds
    theirs.mkdir()
    (theirs / "realaigym.json").write_text(json.dumps({"protocol": "global-v3", "robot": "r", "controller": "c"}))
    assert folder_owner(theirs) == ("realaigym", "realaigym --protocol global-v3")
    (other / "realaigym.json").unlink()
    (other / "report.md").write_text("# Liu & Xin (2015) reproduced in MuJoCo\n\n...")  # what reproduce writes
    assert folder_owner(other) == ("reproduce", "reproduce")


def test_model_error_beyond_the_plausible_parameters_is_refused_before_any_run():
    from paa_mj.studies.robustness import check_model_error

    heavy = SimpleNamespace(params=RobotParams.uniform_rods([1e6] * 3, [1.0] * 3))  # make-model's largest masses
    check_model_error(heavy, [0.0], "lower it")
    with pytest.raises(PaaError, match=r"a model error of 10 % makes the controller's model non-physical: m1 = 1.1e\+06"
                                       r" lies outside the plausible range .*; lower it$"):
        check_model_error(heavy, [2.0, 10.0, 5.0], "lower it")
    short = SimpleNamespace(params=RobotParams.uniform_rods([1.0] * 3, [1e-4] * 3))
    with pytest.raises(PaaError, match="l1 = 9.8e-05"):
        check_model_error(short, [2.0], "lower it")


@pytest.fixture(scope="module")
def heavy_xml(tmp_path_factory):
    from paa_mj.model.mjcf import mjcf_from_params

    params = RobotParams.uniform_rods([1e6] * 3, [1.0] * 3)
    path = tmp_path_factory.mktemp("heavy") / "heavy.xml"
    path.write_text(mjcf_from_params(params, name="heavy", gains={"kD": 1e14, "kP": 3e14, "kV": 5e13}))
    return path


def test_the_studies_that_perturb_a_robot_at_the_edge_refuse_it_up_front(run, heavy_xml):
    _one_line(run("robustness", "--robot", heavy_xml, "--trials", "1", "--t-final", "0.05", "--scheduler", "inline"),
              "makes the controller's model non-physical: m1 = 1.1e+06 lies outside the plausible range"
              " [1e-06, 1e+06]; lower --model-error, or leave model_error out of --factors")
    _one_line(run("compare", "--robot", heavy_xml, "--quick", "--no-video", "--scheduler", "inline"),
              "the leaderboard's model-error sweep cannot run on this robot")
    _one_line(run("atlas", "--robot", heavy_xml, "--grid", "2", "--scheduler", "inline"),
              "the atlas's factors 0.25 to 4 on l1, m1 make a robot of the family non-physical: m1 = 4e+06")


NAN_CONTROLLER = '''
import numpy as np


class NaNAfter:
    def __init__(self, robot):
        pass

    def torque(self, q, qd, t):
        return np.full_like(q[..., 1:], np.nan if np.max(t) > 0.02 else 0.0)
'''


def test_every_study_says_its_diverged_runs_as_realaigym_does(run, tmp_path):
    path = tmp_path / "nan_after.py"
    path.write_text(NAN_CONTROLLER)
    said = "4 of 4 runs diverged (non-finite, or joint speeds above the engines' limit), each counted a failure"
    for study in (["basin", "--grid", "2"], ["robustness", "--trials", "1", "--factors", "noise"]):
        result = run(*study, "--controller", f"{path}:NaNAfter", "--t-final", "0.05", "--scheduler", "inline")
        assert result.returncode == 0 and f"paa-mj: {said}" in result.stderr.splitlines(), result.stderr
    quiet = run("basin", "--grid", "2", "--t-final", "0.05", "--scheduler", "inline")
    assert quiet.returncode == 0 and "diverged" not in quiet.stderr


def test_every_sized_sample_count_is_sized_before_any_work(run):
    from paa_mj.cli.roa import _check_size
    from paa_mj.limits import check_seconds
    from paa_mj.studies.peer_dynamics import dynamics

    with pytest.raises(PaaError, match=r"GiB of the dynamics' random states .*; lower --samples$"):
        dynamics(samples=10**9)  # peers --samples: refused before Drake is asked for anything
    with pytest.raises(PaaError, match=r"GiB of the MuJoCo check's states .*; lower --check$"):
        _check_size(10**9, 3, 1e-3)  # roa --check: before the region, which takes minutes, is computed
    with pytest.raises(PaaError, match=r"physics steps for the MuJoCo check of 10000000 states of at least 10 s"):
        _check_size(10**7, 3, 1e-3)
    _check_size(50, 3, 1e-3)
    with pytest.raises(PaaError, match=r"would need about 1\.2e\+02 days for this here \(the limit is 1 days\); lower x$"):
        check_seconds(1e7, "this", "x")
    _one_line(run("roa", "--check", "1000000000"), "of the MuJoCo check's states")


def test_the_merged_acrobot_s_search_is_kept_by_content(tmp_path, monkeypatch):
    import paa_mj.theory.merged as merged
    from paa_mj.model.dynamics import AnalyticModel

    monkeypatch.setenv("PAA_MJ_CACHE", str(tmp_path))
    am = AnalyticModel.from_params(RobotParams.uniform_rods([1.0, 0.8, 0.6, 0.5], [1.0, 0.9, 0.8, 0.7]))
    first = merged.merged_acrobot(am)
    assert len(list((tmp_path / "merged_acrobot").glob("*.json"))) == 1
    searched = []
    real = merged._merged_acrobot
    monkeypatch.setattr(merged, "_merged_acrobot", lambda *a: searched.append(a) or real(*a))
    assert merged.merged_acrobot(am) == first and not searched  # kept: theory on a ten-link chain saved 5 CPU-s
    assert merged.merged_acrobot(am, budget_cpu_s=1.0) == first and len(searched) == 1  # another budget: searched
    assert merged.merged_acrobot(am, budget_cpu_s=0.0).controllable is None and len(searched) == 2  # never kept
    assert len(list((tmp_path / "merged_acrobot").glob("*.json"))) == 2


@pytest.mark.parametrize("protocol", ["performance-v2", "global-v3"])
def test_a_protocol_s_one_run_interrupted_is_not_run_as_in_every_study(run, monkeypatch, tmp_path, protocol):
    import paa_mj.realaigym.study as study

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(study, protocol.replace("-", "_"), interrupted)
    result = run("realaigym", "--protocol", protocol, "--controller", "passive", "--json", "--out", tmp_path / "o")
    assert result.returncode == 130, result.stderr
    summary = json.loads(result.stdout)  # --json prints its summary, as robustness-v2's and every study's
    assert summary["interrupted"] and (summary["runs"], summary["not_run"], summary["completed_fraction"]) == (1, 1, 0.0)
    assert summary["success"] is None and "time_up" not in summary["result"]
    assert result.stderr.strip().splitlines()[-1] == "paa-mj: interrupted: 0 % of the runs done (1 not run: null in the JSON)"
    assert not (tmp_path / "o" / "realaigym.json").exists()


def test_a_diverged_protocol_run_s_criteria_read_as_numbers_in_the_text_line():
    from paa_mj.cli.realaigym import _num

    assert _num(15.1912, 2) == "15.19" and _num(0.4601, 3) == "0.460"  # a run's usual line: unchanged
    assert _num(4.1547e138, 2) == "4.155e+138"  # a diverged run's energy (139 digits with :.2f)
    assert _num(float("nan"), 3) == "none" and _num(None, 3) == "none"  # null in the JSON
    assert _num(float("inf"), 3) == "inf"


def test_the_python_cross_check_takes_the_seeds_check_takes():
    """``cross_check(seed=...)`` takes the one range of every seed, as ``paa-mj check --seed`` does."""
    from paa_mj.model import load_robot
    from paa_mj.model.crosscheck import cross_check

    model = load_robot("acrobot").model
    assert cross_check(model, samples=4, seed=2**32 - 1).worst() < 1e-6
    with pytest.raises(PaaError, match=r"seed must be a whole number in \[0, 2\^32\)"):
        cross_check(model, samples=4, seed=2**40)
