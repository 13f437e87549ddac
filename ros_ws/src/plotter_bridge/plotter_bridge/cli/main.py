"""The ``plotter`` command line: one table of subcommands and ``main``.

``COMMANDS`` holds this package's subcommands (check.py: ``check``; run.py:
the ones that run the node graph).  Each adds its arguments to its own
argparse sub-parser and runs with the parsed namespace, returning the exit
code; further subcommands are added to the table without changing ``main``.
"""
from __future__ import annotations

import argparse
import sys
from typing import Dict, Optional, Sequence

from . import check, run
from .command import EXIT_BAD_PROGRAM, Command

COMMANDS: Dict[str, Command] = {c.name: c for c in (*check.COMMANDS, *run.COMMANDS)}


def build_parser(commands: Optional[Dict[str, Command]] = None) -> argparse.ArgumentParser:
    commands = COMMANDS if commands is None else commands
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
