"""Studies at their edges: one notion of a run not run in every study's output (null in the JSON, False in a
``completed`` mask, counted as ``not_run`` in the summary), whichever study was interrupted."""
import json

import numpy as np
import pytest

from paa_mj.control.registry import ControllerSpec
from paa_mj.io import dumps
from paa_mj.model.robot import load_robot
from paa_mj.studies import runner
from paa_mj.task import Task


def _interrupt_after(monkeypatch, module, name, calls):
    """``module.name`` raises KeyboardInterrupt (as Ctrl-C) from its call number ``calls + 1`` on."""
    original = getattr(module, name)
    count = {"n": 0}

    def wrapped(*args, **kwargs):
        count["n"] += 1
        if count["n"] > calls:
            raise KeyboardInterrupt
        return original(*args, **kwargs)

    monkeypatch.setattr(module, name, wrapped)


def _says_what_was_not_run(summary, not_run, runs):
    assert summary["interrupted"] is True
    assert summary["runs"] == runs and summary["not_run"] == not_run
    assert summary["completed_fraction"] == pytest.approx((runs - not_run) / runs)
    json.loads(dumps(summary))  # null, not NaN, in what is written


def test_an_interrupted_realaigym_robustness_lists_its_runs_not_run_as_null(monkeypatch):
    from paa_mj.realaigym import study as rg

    acrobot = load_robot("realaigym_acrobot")
    task = Task.named("stretched", acrobot)
    for name, value in (("LEVELS", 3), ("REPETITIONS", 2), ("PERTURBATION_RUNS", 2), ("CHUNK", 8)):
        monkeypatch.setattr(rg, name, value)
    calls = []

    def run_many(self, runs, T, advanced=None):  # the first chunk "runs" (half of it ends at the goal), then Ctrl-C
        calls.append(len(runs))
        if len(calls) > 1:
            raise KeyboardInterrupt
        goal = rg.their_goal(acrobot, task)
        return [(np.tile(goal if i % 2 else goal + 1.0, (len(T), 1)), np.zeros((len(T) - 1, 2))) for i in range(len(runs))]

    monkeypatch.setattr(rg.Runs, "run_many", run_many)
    summary, _ = rg.run_protocol("robustness-v2", acrobot, ControllerSpec("spong", task=task), task, seed=3,
                                 progress=False)
    result = summary["result"]
    _says_what_was_not_run(summary, 50 - 8, 50)
    _says_what_was_not_run(result, 50 - 8, 50)
    runs = [r for entries in result["criteria"].values() for e in entries.values() for level in e["runs"]
            for r in level]
    assert len(runs) == 50 and runs.count(None) == 42 and all(r in (True, False, None) for r in runs)
    assert runs[:8] == [False, True] * 4  # their order: the first chunk ran, every second run at the goal
    for entries in result["criteria"].values():
        for entry in entries.values():  # a level with a run not run has no success, never false
            for level, success in zip(entry["runs"], entry["success"]):
                assert (success is None) == (None in level)
    assert "scores" not in result and "score" not in result


@pytest.fixture
def interrupted_chunks(monkeypatch):
    """Every study run by :func:`~paa_mj.studies.runner.run_study` stops (as by Ctrl-C) after its first chunk."""
    _interrupt_after(monkeypatch, runner, "_rollout_task", 1)


def test_an_interrupted_basin_marks_its_runs_not_run(interrupted_chunks):
    from paa_mj.studies.basin import NOT_RUN_CODE, basin

    summary, arrays = basin(load_robot("gymnast"), (0, 1), 2, 0.05, chunk=2)
    _says_what_was_not_run(summary, 2, 4)
    assert sum(summary["outcomes"].values()) == 2
    assert arrays["completed"].tolist() == [True, True, False, False]
    assert arrays["outcome"][2:].tolist() == [NOT_RUN_CODE] * 2 and np.all(arrays["outcome"][:2] >= 0)


def test_an_interrupted_robustness_counts_each_level_s_runs_not_run(interrupted_chunks):
    from paa_mj.studies.robustness import robustness

    summary, arrays = robustness(load_robot("gymnast"), trials=2, t_final=0.05, factors=["noise"],
                                 levels={"noise": [0.0, 0.01]}, chunk=2)
    _says_what_was_not_run(summary, 2, 4)
    first, second = summary["factors"]["noise"]["levels"]
    assert (first["not_run"], first["trials"]) == (0, 2)
    assert (second["not_run"], second["trials"], second["success_rate"]) == (2, 0, None)
    assert arrays["completed"].tolist() == [True, True, False, False]


def test_an_interrupted_atlas_counts_its_robots_not_run(monkeypatch):
    from paa_mj.studies import atlas as at

    _interrupt_after(monkeypatch, at, "_theory_task", 1)
    summary, arrays = at.atlas(load_robot("gymnast"), grid=2, chunk=2)
    _says_what_was_not_run(summary, 2, 4)
    assert len(summary["robots"]) == 2 and arrays["theory_done"].tolist() == [True, True, False, False]


def test_the_command_says_how_many_were_not_run(run, monkeypatch, tmp_path):
    _interrupt_after(monkeypatch, runner, "_rollout_task", 1)
    result = run("basin", "--grid", "2", "--t-final", "0.05", "--chunk", "2", "--scheduler", "inline", "--json",
                 "--out", tmp_path)
    assert result.returncode == 130 and "2 of 4 runs not run" in result.stderr
    summary = json.loads(result.stdout)
    assert summary["not_run"] == 2 and json.loads((tmp_path / "summary.json").read_text())["not_run"] == 2
