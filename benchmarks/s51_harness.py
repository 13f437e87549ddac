#!/usr/bin/env python3
"""What firmware/tools/s51_poll.c saves the s51 tests, measured on this machine.

usage: .venv/bin/python benchmarks/s51_harness.py [--seconds S] [--commands N]

For s51 as Debian ships it (PLOTTER_S51_SHIM=0) and with s51_poll.so
preloaded (tools/s51sim.py's default), on the board's image (make -C
firmware): simulated seconds per host second of a free run with the UART
polled often (uart0_check_often=1, as every test runs it), and host
milliseconds per console command of a stopped simulation.  Prints one line
each; the host's load changes the first figure, not their ratio much.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "firmware" / "tools"))
import s51sim  # noqa: E402


def measure(shim: bool, seconds: float, commands: int) -> tuple:
    os.environ["PLOTTER_S51_SHIM"] = "1" if shim else "0"
    with s51sim.Sim(timeout=300) as sim:        # as shipped, a stop waits for s51 seconds
        start = time.monotonic()
        for _ in range(commands):
            sim.cmd("state")
        per_command = (time.monotonic() - start) / commands
        ticks0 = sim.ticks()
        start = time.monotonic()
        sim.go()
        time.sleep(seconds)
        sim.stop()
        rate = (sim.ticks() - ticks0) / s51sim.CLOCK_HZ / (time.monotonic() - start)
    return rate, per_command


def main(argv) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=5.0, help="host seconds of the free run")
    parser.add_argument("--commands", type=int, default=50, help="console commands timed")
    args = parser.parse_args(argv)
    if s51sim.s51_path() is None:
        print("s51 (Debian package sdcc-ucsim) is not installed", file=sys.stderr)
        return 2
    for shim in (False, True):
        rate, per_command = measure(shim, args.seconds, args.commands)
        print(f"s51 {'with s51_poll.so' if shim else 'as shipped     '}: {rate:5.2f} simulated s per host s, "
              f"{per_command * 1000:6.1f} ms per console command")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
