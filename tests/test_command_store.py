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
