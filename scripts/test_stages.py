#!/usr/bin/env python3
"""Runs the test suite in its stages and sums the stages up in one last line.

usage: scripts/test_stages.py [--stage NAME] [--workers N] [pytest arguments...]

Two stages, one after the other, each one pytest run spread over the
machine's cores by pytest-xdist (two workers a core for `ros`), a test file
to a worker (a file's module fixtures, an s51 session or a node graph, are
then made once):

  noros  the tests that need no ROS: the pure Python, the firmware's host
         build and the 8051 image in the s51 simulator (CPU-bound sweeps);
  ros    the tests marked `ros`: rclpy in the test process, and node graphs
         as processes that answer in real time.  They never share a core
         with a sweep of the other stage.

A test that runs longer than pytest.ini's timeout fails with every thread's
stack; the stages together get PLOTTER_TEST_LIMIT seconds (default 4200, CI
allows 5400 with the set-up): a stage still running then is stopped and the
run fails, naming the stage.  The last line gives every stage's counts and
the whole time, set-up included when scripts/test.sh passes its start time
in PLOTTER_TEST_START (seconds since the epoch).  A skip is allowed only
for a reason tests/conftest.py's EXPECTED_SKIPS lists (PLOTTER_STRICT_SKIPS).

Exit status: 0 when every stage passed and at least one test ran; 5 when
none was collected; 1 otherwise.
"""
from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List

ROOT = Path(__file__).resolve().parent.parent
ORDER = ("failed", "passed", "skipped", "xfailed", "xpassed", "error", "deselected")


@dataclass(frozen=True)
class Stage:
    name: str
    marks: str
    per_core: int = 1          # pytest-xdist workers for each core


# A node graph's test waits much of its time for what its processes do in
# real time: with a worker a core the ros stage kept one of the 2 cores busy
# (918 s), with two a core both (716 s).  Still never beside a sweep.
STAGES = (Stage("noros", "not ros"), Stage("ros", "ros", per_core=2))


@dataclass
class Outcome:
    counts: Dict[str, int] = field(default_factory=dict)
    skips: List[dict] = field(default_factory=list)
    exitstatus: int = 0
    seconds: float = 0.0
    note: str = ""


def summary(counts: Dict[str, int]) -> str:
    """pytest's own wording: "1 failed, 2 passed, 3 skipped"."""
    parts = [f"{counts[k]} {'errors' if k == 'error' and counts[k] != 1 else k}"
             for k in ORDER if counts.get(k)]
    return ", ".join(parts) or "no tests ran"


def run_stage(stage: Stage, workers: int, args: List[str], deadline: float) -> Outcome:
    report = Path(tempfile.mkstemp(prefix=f"plotter-{stage.name}-", suffix=".json")[1])
    targets = [] if any(Path(a.split("::")[0]).exists() for a in args if not a.startswith("-")) else ["tests/"]
    cmd = [sys.executable, "-m", "pytest", *targets, "-m", stage.marks, "-q", "--durations=25",
           f"--stage-report={report}", *(["-n", str(workers), "--dist", "loadfile"] if workers > 1 else []),
           *args]
    print(f"[test] stage {stage.name}: {' '.join(cmd[1:])}", flush=True)
    start = time.monotonic()
    proc = subprocess.Popen(cmd, cwd=ROOT, start_new_session=True)
    outcome = Outcome()
    try:
        proc.wait(timeout=max(1.0, deadline - time.monotonic()))
    except (subprocess.TimeoutExpired, KeyboardInterrupt) as exc:
        # In its own session (so that the stop reaches every worker and node it started): stopped
        # here, on the time limit or on Ctrl-C.
        outcome.note = (f"stage {stage.name} passed the run's time limit and was stopped"
                        if isinstance(exc, subprocess.TimeoutExpired) else f"stage {stage.name} interrupted")
        os.killpg(proc.pid, signal.SIGINT)        # pytest prints what it has, then ends
        try:
            proc.wait(timeout=60)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
        if isinstance(exc, KeyboardInterrupt):
            raise
    outcome.seconds = time.monotonic() - start
    try:
        data = json.loads(report.read_text() or "{}")
    except (OSError, ValueError):
        data = {}
    finally:
        report.unlink(missing_ok=True)
    outcome.counts = data.get("counts", {})
    outcome.skips = data.get("skips", [])
    outcome.exitstatus = proc.returncode if not outcome.note else 1
    if not data and not outcome.note:
        outcome.note = f"stage {stage.name} ended ({proc.returncode}) without its report"
    return outcome


def main(argv: List[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--stage", choices=[s.name for s in STAGES], action="append",
                        help="run only this stage (may be given twice)")
    parser.add_argument("--workers", type=int, default=0,
                        help="pytest-xdist workers of every stage (default: the machine's cores, "
                             "twice that for the ros stage)")
    opts, pytest_args = parser.parse_known_args(argv)
    limit = float(os.environ.get("PLOTTER_TEST_LIMIT", "4200"))
    started = float(os.environ.get("PLOTTER_TEST_START", "") or time.time())
    deadline = time.monotonic() + limit
    outcomes: Dict[str, Outcome] = {}
    for stage in STAGES:
        if opts.stage and stage.name not in opts.stage:
            continue
        workers = opts.workers or (os.cpu_count() or 1) * stage.per_core
        outcomes[stage.name] = run_stage(stage, workers, pytest_args, deadline)
        if time.monotonic() >= deadline:
            break
    total = {k: sum(o.counts.get(k, 0) for o in outcomes.values()) for k in ORDER}
    total["deselected"] = 0              # each stage deselects the other's tests
    failed = False
    for name, o in outcomes.items():
        shown = {k: v for k, v in o.counts.items() if k != "deselected"}
        print(f"[test] stage {name}: {summary(shown)} in {o.seconds:.0f} s")
        for skip in o.skips:
            print(f"[test]   skipped {skip['test']}: {skip['reason']}")
        if o.note:
            print(f"[test] ERROR: {o.note}")
        # pytest's 5 is a stage the arguments left without tests, not a failure of its own.
        failed |= bool(o.note) or o.exitstatus not in (0, 5)
    ran = sum(total[k] for k in ORDER if k != "deselected")
    expected_skips = int(os.environ.get("PLOTTER_EXPECTED_SKIPS", "0"))
    if total["skipped"] > expected_skips:
        print(f"[test] ERROR: {total['skipped']} tests skipped, more than the {expected_skips} expected")
        failed = True
    elapsed = time.time() - started
    hms = f"{int(elapsed // 3600)}:{int(elapsed % 3600 // 60):02d}:{int(elapsed % 60):02d}"
    print(f"{'=' * 20} {summary(total)} in {elapsed:.2f}s ({hms}) {'=' * 20}", flush=True)
    if ran == 0:
        return 5
    return 1 if failed or total["failed"] or total["error"] else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
