#!/usr/bin/env python3
"""Run the 8051 image in the uCsim simulator s51 and talk to it.

Used by tools/bench.py and tests/test_firmware_sim.py.  The simulated board:

- s51 -t 8052 -X 11.0592M, the STC89C52RC's clock: one machine cycle is
  12 clocks, CYCLE_PS picoseconds.  A chip in 6-clock mode (make CPU6T=1)
  runs as s51 does at twice the crystal, CLOCK_HZ_6T: s51 knows only 12
  clocks a cycle;
- its 256 bytes of XRAM at every page of the xram space, as MOVX @Ri
  reaches them on the chip whatever P2 holds;
- its UART on two pseudo-terminals in raw mode (`-S in=...,out=...`), polled
  often (`uart0_check_often=1`) so that typed lines arrive whole: at every
  instruction in s51 itself, every 20 us of host time with tools/s51_poll.c
  preloaded (poll_shim), which makes it five times faster; and
  with s51's flow control on (`uart0_flowctrl=1`): the pty's next byte is
  taken only once the firmware has read SBUF.  Without it s51 loses bytes
  the chip never would: every 10000 instructions its command loop polls the
  pty too, and a byte it reads there while a frame is still arriving is
  dropped, more often on a busy machine (a host's adapter sends back to
  back at the baud rate and the chip loses none; tests/test_firmware_link.py
  writes bursts of lines to show that none is lost).  The pty's raw
  Ctrl-X, the reset byte, also stops being s51's escape to its menu.  But
  bytes still waiting when the simulation stops (at a breakpoint) then keep
  s51's command loop on the pty and away from the command port for good: a
  host that writes more than the firmware takes before such a stop (a
  stream beside a run) turns flow control off first (Sim.flow_control).
  Written to a stopped simulation, Sim.write hands over one byte at a time,
  each once the firmware has read the one before;
- a stopped simulation run in bounded steps (Sim.run_for, Sim.read_until):
  a `stop` after `go` waits for s51's next look at its command port, a
  million instructions away, where `step N` stops at once;
- the simulator's command line on a local TCP port (`-Z`), prompt a NUL
  byte (`-P`), no colours (`-b`);
- optionally a VCD recording of port 1 (the step/direction/pen port) and of
  PSW.3, the register-bank bit that only the step interrupt sets: it is 1
  from the interrupt's `mov psw,#0x08` to its `pop psw`; more signals on
  request (port 2 for the Y windings of the phase-drive builds).

Addresses come from the linker's map (global symbols) and the relocated
listings build/mcs51/*.rst (static symbols and instructions).
"""
import fcntl
import os
import pty
import re
import select
import shutil
import socket
import subprocess
import tempfile
import threading
import time
import tty
from pathlib import Path

CLOCK_HZ = 11_059_200
CLOCK_HZ_6T = 2 * CLOCK_HZ
CYCLE_PS = 12 * 10**12 / CLOCK_HZ          # one machine cycle in picoseconds

FIRMWARE = Path(__file__).resolve().parent.parent

# Bounded runs of a stopped simulation (Sim.run_for, Sim.read_until, and
# Sim.write's waits): s51 stops after a `step N` at once, where a `stop`
# waits for its next look at the command port, a million instructions away.
# CHUNK instructions are some 40-90 ms of simulated time, BYTE_INSTRUCTIONS
# about a byte time at 9600 baud (960 machine cycles; an instruction takes
# one to four, most one or two).
CHUNK = 50_000
STEP_MAX = 500_000
BYTE_INSTRUCTIONS = 1_000


def s51_path():
    return shutil.which("s51")


def poll_shim():
    """build/tools/s51_poll.so, compiled from tools/s51_poll.c when missing or
    older than it (one process at a time), or None where there is no C compiler:
    s51 then polls its UART at every instruction and answers its console slowly
    (tools/s51_poll.c says how much)."""
    source = FIRMWARE / "tools" / "s51_poll.c"
    lib = FIRMWARE / "build" / "tools" / "s51_poll.so"
    compiler = shutil.which(os.environ.get("CC", "cc")) or shutil.which("gcc")
    if lib.exists() and lib.stat().st_mtime >= source.stat().st_mtime:
        return lib
    if compiler is None:
        return None
    lib.parent.mkdir(parents=True, exist_ok=True)
    with open(source) as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not lib.exists() or lib.stat().st_mtime < source.stat().st_mtime:
            part = lib.with_suffix(f".{os.getpid()}.so")
            subprocess.run([compiler, "-O2", "-shared", "-fPIC", "-o", str(part), str(source), "-ldl"], check=True)
            os.replace(part, lib)
    return lib


class Symbols:
    """Addresses of the image's symbols: globals from the .map, statics and
    code labels from the .rst listings."""

    def __init__(self, base):
        base = Path(base)
        self.addr = {}
        for line in open(base.with_suffix(".map")):
            m = re.match(r"\s*(?:[A-Z]:\s+)?([0-9A-F]{8})\s+(_\w+)\s+\w+\s*$", line)
            if m:
                self.addr.setdefault(m.group(2), int(m.group(1), 16))
        self.rst = {}
        for rst in sorted((base.parent / "mcs51").glob("*.rst")):
            self.rst[rst.stem] = rst.read_text(errors="replace").splitlines()
            for line in self.rst[rst.stem]:
                m = re.match(r"\s+([0-9A-F]{6})\s+\d+\s+(_\w+):\s*$", line)
                if m:
                    self.addr.setdefault(m.group(2), int(m.group(1), 16))

    def __getitem__(self, name):
        return self.addr[name]

    def instructions(self, module, label, mnemonic, operands=None):
        """Addresses of the instructions `mnemonic` (with exactly these
        operands, if given) in function `label` of module."""
        out, inside = [], False
        for line in self.rst[module]:
            m = re.match(r"\s+([0-9A-F]{6})\s+\d+\s+(_\w+):\s*$", line)
            if m:
                inside = m.group(2) == label
                continue
            m = re.match(r"\s+([0-9A-F]{6})\s+(?:[0-9A-F]{2}\s)+\s*\[\d+\]\s+\d+\s+(\w+)\s*([^;\s]*)", line)
            if inside and m and m.group(2) == mnemonic and operands in (None, m.group(3)):
                out.append(int(m.group(1), 16))
        return out


class Sim:
    """One simulated board.  Use as a context manager."""

    def __init__(self, base=FIRMWARE / "build" / "plotter", vcd=None, timeout=30.0, extra_signals=(),
                 clock_hz=CLOCK_HZ):
        self.base = Path(base)
        self.clock_hz = clock_hz
        self.sym = Symbols(self.base)
        self.timeout = timeout
        self._pty = []
        self.rx_master, rx_name = self._raw_pty()     # we write, the board's UART reads
        self.tx_master, tx_name = self._raw_pty()     # the board's UART writes, we read
        sock = socket.socket()
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
        sock.close()
        env = dict(os.environ)
        shim = None if os.environ.get("PLOTTER_S51_SHIM") == "0" else poll_shim()
        if shim:
            env["LD_PRELOAD"] = " ".join(filter(None, (str(shim), env.get("LD_PRELOAD"))))
        self.proc = subprocess.Popen(
            ["s51", "-b", "-P", "-t", "8052", "-X", str(clock_hz), "-C", str(self._chip_xram_commands()),
             "-S", f"in={rx_name},out={tx_name}", "-Z", str(port),
             str(self.base.with_suffix(".ihx"))],
            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
        deadline = time.time() + 10
        while True:
            try:
                self.sock = socket.create_connection(("127.0.0.1", port))
                break
            except OSError:
                if time.time() > deadline or self.proc.poll() is not None:
                    raise RuntimeError("s51 did not open its command port")
                time.sleep(0.05)
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._con = b""
        self._ser = b""
        self.running = False
        self._until_con(rb"details\.\r\n\x00")
        self.cmd("expr uart0_check_often=1")
        self.flow_control(True)
        self.vcd = vcd
        if vcd:
            self.cmd(f'set hw vcd[0] output "{vcd}"')
            self.cmd("set hw vcd[0] add sfr[0x90]")
            self.cmd("set hw vcd[0] add sfr[0xd0].3")
            for signal in extra_signals:      # e.g. "sfr[0xa0]", port 2
                self.cmd(f"set hw vcd[0] add {signal}")

    @staticmethod
    def _chip_xram_commands():
        """A command file for s51 -C: the chip's 256 bytes of XRAM at every
        page of s51's xram.  MOVX @Ri (the image's __pdata) reaches the
        STC89C52RC's on-chip XRAM at Ri whatever P2 holds, while s51's 8052
        takes P2 as the high byte, and the keypad scan and the phase drives
        write P2."""
        path = Path(tempfile.gettempdir()) / f"s51-stc89-xram-{os.getpid()}.cmd"
        if not path.exists():
            part = path.with_suffix(f".{threading.get_ident()}")
            part.write_text("".join(f"memory create addressdecoder xram 0x{page:02x}00 0x{page:02x}ff "
                                    f"xram_chip 0x0000\n" for page in range(1, 256)))
            os.replace(part, path)
        return path

    def _raw_pty(self):
        master, slave = pty.openpty()
        tty.setraw(master)
        tty.setraw(slave)
        self._pty += [master, slave]
        return master, os.ttyname(slave)

    # --- simulator command line ------------------------------------------
    def _until_con(self, pattern, timeout=None):
        deadline = time.time() + (timeout or self.timeout)
        while True:
            m = re.search(pattern, self._con, re.S)
            if m:
                out, self._con = self._con[:m.end()], self._con[m.end():]
                return out.decode(errors="replace")
            if time.time() > deadline:
                raise TimeoutError(f"s51 console: waiting for {pattern!r}, got {self._con[-300:]!r}")
            r, _, _ = select.select([self.sock], [], [], 0.02)
            if r:
                data = self.sock.recv(65536)
                if not data:
                    raise RuntimeError("s51 closed its command port")
                self._con += data

    def cmd(self, text, timeout=None):
        """A command while the simulation is stopped; its output."""
        assert not self.running, "stop the simulation first"
        self.sock.sendall(text.encode() + b"\n")
        return self._until_con(rb"\x00", timeout)

    def go(self):
        """Let the simulation run (in the background), until stop()."""
        self.sock.sendall(b"go\n")
        self._until_con(rb"Simulation started[^\n]*\n")
        self.running = True

    def stop(self):
        """Stop a simulation let run by go().  Slow: s51 reads its command
        port once a million instructions while it runs (1-3 s of host time);
        a stopped simulation run in bounded steps (run_for, read_until) needs
        none."""
        if not self.running:
            return ""
        self.sock.sendall(b"stop\n")
        out = self._until_con(rb"Stop at.*?\x00")
        self.running = False
        return out

    def _step(self, instructions):
        """Run `instructions` instructions of the stopped simulation; the
        text of the stop.  A breakpoint on the way stops it there."""
        assert not self.running, "stop the simulation first"
        self.sock.sendall(f"step {instructions}\n".encode())
        try:
            return self._until_con(rb"Stop at.*?\x00")
        except TimeoutError as e:
            raise TimeoutError(f"{e} (a bounded run that does not end: bytes written to the UART "
                               f"while the simulation was stopped, past s51sim.Sim.write?)") from None

    def run_for(self, seconds=None, instructions=None):
        """Run the stopped simulation for at least `seconds` of simulated time
        (or exactly `instructions` instructions) and leave it stopped at once,
        without the wait of stop(): an instruction takes one to four machine
        cycles, so up to four times as long as asked in simulated time.  A
        breakpoint on the way ends it early (the stop text says which)."""
        if instructions is None:
            instructions = max(1, round(seconds * self.clock_hz / 12))
        out = ""
        while instructions > 0:
            n = min(instructions, STEP_MAX)
            out = self._step(n)
            instructions -= n
            if "stepped" not in out:
                break
        self._drain_serial()
        return out

    def run_to(self, addr, timeout=None):
        """Run until the instruction at addr is about to execute."""
        self.cmd(f"tbreak 0x{addr:x}")
        self.sock.sendall(b"go\n")
        self.running = True
        out = self._until_con(rb"Stop at.*?\x00", timeout)
        self.running = False
        return out

    def wait_stop(self, timeout=None):
        """Wait, while it runs, until the simulation stops at a breakpoint."""
        assert self.running, "the simulation is not running"
        out = self._until_con(rb"Stop at.*?\x00", timeout)
        self.running = False
        return out

    def ticks(self):
        """Clock ticks since reset (12 per machine cycle)."""
        m = re.search(r"\((\d+) clks\)", self.cmd("state"))
        return int(m.group(1))

    def max_sp(self):
        m = re.search(r"Max value of stack pointer= 0x([0-9a-f]+)", self.cmd("state"))
        return int(m.group(1), 16)

    def dump(self, space, addr, n):
        """n bytes of a memory space ("iram", "xram") from addr."""
        out = self.cmd(f"dump {space} 0x{addr:x} 0x{addr + n - 1:x}")
        data = []
        for line in out.splitlines():
            m = re.match(r"\s*0x[0-9a-f]+((?:\s+[0-9a-f]{2})+)", line)
            if m:
                data += [int(v, 16) for v in m.group(1).split()]
        return bytes(data[:n])

    def sfr(self, addr):
        """The special function register at addr (s51 dumps it by name, in binary and hex)."""
        out = self.cmd(f"dump sfr 0x{addr:x} 0x{addr:x}")
        return int(re.search(r"0b[01]{8} 0x([0-9a-f]{2})", out).group(1), 16)

    def iram(self, addr, n):
        return self.dump("iram", addr, n)

    def set_iram(self, addr, data):
        self.cmd(f"set memory iram 0x{addr:x} " + " ".join(f"0x{b:02x}" for b in data))

    def fetches(self, lo, hi):
        """{address: how many times the byte there was read}, over lo..hi, since
        the simulation started (s51's per-address statistic of the code memory):
        at an instruction's first byte, how many times it ran."""
        out = self.cmd(f"statistic rom 0x{lo:x} 0x{hi:x}")
        return {int(a, 16): int(n) for a, n in
                re.findall(r"rom\[0x([0-9a-f]+)\]\s+writes=\s*\d+\s+\([^)]*\)\s+reads=\s*(\d+)", out)}

    def int32(self, name):
        return int.from_bytes(self.iram(self.sym[name], 4), "little", signed=True)

    def flow_control(self, on):
        """s51's UART flow control (the module's docstring says why it is on)."""
        self.cmd(f"expr uart0_flowctrl={int(on)}")

    def vcd_start(self):
        self.cmd("set hw vcd[0] start")

    def vcd_stop(self):
        self.cmd("set hw vcd[0] stop")

    # --- the board's UART --------------------------------------------------
    def write(self, data):
        """Bytes to the board's UART.  Written to a stopped simulation, each
        waits (the simulation runs meanwhile, in steps of a byte time) until
        the firmware has read the one before it (s51's flow control lets the
        UART take a byte then): s51 takes it in at once, stopped, and a byte it
        could not take would keep it from its command port for good (the
        module's docstring)."""
        if self.running:
            os.write(self.rx_master, data)
            return
        deadline = time.time() + self.timeout
        for byte in data:
            while self.cmd("expr uart0_able_receive").split()[-2:-1] != ["1"]:
                if time.time() > deadline:
                    raise TimeoutError(f"serial: the firmware reads no byte (writing {data!r})")
                self._step(BYTE_INSTRUCTIONS)
            os.write(self.rx_master, bytes([byte]))

    def _drain_serial(self):
        while select.select([self.tx_master], [], [], 0)[0]:
            self._ser += os.read(self.tx_master, 4096)

    def read_until(self, pattern, timeout=None):
        """Serial output up to and including the first match of pattern.  A
        stopped simulation is run meanwhile in bounded steps (CHUNK
        instructions) and left stopped within one of the match."""
        deadline = time.time() + (timeout or self.timeout)
        while True:
            m = re.search(pattern, self._ser, re.S)
            if m:
                out, self._ser = self._ser[:m.end()], self._ser[m.end():]
                return out
            if time.time() > deadline:
                raise TimeoutError(f"serial: waiting for {pattern!r}, got {self._ser[-300:]!r}")
            if self.running:
                r, _, _ = select.select([self.tx_master], [], [], 0.02)
                if r:
                    self._ser += os.read(self.tx_master, 4096)
            else:
                stop = self._step(CHUNK)        # whole: its stop text must not answer a later command
                self._drain_serial()
                if "stepped" not in stop:
                    raise RuntimeError(f"serial: waiting for {pattern!r}, the simulation stopped: {stop[:200]!r}")

    def line(self, text, timeout=None):
        """Send one command line, return the reply line (without CR LF)."""
        self.write(text.encode() + b"\n")
        return self.read_until(rb"(?:ok|err|rs)[^\r\n]*\r\n", timeout).decode().strip().splitlines()[-1]

    def close(self):
        try:
            self.sock.sendall(b"quit\n")
        except OSError:
            pass
        try:
            self.proc.wait(2)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        self.sock.close()
        for fd in self._pty:
            os.close(fd)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def read_vcd(path):
    """{signal name: [(time in ps, value as int), ...]} of a uCsim VCD file."""
    ids, events, t = {}, {}, 0
    with open(path) as f:
        for line in f:
            line = line.strip()
            if line.startswith("$var"):
                parts = line.split()
                ids[parts[3]] = parts[4]
                events[parts[4]] = []
            elif line.startswith("#"):
                t = int(line[1:])
            elif line.startswith("b"):
                value, ident = line[1:].split()
                if "x" not in value:
                    events[ids[ident]].append((t, int(value, 2)))
            elif line and line[0] in "01" and line[1:] in ids:
                events[ids[line[1:]]].append((t, int(line[0])))
    return events


def cycles(ps, clock_hz=CLOCK_HZ):
    """Machine cycles in ps picoseconds of s51 run at clock_hz."""
    return ps * clock_hz / (12 * 10**12)
