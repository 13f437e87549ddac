"""A watchdog over the destruction of a process's nodes.

Fast DDS 2.14 can deadlock deleting a writer while its event thread checks
a remote participant's liveliness (eProsima/Fast-DDS#6502): seen here as a
node stuck in destroy_publisher after Ctrl-C, most likely when the other
nodes of the graph stop at the same time.  The GIL is held meanwhile, so no
Python thread could end it: faulthandler's own thread prints every thread's
stack, and SIGALRM's default action ends the process.
"""
from __future__ import annotations

import contextlib
import faulthandler
import signal
import threading
from typing import Iterator

#: Seconds the destruction may take before the stacks are printed; one more,
#: and the process ends (exit status -SIGALRM, 142 in a shell).
TEARDOWN_S = 8


@contextlib.contextmanager
def teardown_watchdog() -> Iterator[None]:
    """The watchdog over the `with` block.  Not armed off the main thread,
    nor where SIGALRM has a handler: the alarm is not this code's to take
    there."""
    if threading.current_thread() is not threading.main_thread() \
            or signal.getsignal(signal.SIGALRM) != signal.SIG_DFL:
        yield
        return
    faulthandler.dump_traceback_later(TEARDOWN_S)
    signal.alarm(TEARDOWN_S + 1)
    try:
        yield
    finally:
        signal.alarm(0)
        faulthandler.cancel_dump_traceback_later()
