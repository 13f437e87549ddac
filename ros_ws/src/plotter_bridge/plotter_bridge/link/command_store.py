"""A job's board commands held as one text, not as a string object each.

A board command is 5 to 40 ASCII characters ("L 77 -92 5635 1872"); as a
Python str each costs about 70 bytes with its place in a list, so a
million-command job would hold 70 MB in the streamer and as much again in
the bridge.  Kept as one text with the offset of each command, it costs the
characters and 4 bytes: what the job itself is.  It reads as a sequence of
the commands; a slice is a view of the same text.
"""
from __future__ import annotations

import bisect
import re
from array import array
from typing import Iterable, Iterator, Optional, Sequence, Union, overload

import numpy as np


_BATCH = 4096
_CHUNK = 1 << 20


class CommandStore(Sequence[str]):
    """Commands, each without a line end, in the order given."""

    def __init__(self, texts: Iterable[str] = ()) -> None:
        # Joined a few thousand at a time: a list of every command, or a StringIO's accumulator of
        # them, would hold a string object each until the end.
        chunks, batch = [], []
        ends = array("I")
        pos = 0
        for text in texts:
            if "\n" in text:
                raise ValueError(f"a board command on more than one line: {text!r}")
            batch.append(text)
            pos += len(text) + 1
            ends.append(pos)
            if len(batch) == _BATCH:
                chunks.append("\n".join(batch) + "\n")
                batch.clear()
        if batch:
            chunks.append("\n".join(batch) + "\n")
        self._text, self._ends, self._first, self._count = "".join(chunks), ends, 0, len(ends)

    @classmethod
    def from_text(cls, text: str) -> "CommandStore":
        """The commands of `text`, one per line (as `text` gives them)."""
        store = cls()
        if text and not text.endswith("\n"):
            text += "\n"
        ends = array("I")
        if text.isascii():
            # a character a byte: the line ends a megabyte at a time (a million commands in 30 ms,
            # and the copies made for it a few MB, not three times the text)
            for at in range(0, len(text), _CHUNK):
                piece = np.frombuffer(text[at:at + _CHUNK].encode("ascii"), dtype=np.uint8)
                ends.frombytes((np.flatnonzero(piece == 10) + (at + 1)).astype(np.uint32).tobytes())
        else:
            pos = text.find("\n")
            while pos >= 0:
                ends.append(pos + 1)
                pos = text.find("\n", pos + 1)
        store._text, store._ends, store._count = text, ends, len(ends)
        return store

    def find(self, pattern: "re.Pattern[str]", k: int = 0) -> Optional[int]:
        """The index of the first command from k on that `pattern` (MULTILINE, ^ and $ a command's
        ends) matches in, None if none does."""
        if k >= self._count:
            return None
        end = self._ends[self._first + self._count - 1]
        found = pattern.search(self._text, self._start(k), end)
        if found is None:
            return None
        # the command whose end is the first after the match's start
        return bisect.bisect_right(self._ends, found.start(), self._first + k, self._first + self._count) - self._first

    @property
    def text(self) -> str:
        """The commands one per line, each ended by a line end."""
        start = self._start(0)
        end = self._ends[self._first + self._count - 1] if self._count else start
        return self._text[start:end]

    def longest(self) -> int:
        """Characters of the longest command (0 for none)."""
        if not self._count:
            return 0
        ends = np.frombuffer(self._ends, dtype=np.uint32)[self._first:self._first + self._count].astype(np.int64)
        starts = np.concatenate(([self._start(0)], ends[:-1]))
        return int((ends - starts).max()) - 1

    def _start(self, k: int) -> int:
        i = self._first + k
        return self._ends[i - 1] if i > 0 else 0

    def __len__(self) -> int:
        return self._count

    @overload
    def __getitem__(self, index: int) -> str: ...

    @overload
    def __getitem__(self, index: slice) -> "CommandStore": ...

    def __getitem__(self, index: Union[int, slice]) -> Union[str, "CommandStore"]:
        if isinstance(index, slice):
            start, stop, step = index.indices(self._count)
            if step != 1:
                return CommandStore(self[k] for k in range(start, stop, step))
            view = CommandStore()
            view._text, view._ends = self._text, self._ends
            view._first, view._count = self._first + start, max(0, stop - start)
            return view
        if index < 0:
            index += self._count
        if not 0 <= index < self._count:
            raise IndexError("command index out of range")
        return self._text[self._start(index):self._ends[self._first + index] - 1]

    def __iter__(self) -> Iterator[str]:
        text, ends = self._text, self._ends
        start = self._start(0)
        for i in range(self._first, self._first + self._count):
            end = ends[i]
            yield text[start:end - 1]
            start = end

    def __eq__(self, other: object) -> bool:
        if isinstance(other, CommandStore):
            return self.text == other.text
        if isinstance(other, Sequence) and not isinstance(other, str):
            return len(other) == self._count and all(a == b for a, b in zip(self, other))
        return NotImplemented

    def __repr__(self) -> str:
        head = ", ".join(repr(c) for c in self[:3])
        return f"CommandStore([{head}{', ...' if self._count > 3 else ''}], {self._count} commands)"


def as_commands(commands: Sequence[str]) -> CommandStore:
    """`commands` as a CommandStore (itself if it is one)."""
    return commands if isinstance(commands, CommandStore) else CommandStore(commands)


def goal_commands(goal) -> Sequence[str]:
    """A StreamCommands goal's commands as they came (a big job is not copied): its list, or its
    command_text read as a CommandStore; ValueError for a goal that gives both."""
    if goal.command_text:
        if goal.commands:
            raise ValueError("both commands and command_text given: give one")
        return CommandStore.from_text(goal.command_text)
    return goal.commands
