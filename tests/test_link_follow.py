"""The host's side of line following (link/follow.py, link/protocol.py): a
goal in mm and degrees as the board's `F`, every reason a goal is refused
given at once, and the follow fields of a FOLLOW=1 board's status report."""
import re
from pathlib import Path

import pytest

from plotter_bridge.link.follow import (FollowError, FollowGoal, FollowTrack, follow_command, follow_state_name,
                                        goal_or_defaults)
from plotter_bridge.link.protocol import Status, checksum, parse_reply

FIRMWARE = Path(__file__).resolve().parent.parent / "firmware"


def signed(body: str) -> str:
    return f"{body} *{checksum(body + ' ')}"


@pytest.mark.parametrize("goal, spm, command", [
    (FollowGoal(), 80.0, "F 0 400 0 280"),
    (FollowGoal(heading_deg=90.0, feed_mm_s=2.5, lost_mm=4.0, distance_mm=100.0, gate_mm=3.0), 80.0,
     "F 6 320 8000 240 200"),
    (FollowGoal(heading_deg=-97.0), 80.0, "F 18 400 0 280"),       # the nearest of the 24 headings
    (FollowGoal(heading_deg=352.6, feed_mm_s=1.0), 100.0, "F 0 500 0 350 100"),
])
def test_a_goal_becomes_the_boards_f(goal, spm, command):
    assert follow_command(goal, spm) == command


def test_a_bad_goal_is_refused_with_every_reason():
    goal = FollowGoal(heading_deg=float("nan"), feed_mm_s=5.0, lost_mm=-1.0, distance_mm=900.0, gate_mm=300.0)
    with pytest.raises(FollowError) as err:
        follow_command(goal, 80.0)
    text = str(err.value)
    for what in ("heading", "lost distance", "distance 900 mm is 72000 steps", "gate 300 mm",
                 "feed 5 mm/s is 400 steps/s: the board follows at 15 to 250 steps/s"):
        assert what in text


@pytest.mark.parametrize("goal, what", [
    (FollowGoal(lost_mm=0.001), "less than a step"),
    (FollowGoal(feed_mm_s=0.1), "feed 0.1 mm/s is 8 steps/s"),
    (FollowGoal(feed_mm_s=-1.0), "feed must be"),
])
def test_goals_the_board_cannot_run(goal, what):
    with pytest.raises(FollowError, match=what):
        follow_command(goal, 80.0)


def test_the_status_of_a_follow_board_is_read_and_of_others_as_before():
    follow = parse_reply(signed("<Idle X1200 Y-40 Q6 N0 S0 P0 U0 A0 B7 F2 W15230>"))
    assert follow == Status("Idle", 1200, -40, 6, 0, 0, False, 0, 0, None, 7, 2, 15230)
    assert follow_state_name(follow.follow) == "home"
    plain = parse_reply(signed("<Run X12 Y-3 Q4 N18 S17 P1 U0 A0>"))
    assert plain == Status("Run", 12, -3, 4, 18, 17, True, 0, 0) and plain.sensors is None
    assert parse_reply(signed("<Idle X0 Y0 Q6 N0 S0 P0 U0 A0 B9 F2 W1>")) is None   # three sensors: 0..7


def test_a_job_with_a_follow_has_no_end_the_session_can_foretell():
    from plotter_bridge.link.board_session import displacement
    assert displacement(["L 10 -5 2000 0", "A 4 0 2 0"]) == (14, -5)
    assert displacement(["P 0", "F 6 400 0 280", "L 10 0"]) is None


def test_unset_lost_and_gate_of_a_message_mean_the_defaults_and_the_rest_is_kept():
    goal = goal_or_defaults(90.0, 2.5, 0.0, 20.0, 0.0)
    assert goal == FollowGoal(90.0, 2.5, FollowGoal().lost_mm, 20.0, FollowGoal().gate_mm)
    # A bad value is not a default: it stays, for follow_command to refuse.
    assert goal_or_defaults(0.0, 0.0, -1.0, 0.0, 2.0).lost_mm == -1.0


def test_the_track_counts_the_path_only_while_the_board_follows_and_ends_where_the_job_ends():
    track = FollowTrack()
    track.add(2, 5000, (50.0, 50.0))          # the last follow's state while the pen goes to the start
    track.add(2, 5000, (0.0, 0.0))            # at the start, the F not begun
    assert (track.steps, track.length_mm) == (0, 0.0)
    track.add(1, 240, (3.0, 0.0))
    track.add(1, 560, (3.0, 4.0))
    assert (track.steps, track.length_mm) == (560, 7.0)
    track.add(3, 800, (3.0, 10.0))            # stopped: the end comes with the job's result
    assert track.length_mm == 7.0
    track.end(800, (3.0, 7.0))
    assert (track.steps, track.length_mm) == (800, 10.0)


def test_a_follow_too_short_for_any_feedback_is_the_chord_from_the_start_to_its_end():
    track = FollowTrack()
    track.add(0, 0, (1.0, 1.0))
    track.end(400, (4.0, 5.0))
    assert (track.steps, track.length_mm) == (400, 5.0)
    stopped_before = FollowTrack()
    stopped_before.add(0, 0, (1.0, 1.0))
    stopped_before.end(0, (1.0, 1.0))
    assert (stopped_before.steps, stopped_before.length_mm) == (0, 0.0)


def _defines(*paths: str) -> dict:
    """The firmware's `#define NAME value` numbers in these files (the last of each name: the #else's)."""
    out: dict = {}
    for path in paths:
        for name, value in re.findall(r"^#define\s+(\w+)\s+(0x[0-9A-Fa-f]+|\d+)u?\b", (FIRMWARE / path).read_text(),
                                      re.M):
            out[name] = int(value, 0)
    return out


def test_the_hosts_limits_and_names_are_the_boards():
    from plotter_bridge.link import follow
    c = _defines("core/follow.h", "core/ramp.h", "core/planner.c")
    assert follow.HEADINGS == c["FOLLOW_DIRS"]
    assert follow.MAX_GATE == c["FOLLOW_MAX_GATE"]
    assert follow.MAX_RATE == c["RAMP_R0"]
    assert follow.MIN_RATE == c["FEED_MIN"]         # the 12-clock chip's, not CPU_6T's
    assert follow.RUNNING == c["FOLLOW_STATE_RUNNING"]
    states = {c[f"FOLLOW_STATE_{name.upper()}"]: name for name in follow.FOLLOW_STATES}
    assert [states[i] for i in range(len(states))] == list(follow.FOLLOW_STATES)
