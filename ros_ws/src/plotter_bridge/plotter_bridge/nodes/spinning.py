"""An executor spun in a thread of its own, and stopped without leaving a
callback to run into destroyed handles.

rclpy 7.1.6's Executor.shutdown() destroys the executor's guard condition
without waiting for the callbacks in flight (its wait on the work tracker is
never reached), so a spin() in another thread can fail on that handle
(ros2/rclpy#968): a traceback from the spin thread, or "The following
exception was never retrieved: cannot use Destroyable because destruction
was requested" from a callback still running in a worker, printed as the
`plotter` command exits or a node is stopped.  Here the thread spins in
short steps until it is told to stop; stop() joins it and lets the callbacks
in flight end before it shuts the executor down, as run_node does after its
spin in the main thread.
"""
from __future__ import annotations

import threading
import time

from rclpy._rclpy_pybind11 import RCLError
from rclpy.exceptions import InvalidHandle
from rclpy.executors import Executor

STEP_S = 0.1          # s a spin step waits for work: how soon the thread sees stop()
DRAIN_S = 2.0         # s stop() gives the callbacks in flight


class SpinThread:
    def __init__(self, executor: Executor, name: str = "spin") -> None:
        self.executor = executor
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.is_set() and spin_step(self.executor, STEP_S):
            pass

    def stop(self, timeout: float = 5.0) -> None:
        """Stop spinning and shut the executor down; the nodes stay, for
        the caller to destroy."""
        self._stop.set()
        self._thread.join(timeout)
        shutdown_after_callbacks(self.executor)


def spin_step(executor: Executor, timeout: float) -> bool:
    """One spin step of at most `timeout` s; False once the context is shut down.  A shutdown
    (Ctrl-C's handler) between the check and the wait set's creation makes rcl fail "the given
    context is not valid": the same end, not an error.

    An entity destroyed by another thread (the page's web thread swapping subscriptions) after
    the step took its snapshot of the node's entities makes rclpy 7.1.6 fail with InvalidHandle
    while it adds a QoS event handler to the wait set, where it leaves the other kinds out, and
    with RCLError "Failed to add 'rcl_action_client_t' to wait set" for an action client: the
    snapshot was stale, and the next step's is not."""
    if not executor.context.ok():
        return False
    try:
        executor.spin_once(timeout_sec=timeout)
    except RCLError as exc:
        if not executor.context.ok():
            return False
        if "to wait set" in str(exc):
            return True     # an action client destroyed after the snapshot: "pointer is invalid"
        raise
    except InvalidHandle:
        return executor.context.ok()
    return True


def shutdown_after_callbacks(executor: Executor) -> None:
    """Shut down an executor nothing spins any more, once the callbacks
    still running in its workers have ended (or after DRAIN_S)."""
    # A MultiThreadedExecutor keeps each callback's task until it sees it
    # done; one that waits longer than DRAIN_S meets the shutdown, as before.
    tasks = list(getattr(executor, "_futures", ()))
    end = time.monotonic() + DRAIN_S
    while any(not task.done() for task in tasks) and time.monotonic() < end:
        time.sleep(0.005)
    executor.shutdown(timeout_sec=DRAIN_S)
