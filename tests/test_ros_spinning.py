"""plotter_bridge.nodes.spinning.SpinThread: an executor spun in a thread and
stopped while callbacks keep coming, with nothing failing on the handles the
shutdown destroys (rclpy 7.1.6's Executor.shutdown() does not wait for the
callbacks in flight; ros2/rclpy#968)."""
import gc
import threading
import time

import pytest

from node_processes import new_domain

pytestmark = pytest.mark.ros

ROUNDS = 40


def test_stopping_while_callbacks_run_leaves_no_error_behind(capfd):
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import MultiThreadedExecutor
    from plotter_bridge.nodes.spinning import SpinThread
    failed = []
    hook, threading.excepthook = threading.excepthook, failed.append
    domain = new_domain()
    try:
        for _ in range(ROUNDS):
            context = Context()
            rclpy.init(context=context, domain_id=domain)
            node = rclpy.create_node("spinning", context=context)
            ticks = []
            node.create_timer(0.0005, lambda: (ticks.append(1), time.sleep(0.0002)))
            executor = MultiThreadedExecutor(num_threads=4, context=context)
            executor.add_node(node)
            spin = SpinThread(executor)
            time.sleep(0.05)
            spin.stop()
            assert ticks, "the timer never ran"
            node.destroy_node()
            rclpy.try_shutdown(context=context)
        gc.collect()          # a task's unretrieved exception is reported as it is freed
    finally:
        threading.excepthook = hook
    assert not failed, [f.exc_value for f in failed]
    err = capfd.readouterr().err
    assert "never retrieved" not in err and "Destroyable" not in err, err
