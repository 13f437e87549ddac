"""Answers that reach a client its server discovered late.

A service (and each of an action's three services) is a pair of DDS topics.
A client may see the server and send its request before the server's reply
writer has matched the client's reply reader: discovery is not symmetric, and
on a loaded machine the server's side can lag by seconds.  rmw_fastrtps then
waits 100 ms for the match, gives up without writing, and rclpy 7.1.6 only
warns ("failed to send response (timeout)").  For an action's goal that is the
worst case: the client never hears that its goal was accepted while the server
goes on and draws it, so a user who tries again gets the drawing twice
(ros2/rmw_fastrtps#842; measured here: 1 run in 80 of a graph test beside
three CPU-bound processes).

retry_late_answers() makes every node of the process answer again until the
match is made, for up to PATIENCE_S.  Nothing is sent twice: rmw writes the
answer only once the reader is matched.  A goal whose acceptance still cannot
be delivered is not run (rclpy drops a goal whose answer raised), so the
client's "no answer" is true.
"""
from __future__ import annotations

import threading
import time
import warnings
from typing import Callable

import rclpy.logging
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy

PATIENCE_S = 10.0
LOST = "failed to send response (timeout)"

# catch_warnings swaps the process's warning state: one answer at a time.
_ANSWERING = threading.Lock()
_installed = threading.Lock()


def _sent(send: Callable[[], None]) -> bool:
    """Call send(); False if rmw timed out waiting for the client's reader."""
    with _ANSWERING, warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        send()
    lost = False
    for w in caught:
        if issubclass(w.category, RuntimeWarning) and str(w.message).startswith(LOST):
            lost = True
        else:                                  # somebody else's: pass it on
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    return not lost


def deliver(send: Callable[[], None], patience: float = PATIENCE_S,
            clock: Callable[[], float] = time.monotonic) -> int:
    """send() again while the client's reader is not matched yet, for up to
    `patience` seconds (each try waits 100 ms in rmw): the number of tries it
    took, 0 if the answer could not be delivered."""
    deadline = clock() + patience
    tries = 1
    while not _sent(send):
        if clock() >= deadline:
            return 0
        tries += 1
    return tries


def patient(method: Callable, what: str, raise_if_lost: bool, patience: float = PATIENCE_S) -> Callable:
    """method(handle, header, answer) made to deliver(), logging what it took."""
    def answer(handle, *args):
        tries = deliver(lambda: method(handle, *args), patience)
        logger = rclpy.logging.get_logger("late_clients")
        if tries > 1:
            logger.info(f"{what} delivered at try {tries}: the client was discovered late")
        if tries:
            return None
        message = f"{what} not delivered: the client's reply reader was not matched in {patience:g} s"
        logger.error(message + ("; the goal is not run" if what == "goal answer" else ""))
        if raise_if_lost:
            raise _rclpy.RCLError(message)    # rclpy then drops the goal (or the cancel) it answers
        return None
    answer.__wrapped__ = method
    return answer


def retry_late_answers() -> None:
    """Make every service and action server of this process deliver its
    answers to clients discovered late (idempotent)."""
    with _installed:
        server, service = _rclpy.ActionServer, _rclpy.Service
        if hasattr(server.send_goal_response, "__wrapped__"):
            return
        server.send_goal_response = patient(server.send_goal_response, "goal answer", True)
        server.send_cancel_response = patient(server.send_cancel_response, "cancel answer", True)
        # rclpy sends a result answer outside any try for an unknown goal: warn, never raise.
        server.send_result_response = patient(server.send_result_response, "result answer", False)
        service.service_send_response = patient(service.service_send_response, "service answer", False)
