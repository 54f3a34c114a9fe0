"""Programs traced one at a time, in the order they were asked for (engine.trace_queue)."""

from __future__ import annotations

import threading
import time

from mjx_radar.engine.trace_queue import TraceQueue


def _tracers(queue, tickets, hold=0.05):
    """One thread per ticket that waits for its turn and records when it got it."""
    order, lock = [], threading.Lock()

    def trace(t):
        with queue.turn(t):
            with lock:
                order.append(t)
            time.sleep(hold)

    # started in reverse: the later tickets ask for their turn first
    threads = [threading.Thread(target=trace, args=(t,)) for t in reversed(tickets)]
    for th in threads:
        th.start()
        time.sleep(0.02)
    return threads, order


def test_turns_follow_the_tickets_not_the_arrivals():
    queue = TraceQueue()
    tickets = [queue.draw() for _ in range(4)]
    threads, order = _tracers(queue, tickets)
    for th in threads:
        th.join(10)
    assert order == tickets == [0, 1, 2, 3]
    assert queue.wait_idle(timeout=0.1)


def test_a_ticket_given_up_is_skipped_and_finishing_twice_is_harmless():
    queue = TraceQueue()
    first, cached, last = queue.draw(), queue.draw(), queue.draw()
    queue.finish(cached)  # its program came from the caches: nobody waits for it
    threads, order = _tracers(queue, [first, last])
    for th in threads:
        th.join(10)
    assert order == [first, last]
    queue.finish(first)  # idempotent: the served count does not move past the tickets
    assert queue.wait_idle(timeout=0.1)
    nxt = queue.draw()
    assert not queue.wait_idle(timeout=0.05)  # drawn, not finished
    with queue.turn(nxt):
        pass
    assert queue.wait_idle(timeout=0.1)


def test_a_turn_that_never_comes_is_taken_after_the_timeout():
    """The order is a hint: a ticket whose predecessor hangs (another process's file
    lock, say) traces anyway after the timeout."""
    queue = TraceQueue()
    queue.draw()  # never finished
    late = queue.draw()
    t0 = time.perf_counter()
    with queue.turn(late, timeout=0.2):
        waited = time.perf_counter() - t0
    assert 0.15 < waited < 5.0


def test_wait_drawn_stops_when_the_drawing_thread_is_gone():
    queue = TraceQueue()
    t0 = time.perf_counter()
    assert not queue.wait_drawn(1, alive=lambda: False, timeout=5.0)
    assert time.perf_counter() - t0 < 1.0
    threading.Timer(0.1, queue.draw).start()
    assert queue.wait_drawn(1, alive=lambda: True, timeout=5.0)
