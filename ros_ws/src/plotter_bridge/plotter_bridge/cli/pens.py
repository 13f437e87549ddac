"""The pen changes of a job the `plotter` command runs: say which pen comes
next, wait for the user, go on.

The bridge holds a job at each pen change (BoardState PEN_CHANGE, with the
next pen's name and colour) until its `resume`.  The command watches the
state and asks on the terminal: Enter goes on (the bridge's resume), as does
`plotter resume` from elsewhere.  With --no-pen-wait every change goes on at
once (one pen for every layer).  When the terminal has no more input
(stdin closed, a script), a job on a local graph (--mock, --port) is
canceled at the change, resumable from there; a job sent to a running
plotter waits for `plotter resume`.
"""
from __future__ import annotations

import threading
from typing import Callable, Optional, TextIO, Tuple


def read_enter(stdin: TextIO) -> Callable[[], bool]:
    """Wait for a line on stdin: True for Enter, False when it has no more input."""
    def ask() -> bool:
        try:
            return bool(stdin.readline())
        except (OSError, ValueError):
            return False
    return ask


class PenPrompt:
    """Feed it every BoardState (on_state), or where the job waits (at); at each pen change it asks
    and goes on."""

    def __init__(self, err: TextIO, go_on: Callable[[], Tuple[bool, str]],
                 ask: Optional[Callable[[], bool]] = None, give_up: Optional[Callable[[], None]] = None) -> None:
        self.err = err
        self.go_on = go_on           # the bridge's resume
        self.ask = ask               # None: go on at once
        self.give_up = give_up       # when ask has no answer (None: leave the job waiting)
        self.changes = 0
        self._at: Optional[int] = None      # the program line of the change being dealt with
        self._lock = threading.Lock()

    def on_state(self, msg) -> None:
        # A change is known by its line: states of the same change repeat until the job goes on.
        self.at(msg.current_line if msg.state_name == "PEN_CHANGE" else None, msg.next_pen)

    def at(self, change: Optional[int], pen: str) -> None:
        """The job waits at pen change `change` (any key that tells one from another) for `pen`;
        None: it does not wait."""
        with self._lock:
            if change is None or change == self._at:
                self._at = change
                return
            self._at = change
            self.changes += 1
        threading.Thread(target=self._change, args=(pen,), daemon=True).start()

    def _change(self, pen: str) -> None:
        if self.ask is None:
            self.err.write(f"pen change: {pen} (not waited for: --no-pen-wait)\n")
        else:
            self.err.write(f"pen change: put in {pen}, then press Enter (or run plotter resume); "
                           f"Ctrl-C cancels\n")
            self.err.flush()
            if not self.ask():
                if self.give_up is not None:
                    self.err.write("pen change: no one to change the pen (no more input): job canceled here\n")
                    self.give_up()
                else:
                    self.err.write("pen change: no more input here; the job waits for plotter resume\n")
                return
        ok, message = self.go_on()
        if not ok:
            self.err.write(f"pen change: {message}\n")


def watch_session(prompt: PenPrompt, waiting: Callable[[], Optional[Tuple[int, str]]],
                  period: float = 0.1) -> threading.Event:
    """Feed the prompt from a bridge in this process (SerialBridge.pen_change_waiting) every
    `period` s, not from the topic, which another plotter in the ROS domain may also publish;
    set the event to stop."""
    stop = threading.Event()

    def loop() -> None:
        while not stop.wait(period):
            found = waiting()
            prompt.at(*(found if found is not None else (None, "")))
    threading.Thread(target=loop, name="pen-changes", daemon=True).start()
    return stop
