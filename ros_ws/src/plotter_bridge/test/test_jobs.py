"""One job at a time, in the order they came: JobQueue."""
from plotter_bridge.nodes.jobs import JobQueue


def test_jobs_take_their_turn_in_order_and_a_waiting_one_can_leave():
    q = JobQueue(limit=3)
    a, b, c, d = object(), object(), object(), object()
    ta, tb, tc = q.enter(a), q.enter(b), q.enter(c)
    assert ta.result() is True and not tb.done() and not tc.done()
    assert (q.ahead(b), q.ahead(c)) == (1, 2)
    assert q.withdraw(b) and tb.result() is False and q.ahead(c) == 1
    assert not q.withdraw(a)                     # running: it leaves when it ends
    td = q.enter(d)
    q.leave(a)
    assert tc.result() is True and not td.done() and q.ahead(d) == 1
    q.leave(c)
    assert td.result() is True and q.waiting() == []


def test_the_queue_says_when_it_is_full():
    q = JobQueue(limit=2)
    keys = [object() for _ in range(3)]
    for k in keys:
        q.enter(k)
    assert q.full()                               # one running, two waiting
    q.leave(keys[0])
    assert not q.full()
