"""A study's chunks: the unit of work and of files (:mod:`mjx_radar.study.driver`).

The trials ``0..T-1`` of every scenario x method are cut into chunks of ``chunk``
trials, in study order; a chunk's file name holds its scenario, method and trials.
"""

from __future__ import annotations

import hashlib
import re
from dataclasses import dataclass
from pathlib import Path

__all__ = ["Chunk", "all_chunks", "file_label"]


@dataclass
class Chunk:
    spec: object  # mjx_radar.engine.run_spec.RunSpec of its scenario
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
    """Every chunk in study order (``scenarios``: :func:`~mjx_radar.study.driver.load_scenarios`'
    ``(spec, file, steps, seed)``)."""
    chunks = []
    for spec, _, steps, seed in scenarios:
        for method in methods:
            for first in range(0, trials, chunk):
                last = min(first + chunk, trials) - 1
                path = out / "chunks" / f"{spec.name}__{file_label(method)}__{first}-{last}.parquet"
                chunks.append(Chunk(spec, method, steps, seed, first, last, path))
    return chunks
