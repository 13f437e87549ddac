"""Faults on the serial line against the bridge's session (BoardSession) and
the firmware core, on simulated time (tests/reliability_sim.py): no ROS, no pty.

Each job's commands are compared with the board's own log of the sequence
numbers it started (FirmwareCore.seq_log): every one exactly once, in order.
"""
import pytest

from firmware_build import host_library
from plotter_bridge.sim.faults import FaultSpec, FaultyChannel, parse_faults
from reliability_sim import fault_run, random_job


# --- the fault specification and channel -------------------------------------------

def test_parse_faults():
    spec = parse_faults("drop=0.01, corrupt=0.01,dup=0.001,delay=0.002,delay_ms=20,seed=7,unplug_at=500")
    assert spec == FaultSpec(drop=0.01, corrupt=0.01, dup=0.001, delay=0.002, delay_ms=20, seed=7,
                             unplug_at=500)
    assert parse_faults("") == FaultSpec()
    assert str(parse_faults("drop=0.5")) == "drop=0.5"
    for bad, word in (("drop", "key=value"), ("drip=0.1", "key=value"), ("drop=x", "not a number"),
                      ("drop=0.9", "outside"), ("drop=nan", "outside"), ("seed=1.5", "not a number"),
                      ("drop=0.1,drop=0.2", "twice"), ("reset_at=-3", "negative")):
        with pytest.raises(ValueError, match=word):
            parse_faults(bad)


def test_faulty_channel_is_seeded_counts_and_keeps_order():
    spec = FaultSpec(drop=0.05, corrupt=0.05, dup=0.05, delay=0.05, delay_ms=10, seed=3)
    data = bytes(range(256)) * 40
    runs = []
    for _ in range(2):
        ch = FaultyChannel(spec, 0)
        ch.send(data, 0.0)
        assert ch.receive(0.0) != b"" or ch.counts.delayed
        out = ch.receive(0.0)
        runs.append((ch.counts, ch.receive(10.0)))
    assert runs[0] == runs[1], "same seed, same faults"
    counts = runs[0][0]
    assert counts.bytes == len(data)
    for n in (counts.dropped, counts.corrupted, counts.duplicated, counts.delayed):
        assert 0.03 * len(data) < n < 0.07 * len(data)
    clean = FaultyChannel(FaultSpec(delay=1.0 / 3, delay_ms=5), 1)
    clean.send(b"abcdef", 0.0)
    got = clean.receive(0.0)
    got += clean.receive(1.0)
    assert got == b"abcdef" and clean.counts.delayed > 0
    # Dropped, doubled and held back, the bytes that come out come in the order they went in.
    ordered = FaultyChannel(FaultSpec(drop=0.1, dup=0.1, delay=0.1, delay_ms=10, seed=5), 2)
    ordered.send(bytes(range(256)), 0.0)
    got = ordered.receive(0.0) + ordered.receive(1.0)
    assert min(ordered.counts.dropped, ordered.counts.duplicated, ordered.counts.delayed) > 10
    assert list(got) == sorted(got), "a byte overtook an earlier one"
    assert len(set(got)) == 256 - ordered.counts.dropped
    assert len(got) == 256 - ordered.counts.dropped + ordered.counts.duplicated
    del out


# --- 1,000 segments through noise ------------------------------------------------------

@pytest.mark.parametrize("faults", ["drop=0.001,corrupt=0.001,dup=0.001,delay=0.001",
                                    "drop=0.01,corrupt=0.01,dup=0.001,delay=0.001"])
def test_thousand_segments_through_noise_exact_and_once(faults):
    fig = fault_run(parse_faults(faults), 1000, library=host_library())
    assert fig.injected.dropped > 0 and fig.injected.corrupted > 0
    assert fig.completed, "the job ended successfully"
    assert fig.exact, "final position exact to the step"
    assert fig.once_in_order, "every segment executed exactly once, in order"
    assert fig.retransmissions > 0


# --- the port vanishes and comes back --------------------------------------------------

def test_port_unplugged_mid_job_resumes_exactly(rig):
    commands, end = random_job(300, seed=4)
    job = rig.start(commands)
    assert rig.run_until(lambda: job.started > 100, 120)
    rig.port.unplug()
    assert rig.run_until(lambda: rig.session.connection == "disconnected", 1)
    rig.run_until(lambda: False, 3.0)                 # away for 3 s; the board runs its queue dry
    assert rig.session.connection == "disconnected" and job.result is None
    rig.port.replug()
    assert rig.run_until(lambda: job.result is not None, 300)
    assert job.result.success, job.result.message
    assert rig.core.position == end
    assert rig.executed_of(job) == list(range(len(commands)))
    assert rig.session.position_known
    assert any("port back" in line for line in rig.log)


def test_port_away_too_long_aborts_the_job_cleanly(rig):
    rig.session.config.reconnect_timeout = 2.0
    commands, _ = random_job(200, seed=5)
    job = rig.start(commands)
    assert rig.run_until(lambda: job.started > 5, 60)
    rig.port.unplug()
    assert rig.run_until(lambda: job.result is not None, 10)
    assert not job.result.success and "port lost" in job.result.message
    rig.port.replug()
    assert rig.run_until(lambda: rig.session.connection == "connected", 5)
    before = len(rig.port.steps)
    rig.run_until(lambda: False, 2.0)
    assert len(rig.port.steps) == before, "nothing of the aborted job runs after the port is back"
    executed = rig.executed_of(job)
    assert executed == list(range(len(executed))), "what ran, ran once and in order"
    # The link is usable again: a new job runs from where the pen is.
    x, y = rig.core.position
    job2 = rig.start(["L 100 0 4000 0", "L 0 100 4000 0"])
    assert rig.run_until(lambda: job2.result is not None, 30) and job2.result.success
    assert rig.core.position == (x + 100, y + 100)


# --- the board resets -------------------------------------------------------------------

def test_board_reset_mid_job_aborts_and_marks_position_unknown(rig):
    commands, _ = random_job(200, seed=6)
    job = rig.start(commands)
    assert rig.run_until(lambda: job.started > 50, 120)
    rig.core.reset()                                   # power blip: banner, position 0, queue empty
    assert rig.run_until(lambda: job.result is not None, 5)
    assert not job.result.success and "board reset" in job.result.message
    assert "position is unknown" in job.result.message
    assert not rig.session.position_known
    assert rig.core.seq_log() == [], "nothing ran after the reset"
    rig.run_until(lambda: False, 2.0)
    assert rig.core.seq_log() == [] and rig.core.position == (0, 0)
    refused = rig.session.start_job(["L 10 0"], [1])
    assert refused.result is not None and "set the origin" in refused.result.message
    ok, _ = _call(rig, lambda: rig.session.set_origin(timeout=0))
    assert rig.run_until(lambda: rig.session.position_known, 2)


def test_board_reset_while_unplugged_is_detected_without_its_banner(rig):
    commands, _ = random_job(200, seed=7)
    job = rig.start(commands)
    assert rig.run_until(lambda: job.started > 30, 60)
    rig.port.unplug()
    rig.run_until(lambda: False, 0.5)
    rig.core.reset()                                   # the banner is lost with the port
    rig.run_until(lambda: False, 0.5)
    rig.port.replug()
    assert rig.run_until(lambda: job.result is not None, 5)
    assert not job.result.success and "board reset" in job.result.message
    assert not rig.session.position_known
    rig.run_until(lambda: False, 1.0)
    assert rig.core.seq_log() == [], "no line of the old job reached the new board"


# --- emergency stop and cancel ---------------------------------------------------

def test_estop_mid_job_stops_at_once_and_needs_a_reset(rig):
    commands, _ = random_job(100, seed=8)
    job = rig.start(commands)
    assert rig.run_until(lambda: job.started > 10 and rig.core.running, 60)
    rig.session.realtime("estop", timeout=0)
    rig.step(0.0005)
    assert not rig.core.running and rig.core.alarm == 1
    assert rig.run_until(lambda: job.result is not None, 2)
    assert not job.result.success and "emergency stop" in job.result.message
    n, pos = len(rig.port.steps), rig.core.position
    log = rig.core.seq_log()
    rig.run_until(lambda: False, 2.0)
    assert len(rig.port.steps) == n and rig.core.position == pos and rig.core.seq_log() == log
    refused = rig.session.start_job(["L 10 0"], [1])
    assert "alarm" in refused.result.message
    rig.session.realtime("reset", timeout=0)
    assert rig.run_until(lambda: rig.session.link.status.state == "Idle", 2)
    assert rig.session.position_known, "an e-stop keeps the position"
    job2 = rig.start(["L 10 0 2000 0"])
    assert rig.run_until(lambda: job2.result is not None, 10) and job2.result.success
    assert rig.core.position == (pos[0] + 10, pos[1])


def test_estop_byte_lost_in_noise_is_sent_again(rig):
    lost = []

    def swallow_esc(data: bytes) -> bytes:
        if b"\x1b" in data and len(lost) < 3:
            lost.append(data)
            return data.replace(b"\x1b", b"")
        return data

    rig.port._to_board = swallow_esc
    job = rig.start(random_job(50, seed=11)[0])
    assert rig.run_until(lambda: rig.core.running, 10)
    rig.session.realtime("estop", timeout=0)
    assert rig.run_until(lambda: rig.core.alarm == 1, 2)
    assert len(lost) == 3, "the first three were lost, the fourth arrived"
    assert rig.run_until(lambda: job.result is not None, 2)


def test_cancel_stops_where_it_is_and_keeps_the_position(rig):
    commands, _ = random_job(100, seed=9)
    job = rig.start(commands)
    assert rig.run_until(lambda: job.started > 10, 60)
    rig.session._fail(job, "canceled", stop=True)
    assert rig.run_until(lambda: job.result is not None, 10)
    assert job.result.message == "canceled"
    n = len(rig.port.steps)
    rig.run_until(lambda: False, 1.0)
    assert len(rig.port.steps) == n
    assert rig.session.link.status.state == "Idle" and rig.session.position_known


def _call(rig, fn):
    result = fn()
    rig.run_until(lambda: False, 0.1)
    return result
