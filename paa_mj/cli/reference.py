"""The options of every command, as ``--help`` prints them, for ``docs/cli.md``.

``python -m paa_mj.cli.reference docs/cli.md`` rewrites the part of that file after
:data:`MARKER`; a test checks that the checked-in file is what this writes, so the
documented options are always the real ones.
"""
from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

MARKER = "<!-- The options below are written by `python -m paa_mj.cli.reference docs/cli.md`. -->"
#: Line width of the help texts in the documentation (argparse reads it from COLUMNS).
WIDTH = 100


def options_reference() -> str:
    """Markdown: one section per command with its ``--help`` text."""
    from . import build_parser

    before = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = str(WIDTH)
    try:
        parser = build_parser()
        commands = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices
        parts = [MARKER, "", "## Options of each command", ""]
        for name, command in commands.items():
            parts += [f"### {name}", "", "```text", command.format_help().rstrip(), "```", ""]
    finally:
        if before is None:
            os.environ.pop("COLUMNS", None)
        else:
            os.environ["COLUMNS"] = before
    return "\n".join(parts)


def with_reference(text: str) -> str:
    """``text`` (a cli.md) with everything from :data:`MARKER` on replaced by the current reference."""
    head = text.split(MARKER)[0].rstrip("\n")
    return head + "\n\n" + options_reference()


if __name__ == "__main__":
    path = Path(sys.argv[1] if len(sys.argv) > 1 else "docs/cli.md")
    path.write_text(with_reference(path.read_text()))
    print(f"wrote the options of every command into {path}")
