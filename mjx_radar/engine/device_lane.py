"""One batch of trials on one device, its segments read one segment late.

A compiled loop (:class:`mjx_radar.engine.programs.Programs`) advances a batch of
trials in segments of control periods. :class:`DeviceBatch` holds one device's batch:
its parameters and trial ids on the device, the loop state between segments, and the
segments dispatched but not yet read. :meth:`DeviceBatch.dispatch` enqueues the next
segment and starts copying its records to the host at once
(``jax.Array.copy_to_host_async``); :meth:`DeviceBatch.collect` returns the oldest
dispatched segment's records on the host. A driver that dispatches segment ``k + 1``
before it collects segment ``k`` (:func:`run_batches`) never leaves the device idle
while the host reads, converts and hands on a segment's records: the device runs the
next segment meanwhile. Same programs, same inputs: the numbers do not depend on when
the records are read.

On a GPU a program with loops keeps its host thread busy while it runs (the loop's
condition is read back every iteration), so each device is driven from a thread of
its own: :func:`run_batches` for the devices of one run (one thread per device and
segment round), :mod:`mjx_radar.study.lanes` for a study (one thread per device for
the whole study).
"""

from __future__ import annotations

import collections
from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np

from mjx_radar.engine.threads import parallel

__all__ = ["DeviceBatch", "run_batches", "run_on_device", "segment_periods"]


class DeviceBatch:
    """One device's batch of trials of a compiled loop.

    Args:
        prog: the device's :class:`~mjx_radar.engine.programs.Programs`.
        params: the flat leaves of the run's :class:`~mjx_radar.task.params.TaskParams`.
        ids: ``[B]`` int32 trial indices of this device (common random numbers).

    The initial conditions run at construction (asynchronously); :meth:`placed` reads
    their per-trial placement flags.
    """

    def __init__(self, prog, params, ids):
        self.prog = prog
        self._p = [jax.device_put(x, prog.replicated) for x in params]
        ids = jax.device_put(jnp.asarray(ids, jnp.int32), prog.trial_sharding)
        *carry, self._ok = prog.init(ids, *self._p)
        self._carry = list(carry)
        self._queue: collections.deque = collections.deque()

    def placed(self) -> np.ndarray:
        """``[B]`` bool: the trials whose radars could be placed (waits for ``init``)."""
        return np.asarray(self._ok)

    def dispatch(self) -> None:
        """Enqueues the next segment; its records start copying to the host when ready."""
        out = self.prog.step(*self._p, *self._carry)
        n = self.prog.n_carry
        self._carry = list(out[:n])
        records = out[n:]
        for r in records:
            r.copy_to_host_async()
        self._queue.append(records)

    def collect(self) -> list[np.ndarray]:
        """The oldest dispatched segment's records on the host (waits for them)."""
        return [np.asarray(r) for r in self._queue.popleft()]


def run_batches(
    batches: list[DeviceBatch], segments: int, on_segment: Callable[[int, list], None]
) -> None:
    """Runs ``segments`` segments on every device's batch, reading each one segment late.

    Segment ``k + 1`` is dispatched on every device before segment ``k``'s records are
    read; ``on_segment(k, parts)`` gets segment ``k``'s records of every device
    (``parts[d]`` the list of device ``d``'s record arrays), in order, in the caller's
    thread.
    """
    if segments <= 0:
        return
    # one device: driven from the caller's thread (a study's lane); several: a thread each
    each = (lambda fns: [f() for f in fns]) if len(batches) == 1 else parallel
    each([b.dispatch for b in batches])
    for k in range(segments):
        if k + 1 < segments:  # the next segment runs while this one is read
            parts = each([lambda b=b: (b.dispatch(), b.collect())[1] for b in batches])
        else:
            parts = [b.collect() for b in batches]
        on_segment(k, parts)


def segment_periods(timed, steps: int, target_segments: int = 20) -> int:
    """Largest divisor of the number of control periods giving >= ``target_segments`` segments.

    ``timed``: what has the clocks (a ``timing`` table: a
    :class:`~mjx_radar.engine.run_spec.RunSpec`, a :class:`~mjx_radar.task.task.RadarTask`).
    """
    total = steps // timed.timing.control_every
    for p in range(max(1, total // target_segments), 0, -1):
        if total % p == 0:
            return p
    return 1


def run_on_device(prog, spec, method, seed: int, ids, steps: int, progress=None) -> dict:
    """One batch of trials run to the end on one device, metrics only.

    Args:
        prog: the device's :class:`~mjx_radar.engine.programs.Programs` (``full`` off;
            compiled for ``len(ids)`` trials and :func:`~mjx_radar.engine.runner.
            segment_periods` periods per segment, and serving ``method``).
        spec: the :class:`~mjx_radar.engine.run_spec.RunSpec` (its numbers are the
            program's runtime arguments).
        method: a :class:`~mjx_radar.task.method.Method` or its name; seed: base seed.
        ids: ``[B]`` trial indices.
        steps: filter steps K.
        progress: called with the filter steps done after each segment.

    Returns:
        The loop's metrics and sets (:data:`~mjx_radar.rundir.results.LOOP_COLUMNS`,
        :data:`~mjx_radar.env.records.SET_KEYS`) as numpy arrays ``[B, K, ...]``.

    Raises:
        InputError: a trial cannot place its radars (as :func:`~mjx_radar.engine.runner.
            run_trials`).
    """
    from mjx_radar.engine.programs import record_template
    from mjx_radar.errors import InputError
    from mjx_radar.task.method import parse_method

    params = spec.params(parse_method(method), seed)
    ids = np.asarray(ids, np.int32)
    batch = DeviceBatch(prog, jax.tree.leaves(params), ids)
    placed = batch.placed()
    if not placed.all():
        raise InputError(spec.refusal(int(ids[np.argmin(placed)])))
    every = spec.control_every
    periods = segment_periods(spec, steps)
    template, _ = record_template(False)
    structure = jax.tree.structure(template)
    parts = []

    def segment(k, records):
        parts.append(records[0])
        if progress is not None:
            progress(periods * every)

    run_batches([batch], len(range(0, steps // every, periods)), segment)
    records = [np.concatenate(x, axis=1) for x in zip(*parts, strict=True)]
    return dict(jax.tree.unflatten(structure, records))
