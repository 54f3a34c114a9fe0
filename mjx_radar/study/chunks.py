"""A study's chunks: the unit of work and of files (:mod:`mjx_radar.study.driver`).

The trials ``0..T-1`` of every scenario x method are cut into chunks of ``chunk``
trials, in study order; a chunk's file name holds its scenario, method and trials.
"""

from __future__ import annotations

import collections
import hashlib
import re
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

__all__ = ["Background", "Chunk", "all_chunks", "file_label", "rounds"]


@dataclass
class Chunk:
    scenario: object  # Scenario
    method: str
    steps: int
    seed: int
    first: int
    last: int
    path: Path


def file_label(method: str) -> str:
    """``method`` as a file-name part: unchanged unless it holds characters other than
    letters, digits, ``._+-`` (``ddr-sfim+policy:runs/p1``), then those as ``_`` plus a
    digest of the name (distinct names stay distinct)."""
    safe = re.sub(r"[^A-Za-z0-9._+-]", "_", method)
    if safe == method:
        return method
    return f"{safe[:60]}-{hashlib.sha256(method.encode()).hexdigest()[:8]}"


def all_chunks(scenarios, methods, trials: int, chunk: int, out: Path) -> list[Chunk]:
    """Every chunk in study order."""
    chunks = []
    for s, _, steps, seed in scenarios:
        for method in methods:
            for first in range(0, trials, chunk):
                last = min(first + chunk, trials) - 1
                path = out / "chunks" / f"{s.name}__{file_label(method)}__{first}-{last}.parquet"
                chunks.append(Chunk(s, method, steps, seed, first, last, path))
    return chunks


def rounds(todo: list[Chunk], n_dev: int) -> list[list[Chunk]]:
    """Chunks grouped ``n_dev`` at a time, each group of one scenario and method."""
    out: list[list[Chunk]] = []
    for c in todo:
        last = out[-1] if out else None
        same = last and last[0].scenario is c.scenario and last[0].method == c.method
        if same and len(last) < n_dev:
            last.append(c)
        else:
            out.append([c])
    return out


class Background:
    """One host thread that finishes rounds of chunks (set metrics, chunk files) while the
    devices run the next round; at most ``depth`` rounds wait. Leaving the ``with`` block
    waits for every round and raises the first error of one.

    A study's host work per round (GOSPA over every trial and step, the parquet files:
    ~1 s per 250 trials x 600 steps) otherwise leaves the devices idle.
    """

    def __init__(self, depth: int = 2):
        self.depth = depth
        self._pool = ThreadPoolExecutor(1, thread_name_prefix="mjx-radar-chunks")
        self._pending: collections.deque = collections.deque()

    def submit(self, fn) -> None:
        while len(self._pending) >= self.depth:
            self._pending.popleft().result()
        self._pending.append(self._pool.submit(fn))

    def drain(self) -> None:
        while self._pending:
            self._pending.popleft().result()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        try:
            self.drain()
        finally:
            self._pool.shutdown(wait=True)
