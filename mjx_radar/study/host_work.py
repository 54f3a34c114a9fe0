"""A study's host work per chunk, off the devices' path: set metrics, the chunk file and
the rows for ``metrics.parquet``, on a pool of host threads.

When a device has run a chunk (:mod:`mjx_radar.study.lanes`), its loop metrics and
recorded sets go to :class:`HostPool`; a worker thread computes GOSPA, OSPA and
track continuity (:func:`mjx_radar.rundir.results.set_columns`), builds the chunk's
long table, writes its file, and hands the table to ``metrics.parquet``'s
:class:`~mjx_radar.study.consolidate.Stream` (which puts the chunks back in study
order). The device meanwhile runs its next chunk. The heavy parts (numpy on whole
arrays, Arrow's conversion and Parquet writer) release the GIL, so several threads
keep up with several devices. A lane waits for the pool only when more than
``limit`` chunks are pending (their arrays held in memory); :attr:`HostPool.waited_s`
counts those seconds.

Per chunk, :func:`finish_chunk` returns its seconds of set metrics, table and file
(``study.json``'s ``host`` section; docs/scaling.md).
"""

from __future__ import annotations

import collections
import dataclasses
import threading
import time
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path

import numpy as np

__all__ = ["ChunkJob", "HostPool", "finish_chunk"]


@dataclasses.dataclass(frozen=True)
class ChunkJob:
    """What the host needs of a chunk besides its arrays.

    Attributes:
        path: the chunk file.
        scenario_name, method: names written into its rows.
        first, last: its trials (the arrays' first ``last - first + 1`` rows; the
            rest is padding).
        dt_filter: filter step [s] (``time_s = dt_filter · (1..K)``).
        cutoff, order: GOSPA / OSPA ``c`` and ``p`` (the scenario's ``[metrics]``).
    """

    path: Path
    scenario_name: str
    method: str
    first: int
    last: int
    dt_filter: float
    cutoff: float
    order: float


def finish_chunk(job: ChunkJob, loop: dict, sets: dict, stream=None) -> dict:
    """The host's work on one chunk: set metrics, table, chunk file, stream.

    Args:
        job: the chunk.
        loop: :data:`~mjx_radar.rundir.results.LOOP_COLUMNS` arrays ``[B, K]``.
        sets: :data:`~mjx_radar.env.records.SET_KEYS` arrays ``[B, K, ...]``.
        stream: the study's :class:`~mjx_radar.study.consolidate.Stream`, or None.

    Returns:
        Seconds spent: ``{"set_metrics_s", "table_s", "write_s", "stream_s"}``.
    """
    from mjx_radar.rundir import results

    n = job.last - job.first + 1
    t0 = time.perf_counter()
    metrics = {k: v[:n] for k, v in loop.items()}
    metrics |= results.set_columns({k: v[:n] for k, v in sets.items()}, job.cutoff, job.order)
    t1 = time.perf_counter()
    k = next(iter(loop.values())).shape[1]
    time_s = job.dt_filter * np.arange(1, k + 1)
    trials = np.arange(job.first, job.last + 1)
    frame = results.metrics_frame(job.scenario_name, job.method, trials, time_s, metrics)
    t2 = time.perf_counter()
    results.write_parquet(job.path, frame)
    t3 = time.perf_counter()
    if stream is not None:
        stream.add(job.path, frame)
    t4 = time.perf_counter()
    return {"set_metrics_s": t1 - t0, "table_s": t2 - t1, "write_s": t3 - t2, "stream_s": t4 - t3}


class HostPool:
    """Worker threads that finish chunks while the devices run the next ones.

    Args:
        workers: threads (at least 1).
        stream: the study's :class:`~mjx_radar.study.consolidate.Stream`, or None.
        limit: chunks pending at most before :meth:`submit` waits.

    Leaving the ``with`` block waits for every chunk and raises the first error of one
    (a failed write); :meth:`submit` raises it too, so the devices stop early.
    """

    def __init__(self, workers: int, stream=None, limit: int | None = None):
        self.workers = max(1, int(workers))
        self.limit = limit or 4 * self.workers
        self._stream = stream
        self._pool = ThreadPoolExecutor(self.workers, thread_name_prefix="mjx-radar-host")
        self._pending: collections.deque[Future] = collections.deque()
        self._slots = threading.Semaphore(self.limit)
        self._lock = threading.Lock()
        self.waited_s = 0.0  # lanes waited for a free slot
        self.seconds: dict = collections.defaultdict(float)  # summed finish_chunk times
        self.done = 0
        self.last_done = 0.0  # time.perf_counter() when the last chunk was finished

    def submit(self, job: ChunkJob, loop: dict, sets: dict) -> None:
        """Queues one chunk's host work; waits while ``limit`` chunks are pending."""
        self._raise_failed()
        t0 = time.perf_counter()
        self._slots.acquire()
        with self._lock:
            self.waited_s += time.perf_counter() - t0
            future = self._pool.submit(self._run, job, loop, sets)
            self._pending.append(future)

    def _run(self, job, loop, sets):
        try:
            spent = finish_chunk(job, loop, sets, self._stream)
            with self._lock:
                for key, s in spent.items():
                    self.seconds[key] += s
                self.done += 1
                self.last_done = time.perf_counter()
        finally:
            self._slots.release()

    def _raise_failed(self) -> None:
        with self._lock:
            failed = [f for f in self._pending if f.done() and f.exception() is not None]
            self._pending = collections.deque(f for f in self._pending if not f.done())
        if failed:
            raise failed[0].exception()

    def drain(self) -> None:
        """Waits for every chunk queued; raises the first error of one."""
        with self._lock:
            pending = list(self._pending)
        for f in pending:
            f.result()
        self._raise_failed()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        try:
            if exc[0] is None:
                self.drain()
        finally:
            self._pool.shutdown(wait=True, cancel_futures=exc[0] is not None)
