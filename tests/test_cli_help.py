"""The command line explains itself: every option has help, defaults and allowed values are shown."""
import argparse
import re
import subprocess
import sys
from pathlib import Path

import pytest

from paa_mj.cli import build_parser, main


def _subparsers(parser):
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return action.choices
    return {}


def test_every_option_of_every_command_has_help():
    for name, sub in _subparsers(build_parser()).items():
        for action in sub._actions:
            if action.option_strings and action.dest != "help":
                assert action.help, f"{name} {action.option_strings} has no help"
                if action.choices:
                    shown = sub.format_help()
                    assert all(str(c) in shown for c in action.choices), (name, action.option_strings)


def test_help_shows_defaults(capsys):
    assert main(["basin", "--help"]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "(default: 64)" in out and "(default: q1,q2)" in out and "(default: gymnast)" in out


def test_no_option_states_its_default_twice():
    for name, sub in _subparsers(build_parser()).items():
        for action in sub._actions:
            text = sub._get_formatter()._get_help_string(action) if action.option_strings else ""
            assert len(re.findall(r"(?<!%)\(default", text)) <= 1, (name, action.option_strings, text)


def test_top_level_help_is_plain_text(capsys):
    assert main(["--help"]) == 0
    out = capsys.readouterr().out
    assert "``" not in out and ":func:" not in out and ":mod:" not in out
    for command in ("theory", "simulate", "basin", "robustness", "compare", "atlas", "reproduce"):
        assert command in out


def test_version(capsys):
    from paa_mj import __version__

    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"paa-mj {__version__}"


@pytest.mark.parametrize("command", ["view"])
def test_view_has_no_options_it_would_ignore(command):
    sub = _subparsers(build_parser())[command]
    flags = {flag for action in sub._actions for flag in action.option_strings}
    assert "--engine" not in flags and "--sample-dt" not in flags


def test_every_commands_help_renders_its_own_text():
    for name, sub in _subparsers(build_parser()).items():
        text = sub.format_help()
        assert "option_strings" not in text and "%(" not in text, name  # a stray % in a help string


CLI_DOC = Path(__file__).resolve().parents[1] / "docs" / "cli.md"


def test_docs_list_every_option_of_every_command():
    doc = CLI_DOC.read_text()
    for name, sub in _subparsers(build_parser()).items():
        section = doc.split(f"### {name}\n", 1)[1].split("\n### ", 1)[0]
        for action in sub._actions:
            for flag in action.option_strings:
                assert flag in section, f"docs/cli.md does not show {name} {flag}"


@pytest.mark.skipif(sys.version_info[:2] != (3, 11), reason="argparse lays out help differently in other Pythons;"
                                                           " docs/cli.md is written with 3.11")
def test_docs_cli_reference_is_what_the_parser_prints():
    from paa_mj.cli.reference import with_reference

    assert CLI_DOC.read_text() == with_reference(CLI_DOC.read_text()), \
        "docs/cli.md is stale: run python -m paa_mj.cli.reference docs/cli.md"


def test_help_and_version_load_no_heavy_library():
    """--version and every --help answer from the parser alone: no MuJoCo, numba, SciPy or NumPy import."""
    code = ("import sys\nfrom paa_mj.cli import build_parser, main\n"
            "names = ['--version'] + [[n, '--help'] for n in build_parser()._subparsers._group_actions[0].choices]\n"
            "for args in names:\n"
            "    main(args if isinstance(args, list) else [args])\n"
            "heavy = [m for m in ('mujoco', 'numba', 'scipy', 'numpy', 'casadi', 'matplotlib') if m in sys.modules]\n"
            "print('HEAVY', heavy, file=sys.stderr)\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "HEAVY []" in proc.stderr


def test_the_task_horizon_the_options_state_is_the_tasks():
    from paa_mj.cli.common import TASK_HORIZON
    from paa_mj.task import HORIZON

    assert TASK_HORIZON.endswith(f", {HORIZON:g} s")
