"""Batched execution of closed-loop trials on the host: vmap over trials, segments over time.

A batch of trials is advanced in segments of control periods by one jitted,
vmapped call per segment (the loop inside a segment never leaves the device);
between segments the host only updates the progress bar. Results come back as
numpy arrays with leading axes ``[T, ...]``.

One program per scenario *shape* (:func:`mjx_radar.task.params.shape_key`), segment
length, output kind and batch size: the method and the scenario's numbers are
runtime arguments (:class:`~mjx_radar.task.params.TaskParams`), so every method of
a scenario, and every scenario that differs only in its numbers, share it (and the
persistent compilation cache, :mod:`mjx_radar.simulation.compile_cache`, keeps it
between processes). Compilation is ahead of time and timed separately.
"""

from __future__ import annotations

import functools
import os
import threading
import time
from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh, NamedSharding, PartitionSpec

from mjx_radar.config import Scenario
from mjx_radar.io import results
from mjx_radar.simulation import closed_loop
from mjx_radar.task.method import parse_method
from mjx_radar.task.params import shape_key, task_params
from mjx_radar.task.task import RadarTask, make_task


def device_mesh(devices=None) -> Mesh:
    """A 1-D mesh (axis ``"trial"``) over ``devices`` (default: every local device)."""
    return Mesh(np.asarray(devices if devices is not None else jax.local_devices()), ("trial",))


@functools.cache
def _programs(task: RadarTask, periods: int, full: bool, mesh: Mesh):
    """``(init, step)``: the vmapped trial loop, ``shard_map``ped over the mesh's devices.

    Every device runs the same per-device program on its own slice of the trials,
    whatever the number of devices, so a trial's numbers depend only on the
    per-device batch size, never on the device count (docs/scaling.md).
    """

    def one(trial, carry, start, params):
        carry, steps, controls = closed_loop.advance(task, params, trial, carry, start, periods)
        if not full:
            steps = {k: getattr(steps, k) for k in results.METRIC_COLUMNS}
            controls = None
        return carry, steps, controls

    def init_one(trial, params):
        return closed_loop.init_carry(task, params, trial)

    split, whole = PartitionSpec("trial"), PartitionSpec()
    init = jax.shard_map(
        jax.vmap(init_one, in_axes=(0, None)), mesh=mesh, in_specs=(split, whole),
        out_specs=split, check_vma=False,
    )  # fmt: skip
    step = jax.shard_map(
        jax.vmap(one, in_axes=(0, 0, None, None)), mesh=mesh,
        in_specs=(split, split, whole, whole), out_specs=split, check_vma=False,
    )  # fmt: skip
    return jax.jit(init), jax.jit(step, donate_argnums=1)


_EXECUTABLES: dict = {}  # (task, periods, full, batch, mesh) -> (init, step)
_LOCK = threading.Lock()
#: one entry per compiled program: tracing + lowering vs XLA compilation (or cache load) [s]
COMPILE_LOG: list[dict] = []


def compile_programs(
    scenario: Scenario, batch: int, periods: int, full: bool = False, mesh: Mesh | None = None
) -> tuple[tuple, float]:
    """Ahead-of-time compiled ``(init, step)`` for a scenario's shape; ``(programs, seconds)``.

    Args:
        scenario: the scenario (only its shape matters).
        batch: trials per call, a multiple of the mesh's device count.
        periods: control periods per segment.
        full: return trajectories (else metrics only).
        mesh: devices to spread the trials over (default: the default device).

    Seconds are 0 when the programs were compiled before in this process (a hit in the
    persistent cache still takes the time to trace and load).
    """
    mesh = mesh if mesh is not None else device_mesh(jax.local_devices()[:1])
    if batch % mesh.size:
        raise ValueError(f"batch {batch} is not a multiple of {mesh.size} devices")
    task = make_task(shape_key(scenario))
    key = (task, periods, full, batch, mesh)
    with _LOCK:
        if key in _EXECUTABLES:
            return _EXECUTABLES[key], 0.0
    t0 = time.perf_counter()
    init, step = _programs(task, periods, full, mesh)
    params = jax.tree_util.tree_map(
        lambda x: jax.ShapeDtypeStruct(jnp.shape(x), jnp.result_type(x)),
        task_params(scenario, parse_method("stationary")),
    )
    sharding = NamedSharding(mesh, PartitionSpec("trial"))
    trials = jax.ShapeDtypeStruct((batch,), jnp.int32, sharding=sharding)
    carry = jax.eval_shape(init, trials, params)[0]
    start = jax.ShapeDtypeStruct((), jnp.int32)
    lowered = (init.lower(trials, params), step.lower(trials, carry, start, params))
    t1 = time.perf_counter()
    programs = tuple(x.compile() for x in lowered)
    t2 = time.perf_counter()
    with _LOCK:
        _EXECUTABLES[key] = programs
        COMPILE_LOG.append({"n_radars": scenario.n_radars, "n_targets": scenario.n_targets,
                            "batch": batch, "devices": mesh.size, "trace_lower_s": t1 - t0,
                            "xla_compile_s": t2 - t1})  # fmt: skip
    return programs, t2 - t0


def precompile(
    jobs, batch: int, steps: int, full: bool = False, mesh=None, workers: int | None = None
):
    """Compiles the programs of several scenarios concurrently; returns the wall time [s].

    XLA compilation releases the GIL, so a thread pool compiles the programs of a
    study's scenario shapes in parallel on the host's cores. ``jobs`` holds scenarios
    (or tuples whose first item is the scenario); scenarios of the same shape share one
    program.
    """
    from concurrent.futures import ThreadPoolExecutor

    shapes = {}
    for job in jobs:
        s = job[0] if isinstance(job, tuple) else job
        shapes.setdefault(shape_key(s), s)
    todo = list(shapes.values())
    if not todo:
        return 0.0
    t0 = time.perf_counter()
    workers = workers or min(len(todo), os.cpu_count() or 1)
    with ThreadPoolExecutor(max_workers=workers) as pool:
        list(
            pool.map(
                lambda s: compile_programs(s, batch, segment_periods(s, steps), full, mesh), todo
            )
        )
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
    method,
    seed: int,
    trials,
    steps: int,
    full: bool = True,
    progress: Callable[[int], None] | None = None,
    periods: int | None = None,
    mesh: Mesh | None = None,
    phase: Callable[[str], None] | None = None,
) -> dict:
    """Runs the closed loop for a batch of trials.

    Args:
        scenario: scenario (its numbers are runtime arguments of the program).
        method: a :class:`~mjx_radar.task.method.Method` or its name.
        seed: base seed.
        trials: [T] trial indices (common random numbers across methods).
        steps: filter steps K (a multiple of the control period).
        full: also return trajectories and MPPI samples (else only the metrics).
        progress: called with the number of filter steps done after each segment.
        periods: control periods per segment (default: :func:`segment_periods`).
        mesh: devices to spread the trials over (:func:`device_mesh`); ``T`` must be a
            multiple of their number. ``None``: the default device.
        phase: called with ``"compiling"`` and ``"simulating"`` as the run moves on.

    Returns:
        dict of numpy arrays: ``rmse_pos, rmse_state, nees, crlb_pos, obstacle_contacts,
        visible_pairs`` [T, K] (:data:`results.METRIC_COLUMNS`), and if
        ``full`` the fields of ``StepRecord`` / ``ControlRecord`` with leading [T, ...],
        plus ``placement_ok`` [T], ``compile_s`` (ahead-of-time compilation, 0 if this
        process compiled it before), ``sim_s`` (the simulation), ``wall_s`` (both) and
        ``control_hz`` (control periods per second of the batch during the simulation).
    """
    every = scenario.timing.control_every
    if steps % every:
        raise ValueError(f"steps: {steps} must be a multiple of {every}")
    periods = periods or segment_periods(scenario, steps)
    params = task_params(scenario, parse_method(method), seed)
    trials = jnp.asarray(trials, jnp.int32)
    if phase:
        phase("compiling")
    (init, step), compile_s = compile_programs(scenario, trials.shape[0], periods, full, mesh)
    trials = jax.device_put(trials, init.input_shardings[0][0])
    if phase:
        phase("simulating")
    t0 = time.perf_counter()
    carry, ok = init(trials, params)
    chunks = []
    for start in range(0, steps // every, periods):
        carry, srec, crec = step(trials, carry, jnp.int32(start), params)
        chunks.append(jax.device_get((srec, crec)))
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
    sim_s = time.perf_counter() - t0
    out |= {"compile_s": compile_s, "sim_s": sim_s, "wall_s": compile_s + sim_s}
    out["control_hz"] = (steps // every) / sim_s
    return out


def _get(rec, k):
    return rec[k] if isinstance(rec, dict) else getattr(rec, k)
