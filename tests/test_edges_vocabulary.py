"""Frictions of the command line: one vocabulary of engines, the family rule's gains described once (on stderr)."""
from __future__ import annotations

from paa_mj.cli import build_parser
from paa_mj.cli.common import ENGINE_ALIASES, ENGINE_WORDS


def _engine_actions():
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    for name, parser in sub.choices.items():
        for action in parser._actions:
            if "--engine" in action.option_strings:
                yield name, action


def test_every_engine_option_speaks_one_vocabulary():
    """simulate took {mujoco,analytic}, the studies {mujoco,warp}, realaigym {cpu,warp}: now every --engine offers
    names of ENGINE_WORDS, each explained by the same words, and takes the old spelling mujoco as cpu."""
    seen = {}
    for command, action in _engine_actions():
        names = action.metavar.strip("{}").split(",")
        assert set(names) <= set(ENGINE_WORDS), command
        for name in names:
            assert ENGINE_WORDS[name] in " ".join(action.help.split()), (command, name)
        assert action.type("cpu") == action.type("mujoco")  # the old spelling, still accepted
        seen[command] = names
    assert {"simulate", "render", "basin", "robustness", "realaigym"} <= set(seen)
    assert all(names[0] == "cpu" for names in seen.values())  # the same default everywhere
    assert ENGINE_ALIASES == {"mujoco": "cpu"}


def test_the_family_rule_is_described_once_on_stderr(run, tmp_path):
    """A robot whose stored kD is below the stretched goal's bound runs the family rule's gains: the note on
    stderr describes the rule; stdout names the gains' origin without repeating it."""
    out = tmp_path / "unit.xml"
    assert run("make-model", "--m", "1", "1", "1", "--l", "1", "1", "1", "--timestep", "0.001",
               "--out", out).returncode == 0
    result = run("simulate", "--robot", out, "--goal", "stretched", "--t-final", "0.02", "--sample-dt", "0.01")
    assert result.returncode == 0, result.stderr
    rule = "kD = 1.05 kD_min (41)"
    assert rule not in result.stdout and "(the family rule's for the stretched goal)" in result.stdout
    assert result.stderr.count(rule) == 1 and "paa-mj: note: gains of the family rule" in result.stderr
