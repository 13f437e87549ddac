"""Action servers that run one job at a time without holding the executor.

An execute callback that waits inside for the board holds an executor
thread for the whole job, and a handful of goals at once leaves none for the
replies they wait for.  So the plotter's execute callbacks are coroutines:
a goal takes its place in a JobQueue and awaits its turn, the blocking part
of a job runs on the node's own worker thread (Worker), and the coroutine
awaits the outcome.  Neither wait holds an executor thread.

rclpy resumes a waiting coroutine only when the executor wakes up for some
event; a future completed elsewhere does not wake it.  Waker closes that gap:
a future awaited through it triggers a guard condition when it completes.
"""
from __future__ import annotations

import queue
import threading
from typing import Any, Callable, List, Optional, Tuple

from rclpy.node import Node
from rclpy.task import Future


class Waker:
    """Awaits rclpy futures and wakes the node's executor when they complete."""

    def __init__(self, node: Node) -> None:
        self._guard = node.create_guard_condition(lambda: None)

    def wake(self) -> None:
        self._guard.trigger()

    async def wait(self, future: Future) -> Any:
        future.add_done_callback(lambda _: self._guard.trigger())
        return await future


class Worker:
    """One thread of the node's own for the blocking part of its jobs.

    A daemon thread: a job still waiting for the board when the node is
    stopped (Ctrl-C) must not keep the process alive."""

    def __init__(self, name: str) -> None:
        self._jobs: "queue.SimpleQueue[Optional[Tuple[Future, Callable[..., Any], tuple]]]" = queue.SimpleQueue()
        self._thread = threading.Thread(target=self._loop, name=name, daemon=True)
        self._thread.start()

    def run(self, fn: Callable[..., Any], *args: Any) -> Future:
        """fn(*args) on the worker thread; the future holds its result or exception."""
        future = Future()
        self._jobs.put((future, fn, args))
        return future

    def _loop(self) -> None:
        while True:
            job = self._jobs.get()
            if job is None:
                return
            future, fn, args = job
            try:
                future.set_result(fn(*args))
            except BaseException as exc:  # handed to the awaiting coroutine
                future.set_exception(exc)

    def shutdown(self) -> None:
        self._jobs.put(None)


class JobQueue:
    """Jobs of one node, run one at a time in the order they entered.

    `enter` gives a job its place and a future that completes with True when
    its turn comes, or with False if it was withdrawn first; the running job
    `leave`s when it ends, which gives the next one its turn.  A job entered
    again gets the place and the future it has: an action server enters a
    goal when it accepts it (in the order goals come) and again when its
    execute callback starts (in any order, on a multi-threaded executor)."""

    def __init__(self, limit: int) -> None:
        self.limit = limit
        self._lock = threading.Lock()
        self._running: Optional[object] = None
        self._running_turn: Optional[Future] = None
        self._waiting: List[Tuple[object, Future]] = []

    def full(self) -> bool:
        with self._lock:
            return len(self._waiting) >= self.limit

    def enter(self, key: object) -> Future:
        with self._lock:
            if self._running is key:
                return self._running_turn
            placed = next((t for k, t in self._waiting if k is key), None)
            if placed is not None:
                return placed
            turn = Future()
            if self._running is None and not self._waiting:
                self._running, self._running_turn = key, turn
                ready = True
            else:
                self._waiting.append((key, turn))
                ready = False
        if ready:
            turn.set_result(True)
        return turn

    def leave(self, key: object) -> None:
        nxt = None
        with self._lock:
            if self._running is key:
                self._running = None
                self._running_turn = None
                if self._waiting:
                    self._running, nxt = self._waiting.pop(0)
                    self._running_turn = nxt
        if nxt is not None:
            nxt.set_result(True)

    def withdraw(self, key: object) -> bool:
        """Take a waiting job out of the queue (its future completes with False)."""
        with self._lock:
            found = next((k for k, (key2, _) in enumerate(self._waiting) if key2 is key), None)
            turn = self._waiting.pop(found)[1] if found is not None else None
        if turn is not None:
            turn.set_result(False)
        return turn is not None

    def give_up(self, key: object) -> None:
        """A job that will not run after all leaves its place, waiting or running."""
        if not self.withdraw(key):
            self.leave(key)

    def ahead(self, key: object) -> int:
        """Jobs before this one: the running one and those waiting in front of it."""
        with self._lock:
            for k, (key2, _) in enumerate(self._waiting):
                if key2 is key:
                    return k + (self._running is not None)
            return 0

    def waiting(self) -> List[object]:
        with self._lock:
            return [key for key, _ in self._waiting]
