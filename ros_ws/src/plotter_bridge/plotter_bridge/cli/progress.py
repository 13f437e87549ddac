"""The progress of a job on the terminal: the share of the drawing's length
done and the time left (from the action feedback, which takes them from the
planner's timing), the line and the pen.

On a terminal one line is redrawn in place; anywhere else (a pipe, a log
file, CI) plain lines are printed, one per PLAIN_PERIOD at most, so that a
log does not fill with carriage returns.
"""
from __future__ import annotations

import time
from typing import Callable, TextIO

PLAIN_PERIOD = 2.0      # s between plain lines
BAR_PERIOD = 0.1        # s between redraws of the bar
WIDTH = 30


def clock_text(seconds: float) -> str:
    """12 s, 3:05, 1:02:07."""
    s = int(round(max(seconds, 0.0)))
    if s < 60:
        return f"{s} s"
    m, s = divmod(s, 60)
    if m < 60:
        return f"{m}:{s:02d}"
    h, m = divmod(m, 60)
    return f"{h}:{m:02d}:{s:02d}"


class ProgressDisplay:
    """Called with each feedback message (RunProgram or DrawShape feedback)."""

    def __init__(self, name: str, out: TextIO, tty: bool, clock: Callable[[], float] = time.monotonic) -> None:
        self.name, self.out, self.tty, self.clock = name, out, tty, clock
        self._last = -1e9
        self._shown = False

    def __call__(self, fb) -> None:
        now = self.clock()
        if now - self._last < (BAR_PERIOD if self.tty else PLAIN_PERIOD) and fb.progress < 1.0:
            return
        self._last = now
        self.out.write(self._bar(fb) if self.tty else self._plain(fb))
        self.out.flush()
        self._shown = True

    def _where(self, fb) -> str:
        line = f"line {fb.current_line}" + (f"/{fb.total_lines}" if getattr(fb, "total_lines", 0) else "")
        return f"{line}  X {fb.x_mm:.3f}  Y {fb.y_mm:.3f} mm"

    def _bar(self, fb) -> str:
        if fb.jobs_ahead:
            return f"\r{self.name}: waiting, {fb.jobs_ahead} job(s) ahead{' ' * 40}"
        done = int(WIDTH * min(1.0, fb.progress))
        return (f"\r[{'#' * done}{'.' * (WIDTH - done)}] {fb.progress * 100:5.1f}%  "
                f"{clock_text(fb.seconds_left)} left  {self._where(fb)}   ")

    def _plain(self, fb) -> str:
        if fb.jobs_ahead:
            return f"{self.name}: waiting, {fb.jobs_ahead} job(s) ahead\n"
        return (f"{self.name}: {fb.progress * 100:.0f}% done, {clock_text(fb.seconds_left)} left, "
                f"{self._where(fb)}\n")

    def close(self, success: bool) -> None:
        if self.tty and self._shown:
            if success:
                self.out.write(f"\r[{'#' * WIDTH}] 100.0%{' ' * 60}")
            self.out.write("\n")
            self.out.flush()
