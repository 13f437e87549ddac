"""The ``plotter`` command line: one table of subcommands and ``main``.

``COMMANDS`` holds this package's subcommands (check.py: ``check``;
follow.py: ``follow``; run.py: the ones that run the node graph).  Each
adds its arguments to its own argparse sub-parser and runs with the parsed
namespace, returning the exit code; further subcommands are added to the
table without changing ``main``.

Other installed packages add theirs through the entry point group
``plotter.commands`` (a sequence of Command), the way ros2cli finds the verbs
of other packages: plotter_shapes adds ``draw``, ``svg`` and ``text``, and
this package does not depend on it.
"""
from __future__ import annotations

import argparse
import sys
from importlib.metadata import entry_points
from typing import Dict, Optional, Sequence, TextIO

from . import check, follow, run
from .command import EXIT_BAD_PROGRAM, Command

COMMANDS: Dict[str, Command] = {c.name: c for c in (*check.COMMANDS, *run.COMMANDS, *follow.COMMANDS)}
ENTRY_POINT_GROUP = "plotter.commands"


def installed_commands(err: Optional[TextIO] = None) -> Dict[str, Command]:
    """The subcommands other installed packages add (entry points of
    ENTRY_POINT_GROUP); one that fails to load is reported and left out."""
    err = err or sys.stderr
    found: Dict[str, Command] = {}
    for point in sorted(entry_points(group=ENTRY_POINT_GROUP), key=lambda p: p.name):
        try:
            commands = tuple(point.load())
        except Exception as exc:  # a broken extension must not take the other commands with it
            err.write(f"plotter: the commands of {point.value} are not available: {exc}\n")
            continue
        for command in commands:
            if isinstance(command, Command) and command.name not in COMMANDS:
                found[command.name] = command
    return found


def all_commands() -> Dict[str, Command]:
    """This package's subcommands, then those of other installed packages."""
    return {**COMMANDS, **installed_commands()}


def build_parser(commands: Optional[Dict[str, Command]] = None) -> argparse.ArgumentParser:
    commands = all_commands() if commands is None else commands
    parser = argparse.ArgumentParser(prog="plotter", description="Pen plotter tools.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for command in commands.values():
        p = sub.add_parser(command.name, help=command.help, description=command.help)
        command.configure(p)
        p.set_defaults(_run=command.run)
    return parser


def main(argv: Optional[Sequence[str]] = None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse reports usage errors by exiting
        return exc.code if isinstance(exc.code, int) else EXIT_BAD_PROGRAM
    return args._run(args)


if __name__ == "__main__":
    sys.exit(main())
