"""Every search a command may run has a budget the user can set (``--kd-budget``), and says what it gave at it."""
from __future__ import annotations

import pytest

from paa_mj.cli import build_parser
from paa_mj.theory.kd_search import BUDGET_CPU_S, default_budget, search_budget


def _subcommands():
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    return sub.choices


def _flags(parser):
    return {flag for action in parser._actions for flag in action.option_strings}


def test_every_command_that_reads_a_robot_bounds_its_search():
    """Each command with --robot (whose default gains may need kD_min (41) searched), and make-model, takes
    --kd-budget; check (no gains) alone does not."""
    with_robot = {name for name, p in _subcommands().items() if "--robot" in _flags(p)}
    assert {"simulate", "basin", "theory", "roa", "realaigym"} <= with_robot
    for name in with_robot - {"check"}:
        assert "--kd-budget" in _flags(_subcommands()[name]), name
    assert "--kd-budget" in _flags(_subcommands()["make-model"])
    help_text = _subcommands()["make-model"].format_help()
    assert "twice the budget" in " ".join(help_text.split())


def test_the_budget_is_the_process_default_within_the_block():
    assert default_budget() == BUDGET_CPU_S
    with search_budget(0.25):
        assert default_budget() == 0.25
    assert default_budget() == BUDGET_CPU_S


def test_make_model_of_ten_links_stops_at_its_budget_and_states_the_bracket(run, tmp_path, monkeypatch):
    """--links 10 at a budget of 1 CPU-s: written, with the brackets of both goals in the header (it searched each
    goal for 200 CPU-s with no way to bound it)."""
    monkeypatch.setenv("PAA_MJ_CACHE", str(tmp_path / "cache"))
    out = tmp_path / "ten.xml"
    result = run("make-model", "--links", "10", "--m", *["1"] * 10, "--l", *["0.5"] * 10, "--kd-budget", "1",
                 "--timestep", "0.001", "--out", out)
    assert result.returncode == 0, result.stderr
    header = out.read_text().split("-->")[0]
    assert "kD_min taken at the budget of its search (- -kd-budget)" in header  # "--" is not allowed in a comment
    assert header.count("only bracketed") == 2


def test_the_budget_bounds_a_search_that_would_certify(tmp_path, monkeypatch):
    """A 7-link chain, certified at the default budget, is a bracket at a budget of 0.05 CPU-s."""
    from paa_mj.model.dynamics import AnalyticModel
    from paa_mj.model.params import RobotParams
    from paa_mj.task import Task
    from paa_mj.theory.conditions import chain_kd_min

    monkeypatch.setenv("PAA_MJ_CACHE", str(tmp_path / "cache"))
    model = AnalyticModel.from_params(RobotParams.uniform_rods([1.0 + 0.1 * i for i in range(7)], [0.4] * 7))
    with search_budget(0.05):
        kd = chain_kd_min(model, Task.named("folded", model), progress=False)
    assert not kd.certified and kd.upper > kd.value


@pytest.mark.parametrize("value, message", [("1e300", "above 86400 (a day)"), ("0", "positive")])
def test_a_budget_out_of_range_is_one_line(run, value, message):
    result = run("simulate", "--kd-budget", value)
    assert result.returncode == 2 and message in result.stderr and result.stderr.count("\n") == 1
