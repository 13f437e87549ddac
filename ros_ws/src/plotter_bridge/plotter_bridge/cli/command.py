"""A subcommand of the ``plotter`` command line, and its exit codes.

Each subcommand adds its arguments to its own argparse sub-parser and runs
with the parsed namespace, returning the exit code; main.py puts them in one
table.
"""
from __future__ import annotations

import argparse
from dataclasses import dataclass
from typing import Callable

EXIT_OK = 0
EXIT_FAILED = 1            # the board did not finish the program
EXIT_BAD_PROGRAM = 2       # bad input or usage: nothing moved


@dataclass(frozen=True)
class Command:
    name: str
    help: str
    configure: Callable[[argparse.ArgumentParser], None]
    run: Callable[[argparse.Namespace], int]
