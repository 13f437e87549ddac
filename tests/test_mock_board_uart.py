"""The mock board's serial line at the baud rate, on times the test chooses
(no real-time waits): bytes in both directions take 10 bit times each, idle
time is not saved up, and the main loop waits while the 16-byte transmit
ring is full, as on the 8051."""
import pytest

from firmware_build import host_library
from plotter_bridge.sim.firmware_core import FirmwareCore
from plotter_bridge.sim.mock_board import TX_SIZE, MockBoard, MockBoardConfig
from plotter_bridge.link.protocol import machine_line
from plotter_bridge.sim.uart import PacedLine

BYTE_9600 = 10 / 9600


def test_paced_line_sends_one_byte_per_ten_bit_times():
    line = PacedLine(9600)
    line.push(b"abc\n", 1.0)
    assert line.pop_due(1.0 + 0.5 * BYTE_9600) == b""
    assert line.pop_due(1.0 + 2.01 * BYTE_9600) == b"ab"
    assert line.due(b"\n") == pytest.approx(1.0 + 4 * BYTE_9600)
    assert line.pop_due(5.0) == b"c\n"
    # Idle time is not saved up: bytes handed over later start then.
    line.push(b"xy", 9.0)
    assert line.pop_due(9.0 + 1.5 * BYTE_9600) == b"x"
    assert line.due() == pytest.approx(9.0 + 2 * BYTE_9600)


def test_paced_line_queues_behind_bytes_still_on_the_wire():
    line = PacedLine(9600)
    line.push(b"12345", 0.0)
    line.push(b"6", 0.001)                      # the wire is still busy with the first five
    assert line.due(b"6") == pytest.approx(6 * BYTE_9600)
    assert line.pop_due(10.0) == b"123456"


@pytest.fixture
def board():
    b = MockBoard(MockBoardConfig(baud=9600, cpu=False), FirmwareCore(host_library()))
    yield b
    b.close()


def test_the_mock_boards_main_loop_takes_a_line_as_long_as_the_chip():
    """With the chip's CPU charged (the default), a line is queued and
    answered BoardCpu.command_cycles after its line end arrives, at rest,
    and the next line waits for the main loop to be done with it."""
    from plotter_bridge.motion.planner import BOARD_CPU
    from plotter_bridge.sim.firmware_core import CYCLES_PER_S
    b = MockBoard(MockBoardConfig(baud=115200), FirmwareCore(host_library()))
    try:
        b.core.transmitted()
        b.rx.push(b"!!" + machine_line(0, "L 10 0") + machine_line(1, "L 10 0"), 0.0)
        parse = BOARD_CPU.command_cycles / CYCLES_PER_S
        end0 = b.rx.due(b"\n")
        b._serial(end0)
        assert b.core.queue_free == 6 and not b.core.transmitted()
        b._serial(end0 + 0.999 * parse)
        assert b.core.queue_free == 6
        b._serial(end0 + parse)
        assert b.core.queue_free == 5
        assert b.core.rx_free() < 64                        # the second arrived meanwhile, and waits
        b._serial(end0 + 1.999 * parse)
        assert b.core.queue_free == 5
        b._serial(end0 + 2 * parse)
        assert b.core.queue_free == 4
        sent = bytes(b._tx_out) + b.tx.pop_due(10.0)
        assert b"ok N0" in sent and b"ok N1" in sent
    finally:
        b.close()


def test_mock_board_replies_at_the_baud_rate(board):
    """A status report and two acknowledgements leave byte by byte, and while
    they fill the transmit ring a line that arrives waits in the receive ring.
    (A pass of the host build's main loop cannot stop half-way, so the line
    that arrived with the report is parsed in the same pass.)"""
    board.core.transmitted()                                       # the banner
    board.rx.push(b"?" + machine_line(0, "L 10 0") + machine_line(1, "L 10 0"), 0.0)
    first = board.rx.due(b"\n")
    board._serial(first)
    assert len(board.tx) > TX_SIZE + 1
    second = board.rx.due(b"\n")
    board._serial(second)
    assert board.core.rx_free() < 64                                # waits: the ring still holds it
    t, sent = second, b""
    while b"ok N1" not in sent:
        t += BYTE_9600
        board._main_loop(t)
        sent += bytes(board._tx_out)
        board._tx_out.clear()
    report, first_ok = sent.split(b"\r\n")[:2]
    assert report.startswith(b"<Idle") and first_ok.startswith(b"ok N0")
    # Parsed only once all but 17 bytes of the report and the first reply had left.
    assert t >= first + (len(report) + len(first_ok) + 4 - TX_SIZE - 1) * BYTE_9600 - 1e-9


def test_a_serial_a_draws_the_star_on_the_mock_board(tmp_path):
    """The mock board runs the board's image, front panel included: its
    main loop ticks the panel every millisecond, so a single `a` between
    lines draws the built-in star (seed 000, 4.3) as the 8051 does: every
    step of its trace within one step of the figure (its strokes and its
    pen-up travel), and back where it began."""
    import sys

    from firmware_build import FIRMWARE
    from panel_keys import distance, figure_segments
    sys.path.insert(0, str(FIRMWARE / "tools"))
    import gen_figures

    trace_path = tmp_path / "steps.csv"
    b = MockBoard(MockBoardConfig(baud=9600, trace=str(trace_path)), FirmwareCore(host_library()))
    try:
        b.rx.push(b"a", 0.0)
        t = 0.0
        while t < 30.0 and (t < 0.1 or b.core.timer_running()):
            t += 0.002
            b._serial(t)
            b._run_steps(t)
        assert not b.core.timer_running(), "still drawing after 30 s"
    finally:
        b.close()
    trace = [tuple(int(v) for v in line.split(",")[1:]) for line in trace_path.read_text().splitlines()[1:]]
    segments = figure_segments(gen_figures.all_figures()["FIG_STAR"])
    assert len(trace) > 1000, len(trace)
    for p in trace:
        assert min(distance(p, s) for s in segments) <= 1.0, p
    assert trace[-1] == (0, 0)


def test_stop_leaves_the_core_alone_while_the_loop_is_still_in_it(monkeypatch):
    """A loop that does not stop in time keeps its core and pty: closing them
    under it would put two threads in the C core."""
    import threading
    import plotter_bridge.sim.mock_board as mock_board
    b = MockBoard(MockBoardConfig(baud=9600), FirmwareCore(host_library()))
    inside, release = threading.Event(), threading.Event()
    run_steps = b._run_steps

    def stuck(now):
        inside.set()
        release.wait(30)
        run_steps(now)
    monkeypatch.setattr(b, "_run_steps", stuck)
    monkeypatch.setattr(mock_board, "STOP_WAIT_S", 0.2)
    b.start()
    try:
        assert inside.wait(10)
        with pytest.raises(RuntimeError, match="did not stop"):
            b.stop()
        assert b.connected, "the pty was closed under the running loop"
    finally:
        release.set()
        b.stop()
    assert not b.connected
