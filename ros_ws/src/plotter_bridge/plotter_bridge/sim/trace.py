"""The mock board's output files read back: its step trace and its sequence
log (mock_board.py writes them)."""
from __future__ import annotations

import csv
from pathlib import Path
from typing import List


def read_seq_log(path: Path) -> List[object]:
    """The mock board's sequence log: ints, and "reset" where the board restarted."""
    with open(path) as f:
        rows = f.read().split()
    assert rows[0] == "seq"
    return [r if r == "reset" else int(r) for r in rows[1:]]


def read_trace(path: Path, z: bool = False) -> List[tuple]:
    """The mock board's step trace: (t_s, x_steps, y_steps) a step, with
    `z` (a board with a Z axis) (t_s, x_steps, y_steps, z_steps)."""
    with open(path) as f:
        rows = list(csv.reader(f))
    header = rows[0]
    assert header[:3] == ["t_s", "x_steps", "y_steps"] and header[3:] in ([], ["z_steps"]), header
    assert header[3:] == ["z_steps"] or not z, "the trace has no z_steps: a board without a Z axis"
    if z:
        return [(float(t), int(x), int(y), int(zs)) for t, x, y, zs in rows[1:]]
    return [(float(t), int(x), int(y)) for t, x, y, *_ in rows[1:]]
