"""The firmware core (firmware/core, host build) loaded through ctypes.

The same C files that run on the 8051 are compiled by `make -C firmware` into
libplotter_core.so.  Each FirmwareCore loads a private copy of the library so
that several boards can live in one process without sharing C globals.
"""
from __future__ import annotations

import ctypes
import os
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Iterator

CYCLES_PER_S = 921_600  # STC89C52RC: 11.0592 MHz / 12
LIB_NAME = "libplotter_core.so"
SEQ_LOG_CAP = 65536      # hal/host/core_api.c: commands the core logs between two takes


def find_library(z_axis: bool = False, follow: bool = False) -> Path:
    """Locate libplotter_core.so: $PLOTTER_CORE_LIB, else firmware/build above
    this file or cwd; with z_axis the build with a Z axis ($PLOTTER_CORE_LIB_Z,
    firmware/build/z), with follow the build with line following
    ($PLOTTER_CORE_LIB_FOLLOW, firmware/build/follow)."""
    if z_axis and follow:
        raise ValueError("no build has both a Z axis and line following")
    variant = "z" if z_axis else "follow" if follow else ""
    env = os.environ.get("PLOTTER_CORE_LIB" + (f"_{variant.upper()}" if variant else ""))
    if env:
        return Path(env)
    build = Path("firmware", "build", variant) if variant else Path("firmware", "build")
    for start in (Path(__file__).resolve(), Path.cwd().resolve()):
        for parent in (start, *start.parents):
            candidate = parent / build / LIB_NAME
            if candidate.exists():
                return candidate
    if variant:
        option = "ZAXIS=1" if z_axis else "FOLLOW=1"
        raise FileNotFoundError(f"{build / LIB_NAME} not found: run `make -C firmware {option}` "
                                f"or set PLOTTER_CORE_LIB_{variant.upper()}")
    raise FileNotFoundError(
        f"{LIB_NAME} not found: run `make -C firmware` or set PLOTTER_CORE_LIB")


@dataclass(frozen=True)
class Step:
    dx: int      # -1, 0 or +1
    dy: int
    cycles: int  # machine cycles since the previous step


class FirmwareCore:
    """One simulated board: feed bytes in, run the main loop, fire step ticks."""

    def __init__(self, library: Path | None = None) -> None:
        src = Path(library) if library else find_library()
        self.library = src.resolve()
        self._tmpdir = tempfile.TemporaryDirectory(prefix="plotter-core-")
        private = Path(self._tmpdir.name) / LIB_NAME
        shutil.copyfile(src, private)
        lib = ctypes.CDLL(str(private), mode=ctypes.RTLD_LOCAL)
        for name in ("core_pos_x", "core_pos_y"):
            getattr(lib, name).restype = ctypes.c_int32
        # Only the build with a Z axis (ZAXIS=1) has its position.
        self.has_z = hasattr(lib, "core_pos_z")
        if self.has_z:
            lib.core_pos_z.restype = ctypes.c_int32
        # The board's image has the front panel; the option builds do not.
        self.has_panel = hasattr(lib, "core_panel_tick")
        # The build with line following (FOLLOW=1) has the sensors and the command F.
        self.has_follow = hasattr(lib, "core_follow_service")
        lib.core_period.restype = ctypes.c_uint
        lib.core_tx_read.restype = ctypes.c_uint32
        lib.core_seq_log_take.restype = ctypes.c_uint32
        lib.core_run_steps.restype = ctypes.c_int32
        lib.core_rx_free.restype = ctypes.c_uint32
        lib.core_line_top.restype = lib.core_arc_top.restype = ctypes.c_uint
        self._lib = lib
        self._txbuf = ctypes.create_string_buffer(8192)
        self._seqbuf = (ctypes.c_uint16 * SEQ_LOG_CAP)()
        self._seq_history: list[int] = []
        self.reset()

    def close(self) -> None:
        self._tmpdir.cleanup()

    # --- hardware side -------------------------------------------------
    def reset(self) -> None:
        """Power-on reset: clears the queue and position, prints the banner."""
        self._lib.core_reset()
        self._seq_history.clear()

    def receive(self, data: bytes) -> None:
        """Bytes arriving on the UART (real-time bytes act at once)."""
        self._lib.core_rx(data, len(data))

    def rx_free(self) -> int:
        return int(self._lib.core_rx_free())

    def poll(self, times: int = 1) -> None:
        """Run the firmware's main loop."""
        for _ in range(times):
            self._lib.core_poll()

    def transmitted(self) -> bytes:
        """Bytes the firmware sent since the last call."""
        out = bytearray()
        while True:
            n = self._lib.core_tx_read(self._txbuf, len(self._txbuf))
            out += self._txbuf.raw[:n]
            if n < len(self._txbuf):
                return bytes(out)

    def set_switches(self, x_closed: bool, y_closed: bool) -> None:
        """The limit switches at the -X and -Y ends (the board's image only)."""
        if self.has_panel:
            self._lib.core_set_switches(int(x_closed), int(y_closed))

    def panel_tick(self) -> None:
        """The front panel's 1 ms tick of the board's main loop: keys, the
        built-in figures (a serial `a` draws the star), the displays."""
        if self.has_panel:
            self._lib.core_panel_tick()

    @property
    def feed_caps(self) -> tuple[int, int]:
        """The fastest feeds (iterations/s) the board image of this build accepts for a line and
        an arc (core/ramp.h LINE_TOP, ARC_TOP)."""
        return int(self._lib.core_line_top()), int(self._lib.core_arc_top())

    def timer_running(self) -> bool:
        return bool(self._lib.core_timer_on())

    def period(self) -> int:
        """Machine cycles until the next step interrupt."""
        return int(self._lib.core_period())

    def tick(self) -> bool:
        """Fire the step interrupt once; True if a step was emitted (on any axis)."""
        if not self.has_z:
            return bool(self._lib.core_tick())
        z = self._lib.core_pos_z()
        return bool(self._lib.core_tick()) or self._lib.core_pos_z() != z

    # --- line following (core/follow.h), the caller's sheet giving the sensors -------------
    def follow_start(self, heading: int, lost_steps: int, max_steps: int, home_steps: int) -> None:
        """Start following: heading in notches of 15 degrees (0: +X), the
        stops' distances in steps (max_steps 0: no limit)."""
        self._lib.core_follow_start(ctypes.c_int(heading), ctypes.c_int(lost_steps),
                                    ctypes.c_int(max_steps), ctypes.c_int(home_steps))

    def follow_tick(self, black: int) -> int:
        """One step period with these sensor bits (bit i: sensor i on black):
        the step to make (0 +X, 1 -X, 2 +Y, 3 -Y) or a stop (0x80 and up)."""
        return int(self._lib.core_follow_tick(ctypes.c_int(black)))

    def set_sensors(self, black: int) -> None:
        """The FOLLOW build's three sensors: bit i set when sensor i reads black."""
        self._lib.core_set_sensors(ctypes.c_int(black))

    def set_follow_key(self, pressed: bool) -> None:
        """The FOLLOW build's follow key (P2.3 on the board): held for 200 main-loop passes (poll) at rest,
        it starts a follow with the last F's arguments."""
        self._lib.core_set_follow_key(ctypes.c_int(int(pressed)))

    def follow_service(self) -> None:
        """The FOLLOW build's main loop, its part in a running F: decide the
        step the next step interrupt takes, from the sensors as they are now."""
        self._lib.core_follow_service()

    @property
    def follow_mailbox(self) -> int:
        """The FOLLOW build's mailbox (core/follow.h follow_next): a decided
        step or stop the step interrupt has still to take, or FOLLOW_IDLE,
        FOLLOW_QUEUED, FOLLOW_BEGIN, FOLLOW_WAIT (0xFC..0xFF)."""
        return int(self._lib.core_follow_mailbox())

    # --- state --------------------------------------------------------
    @property
    def position(self) -> tuple[int, int]:
        return int(self._lib.core_pos_x()), int(self._lib.core_pos_y())

    @property
    def position_z(self) -> int | None:
        """Z in steps; None without a Z axis."""
        return int(self._lib.core_pos_z()) if self.has_z else None

    @property
    def pen_down(self) -> bool:
        return bool(self._lib.core_pen())

    @property
    def running(self) -> bool:
        return bool(self._lib.core_running())

    @property
    def queue_free(self) -> int:
        return int(self._lib.core_queue_free())

    @property
    def underruns(self) -> int:
        return int(self._lib.core_underruns())

    @property
    def alarm(self) -> int:
        return int(self._lib.core_alarm())

    def take_seq_log(self) -> list[int]:
        """Sequence numbers (16-bit, as on the wire) of the commands started since the last
        take, in the order they started.  The core keeps SEQ_LOG_CAP of them: take them at least
        that often."""
        n = self._lib.core_seq_log_take(self._seqbuf, SEQ_LOG_CAP)
        return list(self._seqbuf[:n])

    def collect_seq_log(self) -> None:
        """Move what the core logged into seq_log()'s history (a caller of take_seq_log keeps
        its own instead)."""
        self._seq_history.extend(self.take_seq_log())

    def seq_log(self) -> list[int]:
        """Every sequence number started since the power-on reset, in order (tests: the list
        grows with the job; SimPort collects them as it goes)."""
        self.collect_seq_log()
        return list(self._seq_history)

    def started_count(self) -> int:
        """How many commands started since the power-on reset: len(seq_log()), without the copy."""
        self.collect_seq_log()
        return len(self._seq_history)

    # --- direct planner access (tests) -------------------------------
    def plan_line(self, dx: int, dy: int, feed: int = 0, exit_rate: int = 0) -> int:
        return int(self._lib.core_plan_line(dx, dy, feed, exit_rate))

    def plan_arc(self, dx: int, dy: int, i: int, j: int, clockwise: bool,
                 feed: int = 0, exit_rate: int = 0) -> int:
        return int(self._lib.core_plan_arc(dx, dy, i, j, int(clockwise), feed, exit_rate))

    def interrupts(self, lines: Iterable[str]) -> Iterator[int]:
        """Typed command lines into the UART as the queue takes them, the main
        loop, and the step interrupt until all is done: after each interrupt,
        the machine cycles it was due after the one before (the caller reads
        the position, pen and ports in between)."""
        pending = list(lines)
        while True:
            while pending and self.queue_free:
                self.receive(pending.pop(0).encode() + b"\n")
                self.poll(3)
            self.poll()
            if not self.timer_running():
                if not pending:
                    return
                continue
            due = self.period()
            self.tick()
            yield due

    def run_steps(self, capacity: int = 1_000_000) -> list[Step]:
        """Run everything queued to the end in simulated time; every step taken."""
        buf = (ctypes.c_int32 * (3 * capacity))()
        n = self._lib.core_run_steps(buf, capacity)
        if n < 0:
            raise OverflowError("more steps than capacity")
        return [Step(buf[3 * k], buf[3 * k + 1], buf[3 * k + 2]) for k in range(n)]

    def run_steps_packed(self, capacity: int) -> memoryview:
        """run_steps without an object per step, for callers that measure
        millions of them: dx, dy, cycles of each step in turn, as int32."""
        buf = (ctypes.c_int32 * (3 * capacity))()
        n = self._lib.core_run_steps(buf, capacity)
        if n < 0:
            raise OverflowError("more steps than capacity")
        return memoryview(buf).cast("B").cast("i")[:3 * n]
