"""Programs traced one at a time in a process, in the order they were asked for.

Tracing a program is Python and holds the GIL; XLA's compilation after it does not.
Several programs traced side by side (a study's shapes, each in its own thread) therefore
all finish their tracing late, together, and only then go to XLA. One after the other,
the first goes to XLA after its own tracing alone, the later ones follow while XLA works,
and a study can run its first rounds while the others compile
(:mod:`mjx_radar.study.schedule`).

Each call of :func:`mjx_radar.engine.programs.compile_programs` draws a ticket when it
starts (:meth:`TraceQueue.draw`), waits for its turn only if it has to trace
(:meth:`TraceQueue.turn`), and gives its turn up when done, traced or not
(:meth:`TraceQueue.finish`), as soon as it knows it will not trace (its program is in the
caches). A thread that starts programs in the background waits until the new thread has
drawn its ticket (:func:`mjx_radar.engine.device_programs.start`), so the order is the
order the programs were started in; a study checks placement (a small program traced
in the caller's thread) once the queue is idle, while XLA compiles the loops
(:func:`mjx_radar.engine.placement_cache.check_placeable`). The order is a hint, never
a condition of correctness: a turn that does not come within :data:`TURN_TIMEOUT_S`
(another process holding a program's file lock that this queue's earlier ticket waits
for, say) is taken anyway.
"""

from __future__ import annotations

import contextlib
import threading
import time

#: the longest a program waits for its turn to trace [s] before tracing anyway
TURN_TIMEOUT_S = 120.0


class TraceQueue:
    """Tickets served in the order drawn; a ticket finished out of order is skipped."""

    def __init__(self):
        self._cond = threading.Condition()
        self._drawn = 0
        self._serving = 0
        self._finished: set[int] = set()

    @property
    def drawn(self) -> int:
        """How many tickets were drawn so far."""
        with self._cond:
            return self._drawn

    def draw(self) -> int:
        """A new ticket, served after every ticket drawn before it."""
        with self._cond:
            self._drawn += 1
            self._cond.notify_all()
            return self._drawn - 1

    def finish(self, ticket: int) -> None:
        """Gives ``ticket``'s turn up (done tracing, or no tracing needed); idempotent."""
        with self._cond:
            if ticket < self._serving:
                return
            self._finished.add(ticket)
            while self._serving in self._finished:
                self._finished.discard(self._serving)
                self._serving += 1
            self._cond.notify_all()

    @contextlib.contextmanager
    def turn(self, ticket: int, timeout: float = TURN_TIMEOUT_S):
        """Waits until every earlier ticket finished (at most ``timeout`` seconds), runs
        the block, then finishes ``ticket``."""
        with self._cond:
            self._cond.wait_for(lambda: self._serving >= ticket, timeout)
        try:
            yield
        finally:
            self.finish(ticket)

    def wait_drawn(self, count: int, alive, timeout: float = 10.0) -> bool:
        """Waits until ``count`` tickets were drawn, while ``alive()`` (the thread that
        is to draw it runs), at most ``timeout`` seconds."""
        with self._cond:
            end = time.monotonic() + timeout
            while self._drawn < count and alive() and time.monotonic() < end:
                self._cond.wait(0.05)
            return self._drawn >= count

    def wait_idle(self, timeout: float = TURN_TIMEOUT_S) -> bool:
        """Waits until every ticket drawn so far is finished: nothing is being traced or
        waiting to be (at most ``timeout`` seconds)."""
        with self._cond:
            return self._cond.wait_for(lambda: self._serving >= self._drawn, timeout)


#: the process's queue (:func:`mjx_radar.engine.programs.compile_programs`)
QUEUE = TraceQueue()
