"""The streamer's journal: each job's board commands and how far the board got.

A job is written before anything is sent (`<id>.job.json`: name, board
commands with their source lines, where the pen started) and its progress is
kept beside it (`<id>.progress.json`: commands the board finished, state,
message), each file replaced atomically.  A job that ended part-way (a
cancel, an e-stop, the board's port or the serial bridge away too long) is
continued by a later `resume` from the first command not finished: the pen travels, raised, to where that
command starts if it is not already there, and the rest runs.  A Z axis
goes back to where that command starts as well, alone, in the order of a
G0: up before the travel, down after it.

Pure functions and a small file store; no ROS.
"""
from __future__ import annotations

import base64
import itertools
import json
import os
import re
import time
from array import array
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import List, Optional, Sequence, Tuple

from .command_store import CommandStore
from .protocol import MAX_DELTA, MAX_RATE, MIN_RATE

RUNNING, DONE, INTERRUPTED = "running", "done", "interrupted"
_ID = re.compile(r"^[0-9a-f]{32}$")
CHUNK = 1 << 20                   # characters of a big text written at a time


def default_journal_dir() -> Path:
    home = os.environ.get("ROS_HOME") or os.path.join(os.path.expanduser("~"), ".ros")
    return Path(home) / "plotter_journal"


@dataclass
class JobRecord:
    job_id: str
    name: str
    commands: Sequence[str]          # a list, or a compiled job's CommandStore
    lines: Sequence[int]             # a list, or an array of a compiled job's (motion/compiler.py)
    start: Tuple[int, int]            # pen position in steps when the job began
    start_pen: bool = False
    rapid_rate: int = MAX_RATE        # steps/s for the travel of a resume
    start_z: Optional[int] = None     # Z in steps when the job began (None: the board has no Z axis)
    machine: str = ""                 # what the commands were planned for (Machine.text(); "" = not recorded)
    pens: List[str] = field(default_factory=list)  # what each pen change ("M6 k") tells the operator


@dataclass
class Progress:
    completed: int = 0                # commands the board finished
    state: str = RUNNING
    message: str = ""
    resumed_by: str = ""              # the job that continued this one

    @property
    def resumable(self) -> bool:
        return self.state == INTERRUPTED and not self.resumed_by


@dataclass
class Journal:
    directory: Path
    _last: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.directory = Path(self.directory)

    def _path(self, job_id: str, kind: str) -> Path:
        if not _ID.match(job_id):
            raise ValueError(f"not a job id: {job_id!r}")
        return self.directory / f"{job_id}.{kind}.json"

    def _write(self, path: Path, data: dict, text_last: str = "") -> None:
        """`data` as JSON; with `text_last`, the object's last member "commands" is that text, written
        a megabyte at a time: a million commands' 22 MB are not also held escaped and encoded."""
        self.directory.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(".tmp")
        with open(tmp, "w") as f:
            if text_last:
                head = json.dumps({**data, "commands": ""})
                assert head.endswith('"commands": ""}')
                f.write(head[:-2])
                for k in range(0, len(text_last), CHUNK):
                    f.write(json.dumps(text_last[k:k + CHUNK])[1:-1])     # a string's escapes are per character
                f.write('"}')
            else:
                json.dump(data, f)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)

    def create(self, record: JobRecord) -> None:
        commands = record.commands
        data = asdict(replace(record, commands=[]))
        if isinstance(record.lines, array):           # a compiled job's: its bytes, not a number object each
            data["lines"] = {"uint32_base64": base64.b64encode(array("I", record.lines).tobytes()).decode()}
        else:
            data["lines"] = list(record.lines)
        # a compiled job's commands as their one text (command_store.py), a few as a list
        if isinstance(commands, CommandStore) and commands.text:
            del data["commands"]
            self._write(self._path(record.job_id, "job"), data, text_last=commands.text)
        else:
            data["commands"] = list(commands)
            self._write(self._path(record.job_id, "job"), data)
        self.update(record.job_id, Progress())

    def update(self, job_id: str, progress: Progress) -> None:
        if self._last.get(job_id) == progress:
            return
        self._write(self._path(job_id, "progress"), asdict(progress))
        self._last[job_id] = Progress(**asdict(progress))

    def load(self, job_id: str) -> Tuple[JobRecord, Progress]:
        """The job and its progress; KeyError if the journal does not hold it."""
        try:
            with open(self._path(job_id, "job")) as f:
                rec = json.load(f)
            with open(self._path(job_id, "progress")) as f:
                prog = json.load(f)
        except (OSError, ValueError) as exc:
            raise KeyError(f"job {job_id} not in the journal {self.directory}: {exc}") from None
        rec["start"] = tuple(rec["start"])
        if isinstance(rec["lines"], dict):
            lines = array("I")
            lines.frombytes(base64.b64decode(rec["lines"]["uint32_base64"]))
            rec["lines"] = lines
        if isinstance(rec["commands"], str):
            rec["commands"] = CommandStore.from_text(rec["commands"])
        return JobRecord(**rec), Progress(**prog)

    def jobs(self) -> List[Tuple[str, Progress, float]]:
        """(id, progress, modification time) of every job, newest first."""
        out = []
        for path in self.directory.glob("*.progress.json"):
            job_id = path.name.split(".")[0]
            try:
                _, prog = self.load(job_id)
            except KeyError:
                continue
            out.append((job_id, prog, path.stat().st_mtime))
        return sorted(out, key=lambda t: -t[2])


@dataclass(frozen=True)
class JobSummary:
    """One journalled job as `plotter jobs` and the web page list it."""
    job_id: str
    name: str
    when: str                 # local time of its last progress, YYYY-MM-DD HH:MM:SS
    state: str
    completed: int
    total: int
    resumed_by: str           # the job that went on with this one, "" if none
    message: str              # why it ended
    resumable: bool

    def note(self, id_chars: Optional[int] = None) -> str:
        """"resumed as ID" (its first id_chars characters, if given), or why it ended."""
        return f"resumed as {self.resumed_by[:id_chars]}" if self.resumed_by else self.message


def job_summaries(journal: Journal, limit: Optional[int] = None) -> List[JobSummary]:
    """The newest `limit` (None: all) jobs of the journal, newest first."""
    out = []
    for job_id, prog, mtime in journal.jobs()[:limit]:
        try:
            record, _ = journal.load(job_id)
        except KeyError:
            continue
        out.append(JobSummary(job_id, record.name, time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(mtime)),
                              prog.state, prog.completed, len(record.commands), prog.resumed_by,
                              prog.message, prog.resumable))
    return out


def _moves(text: str) -> Tuple[int, int]:
    parts = text.split()
    if parts and parts[0] in ("L", "C", "A"):
        return int(parts[1]), int(parts[2])
    return 0, 0


def _z(text: str) -> int:
    parts = text.split()
    return int(parts[1]) if parts and parts[0] == "Z" else 0


def _pen(text: str) -> Optional[bool]:
    parts = text.split()
    if parts and parts[0] == "P":
        return parts[1] == "1"
    return None


def state_before(record: JobRecord, index: int) -> Tuple[Tuple[int, int], bool]:
    """Where the pen is, and whether it is down, before command `index`."""
    x, y = record.start
    pen = record.start_pen
    for text in record.commands[:index]:
        dx, dy = _moves(text)
        x, y = x + dx, y + dy
        p = _pen(text)
        if p is not None:
            pen = p
    return (x, y), pen


def z_before(record: JobRecord, index: int) -> Optional[int]:
    """Where the Z axis is before command `index` (None without one)."""
    if record.start_z is None:
        return None
    return record.start_z + sum(_z(text) for text in record.commands[:index])


def z_travel(dz: int, rate: int) -> List[str]:
    """A Z move split into pieces the firmware accepts."""
    n = -(-abs(dz) // MAX_DELTA)
    out, done = [], 0
    for k in range(1, n + 1):
        to = dz * k // n
        out.append(f"Z {to - done} {rate} 0")
        done = to
    return out


def travel(dx: int, dy: int, rate: int) -> List[str]:
    """A straight move split into pieces the firmware accepts."""
    n = max(1, -(-max(abs(dx), abs(dy)) // MAX_DELTA))
    out, done_x, done_y = [], 0, 0
    for k in range(1, n + 1):
        tx, ty = dx * k // n, dy * k // n
        out.append(f"L {tx - done_x} {ty - done_y} {rate} 0")
        done_x, done_y = tx, ty
    return out


def resume_commands(record: JobRecord, completed: int, pen_at: Tuple[int, int],
                    pen_down: bool, z_at: Optional[int] = None) -> Tuple[Sequence[str], Sequence[int]]:
    """Board commands that finish the job from command `completed` on, for a
    pen now at `pen_at` (steps, down or not) and a Z axis at `z_at` (steps;
    None: no Z axis)."""
    if completed >= len(record.commands):
        return [], []
    (x, y), pen = state_before(record, completed)
    z = z_before(record, completed)
    line = record.lines[completed]
    rate = max(MIN_RATE, min(MAX_RATE, record.rapid_rate))
    dz = 0 if z is None or z_at is None else z - z_at
    head: List[str] = []
    if (x, y) != tuple(pen_at):
        if pen_down:
            head.append("P 0")
        if dz > 0:
            head += z_travel(dz, rate)
        head += travel(x - pen_at[0], y - pen_at[1], rate)
        if dz < 0:
            head += z_travel(dz, rate)
        if pen:
            head.append("P 1")
    else:
        head += z_travel(dz, rate)
        if pen != pen_down:
            head.append("P 1" if pen else "P 0")
    rest = record.commands[completed:]
    commands = CommandStore(itertools.chain(head, rest)) if isinstance(rest, CommandStore) else head + list(rest)
    rest_lines = record.lines[completed:]
    if isinstance(rest_lines, array):
        return commands, array("I", [line] * len(head)) + rest_lines
    return commands, [line] * len(head) + list(rest_lines)
