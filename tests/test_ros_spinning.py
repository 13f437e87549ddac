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
TICKS_BEFORE_STOP = 3      # callbacks in flight and more due as stop() begins


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
            ticking = threading.Event()

            def tick(ticks=ticks, ticking=ticking) -> None:
                ticks.append(1)
                if len(ticks) >= TICKS_BEFORE_STOP:
                    ticking.set()
                time.sleep(0.0002)
            node.create_timer(0.0005, tick)
            executor = MultiThreadedExecutor(num_threads=4, context=context)
            executor.add_node(node)
            spin = SpinThread(executor)
            # Stopped once the timer keeps firing, however long a loaded machine takes to get there.
            assert ticking.wait(60), f"the timer ran {len(ticks)} times in 60 s"
            spin.stop()
            node.destroy_node()
            rclpy.try_shutdown(context=context)
        gc.collect()          # a task's unretrieved exception is reported as it is freed
    finally:
        threading.excepthook = hook
    assert not failed, [f.exc_value for f in failed]
    err = capfd.readouterr().err
    assert "never retrieved" not in err and "Destroyable" not in err, err


def test_a_shutdown_between_the_check_and_the_wait_ends_spinning_cleanly(monkeypatch):
    """Ctrl-C's handler can shut the context down after a spin step checked it and before the
    step builds its wait set: rcl then fails "the given context is not valid".  run_node and
    SpinThread take that as the end it is, not as an error (seen: a node's Ctrl-C exiting 1)."""
    import rclpy
    from rclpy._rclpy_pybind11 import RCLError
    from rclpy.context import Context
    from rclpy.executors import MultiThreadedExecutor
    from plotter_bridge.nodes import main as node_main
    from plotter_bridge.nodes.spinning import SpinThread

    def shut_then_fail(self, timeout_sec=None):
        rclpy.try_shutdown(context=self.context)
        raise RCLError("failed to initialize wait set: the given context is not valid")

    monkeypatch.setattr(MultiThreadedExecutor, "spin_once", shut_then_fail)
    domain = str(new_domain())
    assert node_main.run_node(lambda: rclpy.create_node("racing"), "racing",
                              ["--ros-args", "-p", "use_sim_time:=false", "-r", f"__ns:=/race{domain}"]) == 0
    failed = []
    hook, threading.excepthook = threading.excepthook, failed.append
    try:
        context = Context()
        rclpy.init(context=context, domain_id=int(domain))
        executor = MultiThreadedExecutor(num_threads=1, context=context)
        spin = SpinThread(executor)
        spin._thread.join(5)
        assert not spin._thread.is_alive() and not failed
        spin.stop()
    finally:
        threading.excepthook = hook
        rclpy.try_shutdown(context=context)



@pytest.mark.parametrize("kind", ["subscription", "action client"])
def test_an_entity_destroyed_while_the_wait_set_is_built_does_not_stop_the_spin(monkeypatch, kind):
    """The page swaps its subscriptions from its web thread when the user picks another plotter
    (web_ui_node._connect).  rclpy 7.1.6 builds each wait set from a snapshot of the node's
    entities and, for a subscription's QoS event handler destroyed after the snapshot, fails in
    add_to_wait_set with InvalidHandle ("cannot use Destroyable because destruction was
    requested") instead of leaving it out as it does for the other kinds: seen as the page's
    node dying.  Here the destruction is put inside that window; spin_step takes the stale
    snapshot for what it is and the next step builds its wait set without the entity.  The same
    for the page's action clients, where rclpy fails with RCLError "Failed to add
    'rcl_action_client_t' to wait set: action client pointer is invalid" (seen in a fresh-clone
    run)."""
    import rclpy
    from rclpy.action import ActionClient
    from rclpy.context import Context
    from rclpy.event_handler import EventHandler
    from rclpy.executors import MultiThreadedExecutor
    from std_msgs.msg import String
    from plotter_interfaces.action import DrawShape
    from plotter_bridge.nodes.spinning import spin_step
    context = Context()
    rclpy.init(context=context, domain_id=new_domain())
    node = rclpy.create_node("swapping", context=context)
    executor = MultiThreadedExecutor(num_threads=2, context=context)
    executor.add_node(node)
    if kind == "subscription":
        entity = node.create_subscription(String, "swapped", lambda _m: None, 10)
        owner, destroy, entities = EventHandler, lambda: node.destroy_subscription(entity), node.subscriptions
    else:
        entity = ActionClient(node, DrawShape, "draw")
        owner, destroy, entities = ActionClient, entity.destroy, node.waitables
    enter = owner.__enter__
    destroyed = []

    def destroyed_after_the_snapshot(self):
        if not destroyed:
            destroyed.append(destroy() is not False)     # destroy_subscription says whether it did
        return enter(self)
    monkeypatch.setattr(owner, "__enter__", destroyed_after_the_snapshot)
    try:
        assert spin_step(executor, 0.01)
        assert destroyed == [True]
        monkeypatch.undo()
        assert spin_step(executor, 0.01)        # the next wait set is built without it
        assert entity not in entities
    finally:
        monkeypatch.undo()
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=context)
