"""A job's commands as one text (link/command_store.py): the same sequence a list of them is,
views for slices, the journal and the bridge's goal reading it back, and what it saves."""
from __future__ import annotations

import sys
import tracemalloc
from array import array
from pathlib import Path
from types import SimpleNamespace

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
import gcode_testlib  # noqa: E402,F401  (puts plotter_bridge on the path)

from plotter_bridge.link.command_store import CommandStore, as_commands, goal_commands  # noqa: E402
from plotter_bridge.link.journal import Journal, JobRecord, Progress, resume_commands  # noqa: E402

COMMANDS = ["P 1", "L 77 -92 5635 1872", "C 10 0 5 0 3000 0", "M6 0", "D 250", "L -1 0 15 0"]


def test_it_reads_as_the_list_it_was_made_of():
    store = CommandStore(COMMANDS)
    assert len(store) == len(COMMANDS) and list(store) == COMMANDS and store == COMMANDS
    assert [store[k] for k in range(-len(COMMANDS), len(COMMANDS))] == COMMANDS + COMMANDS
    for a in range(-7, 8):
        for b in range(-7, 8):
            assert list(store[a:b]) == COMMANDS[a:b] and store[a:b] == COMMANDS[a:b]
            assert list(store[a:b][1:]) == COMMANDS[a:b][1:]            # a view of a view
    assert list(store[::2]) == COMMANDS[::2]
    assert store.text == "\n".join(COMMANDS) + "\n"
    assert CommandStore.from_text(store.text) == store == CommandStore.from_text(store.text.rstrip("\n"))
    assert store[2:4].text == "C 10 0 5 0 3000 0\nM6 0\n"
    assert CommandStore() == [] and CommandStore.from_text("").text == "" and len(CommandStore.from_text("")) == 0
    with pytest.raises(IndexError):
        store[6]
    with pytest.raises(ValueError, match="more than one line"):
        CommandStore(["L 1 0", "P 1\nP 0"])
    assert as_commands(store) is store and as_commands(COMMANDS) == store


def test_a_journal_keeps_it_as_text_and_gives_it_back(tmp_path):
    journal = Journal(tmp_path)
    record = JobRecord("a" * 32, "walk", CommandStore(COMMANDS), [1, 2, 3, 4, 5, 6], (0, 0))
    journal.create(record)
    assert '"P 1\\nL 77' in (tmp_path / f"{'a' * 32}.job.json").read_text()
    back, progress = journal.load("a" * 32)
    assert isinstance(back.commands, CommandStore) and back.commands == COMMANDS and progress == Progress()
    packed = JobRecord("c" * 32, "compiled", CommandStore(COMMANDS), array("I", [1, 2, 3, 4, 70000, 6]), (0, 0))
    journal.create(packed)
    again, _ = journal.load("c" * 32)
    assert isinstance(again.lines, array) and list(again.lines) == [1, 2, 3, 4, 70000, 6]
    commands, lines = resume_commands(back, 4, (5, 5), True)
    listed = resume_commands(JobRecord("b" * 32, "few", list(COMMANDS), [1, 2, 3, 4, 5, 6], (0, 0)), 4, (5, 5), True)
    assert isinstance(commands, CommandStore) and (list(commands), list(lines)) == listed
    assert list(commands[-2:]) == COMMANDS[-2:] and len(commands) > 2     # the travel back, then the rest


def test_a_journal_writes_a_big_text_in_pieces_that_read_back_whole(tmp_path, monkeypatch):
    """Journal.create writes a CommandStore's text a CHUNK at a time into the JSON: pieces of 7
    characters here, so that every command is cut somewhere, the file JSON and the text the same."""
    import json
    from plotter_bridge.link import journal as journal_module
    monkeypatch.setattr(journal_module, "CHUNK", 7)
    journal = Journal(tmp_path)
    commands = COMMANDS * 5 + ['M6 0 "quoted" \\ back']
    journal.create(JobRecord("d" * 32, "pieces", CommandStore(commands), list(range(len(commands))), (0, 0)))
    on_disk = json.loads((tmp_path / f"{'d' * 32}.job.json").read_text())
    assert on_disk["commands"] == CommandStore(commands).text and on_disk["name"] == "pieces"
    back, _ = journal.load("d" * 32)
    assert list(back.commands) == commands and list(back.lines) == list(range(len(commands)))


def test_finding_a_command_and_the_parts_of_a_job_read_as_a_list_does():
    """CommandStore.find and BoardSession._part_end over a store's text, against the same over a
    list, from every start, in views too, with pen changes where a plain scan finds them."""
    import random
    import re
    from plotter_bridge.link.board_session import BoardSession, Job
    rng = random.Random(5)
    kinds = ["L 1 2 3 4", "M6 0", "M6 12", "M6  3 ", "M62", "XM6 1", "P 1", "M6 x", "D 5"]
    commands = [rng.choice(kinds) for _ in range(400)]
    store = CommandStore.from_text("\n".join(commands))
    pattern = re.compile(r"^M6 +[0-9]+ *$", re.MULTILINE)
    for k in range(len(commands) + 1):
        expected = next((i for i in range(k, len(commands)) if pattern.search(commands[i])), None)
        assert store.find(pattern, k) == expected
        part_end = BoardSession._part_end
        assert part_end(Job(source=(store, [])), k) == part_end(Job(source=(commands, [])), k)
    view = store[37:211]
    for k in range(len(view) + 1):
        expected = next((i for i in range(k, len(view)) if pattern.search(view[i])), None)
        assert view.find(pattern, k) == expected
    # not ASCII: its line ends found the slow way
    assert CommandStore.from_text("L 1 2\nP \u00e9\nM6 0\n") == ["L 1 2", "P \u00e9", "M6 0"]
    assert CommandStore.from_text("L 1 2\nM6 0") == ["L 1 2", "M6 0"] and CommandStore.from_text("") == []


def test_a_text_is_cut_into_commands_the_same_across_its_pieces(monkeypatch):
    """from_text finds an ASCII text's line ends a piece at a time: pieces of 7 here."""
    from plotter_bridge.link import command_store
    monkeypatch.setattr(command_store, "_CHUNK", 7)
    for text in ["a\n", "L 1 2\nM6 0\nP 1", "abcdefg\nhijklmn\n" * 5, "x" * 20 + "\n" + "y" * 3, "\n".join(COMMANDS)]:
        lines = text.split("\n")
        assert list(CommandStore.from_text(text)) == (lines[:-1] if text.endswith("\n") else lines), text


def test_a_big_jobs_end_is_summed_beside_it_and_the_same():
    """start_job's expected end: summed at once up to SUMMED_AT_ONCE commands, on a thread beyond
    (the job's first line does not wait for a million), the same sum either way."""
    from plotter_bridge.link.board_session import SUMMED_AT_ONCE, Job, _expect_end, displacement
    small = ["L 3 -2 10 0", "P 1", "C 4 0 2 0 10 0"] * 10
    job = Job(source=(CommandStore(small), []))
    assert _expect_end(job, (100, 50)) is None and job.expected_end == (100 + 70, 50 - 20)
    big = CommandStore(["L 3 -2 10 0", "P 1", "A -1 5 0 2 10 0"] * (SUMMED_AT_ONCE // 3 + 1))
    job = Job(source=(big, []))
    thread = _expect_end(job, (7, 8))
    assert thread is not None
    thread.join()
    dx, dy = displacement(list(big))
    assert job.expected_end == (7 + dx, 8 + dy) and (dx, dy) == (2 * len(big) // 3, len(big))
    job = Job(source=(CommandStore(["L 1 1 5 0"] * (SUMMED_AT_ONCE + 1) + ["F 0 400 0 280"]), []))
    thread = _expect_end(job, (0, 0))
    thread.join()
    assert job.expected_end is None, "a follow ends where the line takes the pen"


def test_the_bridge_takes_a_goal_by_list_or_by_text_not_both():
    assert goal_commands(SimpleNamespace(commands=COMMANDS, command_text="")) is COMMANDS
    assert goal_commands(SimpleNamespace(commands=[], command_text="P 1\nL 1 0 15 0\n")) == ["P 1", "L 1 0 15 0"]
    with pytest.raises(ValueError, match="both"):
        goal_commands(SimpleNamespace(commands=COMMANDS, command_text="P 1\n"))


def test_a_hundred_thousand_commands_cost_their_characters_not_an_object_each():
    texts = [f"L {k % 97 - 48} {k % 89 - 44} {4000 + k % 1000} {k % 2000}" for k in range(100_000)]
    chars = sum(len(t) + 1 for t in texts)
    tracemalloc.start()
    try:
        store = CommandStore(iter(texts))
        held, _ = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert len(store) == 100_000 and store[54321] == texts[54321]
    assert held < chars + 4 * 100_000 + 100_000, (held, chars)      # its text and 4 bytes a command
