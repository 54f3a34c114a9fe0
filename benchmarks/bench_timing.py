"""The one timing helper of the benchmark scripts (imported by them, not run)."""

from __future__ import annotations

import time

import jax
import numpy as np


def median_seconds(fn, *args, calls: int = 10) -> float:
    """Median wall seconds of ``fn(*args)`` over ``calls`` calls after one warm-up
    (compiling) call; every call is waited for with ``jax.block_until_ready``."""
    jax.block_until_ready(fn(*args))
    times = []
    for _ in range(calls):
        t0 = time.perf_counter()
        jax.block_until_ready(fn(*args))
        times.append(time.perf_counter() - t0)
    return float(np.median(times))
