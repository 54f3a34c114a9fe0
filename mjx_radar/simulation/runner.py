"""Batched execution of closed-loop trials on the host: vmap over trials, segments over time.

A batch of trials is advanced in segments of control periods by one jitted,
vmapped call per segment (the loop inside a segment never leaves the device);
between segments the host only updates the progress bar. Results come back as
numpy arrays with leading axes ``[T, ...]``.
"""

from __future__ import annotations

import functools
import os
import time
from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np

from mjx_radar.config import Scenario
from mjx_radar.io import results
from mjx_radar.simulation import closed_loop


@functools.cache
def _compiled(scenario: Scenario, method: str, seed: int, periods: int, full: bool):
    def one(trial, carry, start):
        carry, steps, controls = closed_loop.advance(
            scenario, method, seed, trial, carry, start, periods
        )
        if not full:
            steps = {k: getattr(steps, k) for k in results.METRIC_COLUMNS}
            controls = None
        return carry, steps, controls

    init = jax.jit(jax.vmap(lambda t: closed_loop.init_carry(scenario, seed, t)))
    step = jax.jit(jax.vmap(one, in_axes=(0, 0, None)), donate_argnums=1)
    return init, step


_EXECUTABLES: dict = {}  # (scenario, method, seed, periods, full, batch) -> (init, step)


def precompile(
    jobs, batch: int, steps: int, full: bool = False, workers: int | None = None
) -> float:
    """Compiles the programs of several ``(scenario, method, seed)`` jobs concurrently.

    XLA compilation releases the GIL, so a thread pool compiles the programs of a
    study's scenario x method pairs in parallel on the host's cores instead of one
    after the other between GPU runs (compilation was ~45% of the paper study's time).
    :func:`run_trials` then uses the executables for batches of ``batch`` trials on
    the default device.

    Returns:
        Wall time [s] spent compiling.
    """
    from concurrent.futures import ThreadPoolExecutor

    def compile_one(job):
        scenario, method, seed = job
        periods = segment_periods(scenario, steps)
        key = (scenario, method, seed, periods, full, batch)
        if key in _EXECUTABLES:
            return
        init, step = _compiled(scenario, method, seed, periods, full)
        trials = jax.ShapeDtypeStruct((batch,), jnp.int32)
        carry = jax.eval_shape(init, trials)[0]
        _EXECUTABLES[key] = (
            init.lower(trials).compile(),
            step.lower(trials, carry, 0).compile(),
        )

    t0 = time.perf_counter()
    with ThreadPoolExecutor(max_workers=workers or min(len(jobs), os.cpu_count() or 1)) as pool:
        list(pool.map(compile_one, jobs))
    return time.perf_counter() - t0


def segment_periods(scenario: Scenario, steps: int, target_segments: int = 20) -> int:
    """Largest divisor of the number of control periods giving >= ``target_segments`` segments."""
    total = steps // scenario.timing.control_every
    for p in range(max(1, total // target_segments), 0, -1):
        if total % p == 0:
            return p
    return 1


def run_trials(
    scenario: Scenario,
    method: str,
    seed: int,
    trials,
    steps: int,
    full: bool = True,
    progress: Callable[[int], None] | None = None,
    periods: int | None = None,
    sharding: jax.sharding.Sharding | None = None,
) -> dict:
    """Runs the closed loop for a batch of trials.

    Args:
        scenario: scenario (static).
        method: one of ``config.METHODS``.
        seed: base seed.
        trials: [T] trial indices (common random numbers across methods).
        steps: filter steps K (a multiple of the control period).
        full: also return trajectories and MPPI samples (else only the metrics).
        progress: called with the number of filter steps done after each segment.
        periods: control periods per segment (default: :func:`segment_periods`).
        sharding: optional sharding of the trial axis (e.g. a ``NamedSharding`` over a
            1-D ``Mesh`` of ``jax.devices()``); the trial indices are placed with it and
            jit propagates it to the whole batch, so each device runs its slice of the
            trials. ``T`` must be a multiple of the number of devices. ``None``: default
            device.

    Returns:
        dict of numpy arrays: ``rmse_pos, rmse_state, nees, crlb_pos, obstacle_contacts,
        visible_pairs`` [T, K] (:data:`results.METRIC_COLUMNS`), and if
        ``full`` the fields of ``StepRecord`` / ``ControlRecord`` with leading [T, ...],
        plus ``placement_ok`` [T], ``wall_s`` (including compilation) and ``control_hz``
        (control periods per second of the batch, excluding the first, compiling, segment).
    """
    every = scenario.timing.control_every
    if steps % every:
        raise ValueError(f"steps: {steps} must be a multiple of {every}")
    periods = periods or segment_periods(scenario, steps)
    init, step = _compiled(scenario, method, seed, periods, full)
    trials = jnp.asarray(trials, jnp.int32)
    if sharding is not None:
        trials = jax.device_put(trials, sharding)
    else:
        init, step = _EXECUTABLES.get(
            (scenario, method, seed, periods, full, trials.shape[0]), (init, step)
        )
    t0 = time.perf_counter()
    carry, ok = init(trials)
    chunks = []
    t_first = None
    for start in range(0, steps // every, periods):
        carry, srec, crec = step(trials, carry, start)
        chunks.append(jax.device_get((srec, crec)))
        t_first = t_first or time.perf_counter()
        if progress is not None:
            progress(periods * every)
    out: dict = {}
    keys = chunks[0][0]._fields if full else chunks[0][0].keys()
    for k in keys:
        out[k] = np.concatenate([_get(c[0], k) for c in chunks], axis=1)
    if full:
        for k in chunks[0][1]._fields:
            out[k] = np.concatenate([getattr(c[1], k) for c in chunks], axis=1)
    out["placement_ok"] = np.asarray(ok)
    t_end = time.perf_counter()
    out["wall_s"] = t_end - t0
    # Control periods per second after the first segment (which includes compilation).
    rest = steps // every - periods
    out["control_hz"] = rest / (t_end - t_first) if rest else float("nan")
    return out


def _get(rec, k):
    return rec[k] if isinstance(rec, dict) else getattr(rec, k)
