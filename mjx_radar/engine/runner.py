"""Batched execution of closed-loop trials on the host: vmap over trials, segments over time.

A batch of trials is advanced in segments of control periods by one compiled call
per segment (the loop inside a segment never leaves the device); between segments
the host only updates the progress bar. Results come back as numpy arrays with
leading axes ``[T, ...]``.

One program per scenario *shape* (:func:`mjx_radar.task.params.shape_key`), program
kind (the method's information kind: ``none``, ``sfim``, ``pfim``), segment length,
output kind, batch and device mesh (:mod:`mjx_radar.engine.programs`): the noise
model and the scenario's numbers are runtime arguments
(:class:`~mjx_radar.task.params.TaskParams`), so the CCR and DDR methods of a kind,
and every scenario that differs only in its numbers, share it; a run compiles only
the information it needs (stationary radars: no planner), while a study runs the
built-in methods of a shape in one program (kinds ``sfim+none``, ``pfim+none``,
``sfim+pfim+none``: hold or plan by runtime flags, the same numbers;
:func:`program_map`). Compilation is ahead of time and timed apart from the simulation.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import jax
import numpy as np
from jax.sharding import Mesh

from mjx_radar.engine import device_programs as pending_programs
from mjx_radar.engine.device_lane import DeviceBatch, run_batches, segment_periods
from mjx_radar.engine.device_programs import PendingPrograms, device_programs
from mjx_radar.engine.oom import oom_as_input_error
from mjx_radar.engine.program_jobs import program_jobs, program_map, programs_needed
from mjx_radar.engine.programs import (
    COMPILE_LOG,
    compile_programs,
    device_mesh,
    record_template,
)
from mjx_radar.engine.run_spec import RunSpec
from mjx_radar.engine.threads import parallel
from mjx_radar.env.records import control_arrays
from mjx_radar.errors import InputError
from mjx_radar.scenario.schema_metrics import MetricsConfig
from mjx_radar.task.method import parse_method, runs

__all__ = [
    "COMPILE_LOG",
    "compile_programs",
    "device_mesh",
    "precompile",
    "program_log",
    "program_map",
    "programs_needed",
    "run_trials",
    "segment_periods",
    "set_metrics",
    "start_programs",
]


def precompile(jobs, batch: int, steps: int, full: bool = False, mesh=None) -> float:
    """Compiles the programs of several runs concurrently; returns the wall time [s].

    XLA compilation releases the GIL, so a thread pool compiles the programs of a
    study's scenario shapes and program kinds in parallel on the host's cores.
    ``jobs`` holds ``(spec, method)`` pairs (a :class:`~mjx_radar.engine.run_spec.RunSpec`,
    a method or its name), or specs alone (every method's kind); jobs of the same shape
    and kind share one program.
    """
    todo = program_jobs(jobs)
    devices = list(mesh.devices.flat) if mesh is not None else jax.local_devices()[:1]
    t0 = time.perf_counter()
    parallel(
        [  # one thread per shape and kind (big stacks: XLA's compiler recurses deeply)
            lambda s=s, k=k, p=p: device_programs(
                s, batch // len(devices), segment_periods(s, steps), full, devices, k, p
            )
            for s, k, p in todo
        ]
    )
    return time.perf_counter() - t0


def program_log(since: int = 0) -> list[dict]:
    """The programs this process compiled from entry ``since`` of :data:`COMPILE_LOG` on:
    scenario and shape, batch, kind, periods, ``full``, planner, program key, source
    (traced or export cache), trace-and-lower and XLA seconds."""
    return [
        {k: round(v, 2) if isinstance(v, float) else v for k, v in e.items()}
        for e in COMPILE_LOG[since:]
    ]


@oom_as_input_error
def run_trials(
    spec: RunSpec,
    method,
    seed: int,
    trials,
    steps: int,
    full: bool = True,
    progress: Callable[[int], None] | None = None,
    periods: int | None = None,
    mesh: Mesh | None = None,
    phase: Callable[[str], None] | None = None,
    on_segment: Callable[[int, tuple], None] | None = None,
    masks: bool = False,
    program: tuple[str, str] | None = None,
    sets: bool = True,
    programs: PendingPrograms | None = None,
) -> dict:
    """Runs the closed loop for a batch of trials.

    Args:
        spec: the run's :class:`~mjx_radar.engine.run_spec.RunSpec` (its numbers are
            runtime arguments of the program; :func:`~mjx_radar.engine.run_spec.run_spec`).
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
        on_segment: called after each segment, in this thread, with the filter steps
            done and the segment's records, already on the host: ``(StepRecord,
            ControlRecord)`` of numpy arrays ``[T, steps or control steps of the
            segment, ...]`` (if ``full``; else the metrics dict and ``None``). The next
            segment already runs meanwhile (engine.device_lane); keep it cheap (e.g.
            :meth:`mjx_radar.viz.live_view.live.LiveView.update`).
        masks: with ``full``, also the per-pair masks ``visible`` and ``detected``
            ``[T, K, N, M]`` (a program of its own; off: they are not computed).
        program: ``(kind, planner)`` of the program to run the method with: one that
            serves the method's kind (a study's shared program, :func:`program_map`;
            the same numbers; :func:`mjx_radar.task.method.runs`); None: its own.
        sets: compute the set metrics (GOSPA, OSPA, continuity) on the host here; False:
            leave the sets in the result for :func:`set_metrics` (a study computes them
            in a background thread while the devices run its next chunks).
        programs: the programs of :func:`start_programs` for these arguments (started
            before the caller's checks, so that loading them overlaps with those);
            ignored if they are for other arguments.

    Returns:
        dict of numpy arrays: the metrics (:data:`mjx_radar.rundir.results.METRIC_COLUMNS`)
        [T, K] (GOSPA, OSPA and continuity: on the host after the loop), and if ``full``
        the fields of ``StepRecord`` / ``ControlRecord`` with leading [T, ...]; plus
        ``placement_ok`` [T], ``compile_s`` (ahead-of-time compilation, 0 if this process
        compiled it before), ``sim_s`` (the simulation), ``wall_s`` (both) and
        ``control_hz`` (control periods per second of the batch).

    Raises:
        InputError: a trial cannot place its radars (the initial conditions' own
            ``placement_ok``, read before the first step; one line naming the fields);
            XLA ran out of memory compiling or running the programs (one line naming
            the batch and what to reduce, :func:`~mjx_radar.engine.oom.oom_line`).
    """
    method, args = _program_args(spec, method, trials, steps, full, periods, mesh, masks, program)
    params = spec.params(method, seed)
    progs, compile_s = _programs(args, programs, phase)
    t0 = time.perf_counter()
    batches, placed = _batches(spec, progs, params, np.asarray(trials, np.int32))
    template = record_template(full, masks)
    every, periods = spec.control_every, args[2]
    report = (progress, on_segment, periods * every)
    chunks = _run_segments(batches, len(range(0, steps // every, periods)), template, report)
    res = _gather(template, chunks, full) | {"placement_ok": placed}
    sim_s = time.perf_counter() - t0
    if sets:
        res |= set_metrics(spec.metrics, res, full)
    return res | _timing(compile_s, sim_s, steps // every)


def _timing(compile_s: float, sim_s: float, periods: int) -> dict:
    """A run's seconds and control periods per second of the simulation."""
    times = {"compile_s": compile_s, "sim_s": sim_s, "wall_s": compile_s + sim_s}
    return times | {"control_hz": periods / sim_s}


def _programs(args: tuple, programs: PendingPrograms | None, phase) -> tuple[list, float]:
    """``(per-device programs, compile seconds)``: ``programs`` if started for ``args``,
    else made now (0 s when every one came from a cache); ``phase`` told."""
    if phase:
        phase("compiling")
    t0 = time.perf_counter()
    if programs is not None and programs.request == pending_programs.request(*args):
        progs, compile_s = programs.result()
    else:
        progs, compile_s = device_programs(*args), time.perf_counter() - t0
    compile_s = 0.0 if all(s == 0.0 for _, s in progs) else compile_s
    if phase:
        phase("simulating")
    return progs, compile_s


def _batches(spec, progs, params, trials) -> tuple[list[DeviceBatch], np.ndarray]:
    """Each device's batch of the trials (its slice, its own thread, its segments read one
    segment late: engine.device_lane) and ``placement_ok`` [T]; ``InputError`` before any
    step if a trial cannot place its radars."""
    leaves = jax.tree.leaves(params)
    slices = np.split(trials, len(progs))
    batches = [DeviceBatch(prog, leaves, ids) for (prog, _), ids in zip(progs, slices, strict=True)]
    placed = np.concatenate([b.placed() for b in batches])
    if not placed.all():  # refused before any step: nothing written
        raise InputError(spec.refusal(int(trials[np.argmin(placed)])))
    return batches, placed


def _run_segments(batches, n_segments: int, template, report) -> list:
    """Runs the segments; each segment's records of every device, concatenated in order,
    unflattened as ``template`` (``report``: progress, on_segment, filter steps a segment)."""
    progress, on_segment, seg_steps = report
    structure = jax.tree.structure(template)
    chunks = []

    def segment(k, parts):  # segment k's records of every device, in order
        records = [np.concatenate(x, axis=0) for x in zip(*parts, strict=True)]
        chunks.append(jax.tree.unflatten(structure, records))
        if progress is not None:
            progress(seg_steps)
        if on_segment is not None:
            on_segment((k + 1) * seg_steps, chunks[-1])

    run_batches(batches, n_segments, segment)
    return chunks


def _gather(template, chunks: list, full: bool) -> dict:
    """The segments' records joined along time: ``{field: [T, K or C, ...]}``."""
    res: dict = {}
    steps_t, controls_t = template
    for k in steps_t._fields if full else steps_t:
        if _get(steps_t, k) is None:  # a mask not asked for
            continue
        res[k] = np.concatenate([_get(c[0], k) for c in chunks], axis=1)
    if full:
        for k in control_arrays(controls_t):
            res[k] = np.concatenate([control_arrays(c[1])[k] for c in chunks], axis=1)
    return res


def _program_args(spec, method, trials, steps, full, periods, mesh, masks, program):
    """``(method, device_programs arguments)`` of a run, checked (ValueError)."""
    every = spec.control_every
    if steps % every:
        raise ValueError(f"steps: {steps} must be a multiple of {every}")
    method = parse_method(method)
    program = program or (method.kind, method.planner)
    if not runs(program, method):
        raise ValueError(f"program {program}: does not run the method {method.name}")
    devices = list(mesh.devices.flat) if mesh is not None else jax.local_devices()[:1]
    n = np.shape(trials)[0]
    if n % len(devices):
        raise ValueError(f"{n} trials are not a multiple of {len(devices)} devices")
    batch = n // len(devices)
    periods = periods or segment_periods(spec, steps)
    return method, (spec, batch, periods, full, devices, *program, masks)


def start_programs(
    spec: RunSpec,
    method,
    trials,
    steps: int,
    full: bool = True,
    periods: int | None = None,
    mesh: Mesh | None = None,
    masks: bool = False,
    program: tuple[str, str] | None = None,
) -> PendingPrograms:
    """Starts compiling or loading the programs :func:`run_trials` will need for these
    arguments (the same meaning) in a background thread; pass the result to it as
    ``programs``. Raises ValueError as it would."""
    _, args = _program_args(spec, method, trials, steps, full, periods, mesh, masks, program)
    return pending_programs.start(*args)


def set_metrics(metrics: MetricsConfig, res: dict, full: bool = False) -> dict:
    """GOSPA, OSPA and continuity per trial and step of a :func:`run_trials` result
    (host, after the run; the sets of a metrics-only run are dropped from ``res``), with
    the cutoff and order of the scenario's ``[metrics]`` table ``metrics``."""
    from mjx_radar.env.records import SET_KEYS, estimate_sets
    from mjx_radar.rundir.results import set_columns

    if full:
        sets = estimate_sets(res["target"], res["track_pos"], res["track_exist"], res["present"])
    else:
        sets = {k: res.pop(k) for k in SET_KEYS}
    return set_columns(sets, metrics.gospa_cutoff, metrics.gospa_order)


def _get(rec, k):
    return rec[k] if isinstance(rec, dict) else getattr(rec, k)
