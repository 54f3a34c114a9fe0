"""A study's chunks run in lanes, one per device, each taking the next chunk as it frees up.

Each device has a lane: a thread that takes the next chunk of the study as soon as its
previous one is done (of the chunks whose program is ready on its device, one of the
first such program in study order, the costliest method first; if none is ready, the
next chunk in study order, waiting for its program: :mod:`mjx_radar.study.schedule`),
runs it to the end on its device (:func:`mjx_radar.engine.device_lane.run_on_device`:
every segment dispatched before the one before it is read) and hands its arrays to the
host pool (:class:`mjx_radar.study.host_work.HostPool`), which computes the set metrics
and writes the files while the lane runs its next chunk. No lane waits for another: the
devices are never held in lockstep, chunks of different scenarios and methods run side
by side, and the host never sits between a device and its next chunk.

Numbers: every device runs the same single-device program for its scenario shape on a
chunk of ``chunk`` trials (the last one padded), so a trial's numbers do not depend on
which device ran it, on the number of devices, nor on the order chunks finish in.

Times (``study.json``): ``sim_s`` is the time at least one device was running a chunk;
``compile_s`` the time from the programs' start until the end of the last chunk when no
device ran one (waiting for programs); ``timeline`` one entry per chunk (device,
seconds from the programs' start to its start and end, seconds waited for its program
and for a free host slot).
"""

from __future__ import annotations

import os
import sys
import threading
import time

import numpy as np

__all__ = ["host_workers", "run_lanes"]


#: ``$MJX_RADAR_PROGRAMS_FIRST=1``: no lane starts before every program is on every device
PROGRAMS_FIRST_ENV = "MJX_RADAR_PROGRAMS_FIRST"


def programs_first() -> bool:
    """Whether the lanes wait for every program on every device before their first chunk
    (``$MJX_RADAR_PROGRAMS_FIRST`` = ``1``): the simulation then runs alone, without the
    programs still compiling and loading beside it, and ``sim_s`` measures the devices'
    scaling. By default a lane starts as soon as its first chunk's program is there,
    which overlaps the two (docs/scaling.md compares them)."""
    return os.environ.get(PROGRAMS_FIRST_ENV, "0").strip() not in ("", "0")


def host_workers(n_dev: int) -> int:
    """Host threads for ``n_dev`` devices: one more than the devices, at most half the
    host's cores (at least one)."""
    return max(1, min(n_dev + 1, (os.cpu_count() or 2) // 2))


#: the order in which a lane takes the chunks of one ready program: the costliest first,
#: so that the study ends on short chunks that fill the devices evenly
_COST_RANK = {"pfim": 0, "sfim": 1, "none": 2}


def _rank(chunk) -> int:
    from mjx_radar.task.method import parse_method

    return _COST_RANK.get(parse_method(chunk.method).info, 1)


class _Queue:
    """The chunks still to run. A lane takes, of the chunks whose program is ready on its
    device, one of the first program in study order, the costliest method first
    (:data:`_COST_RANK`); when none is ready, the next chunk in study order (and waits for
    its program)."""

    def __init__(self, todo, program, ready):
        # (its program's place in study order, chunk), once per chunk; sorted stably
        self._todo = sorted(((program(c), c) for c in todo), key=lambda x: (x[0], _rank(x[1])))
        self._ready = ready  # (program's place, device) -> bool
        self.programs = 1 + max((k for k, _ in self._todo), default=-1)
        self._lock = threading.Lock()
        self.stop = threading.Event()

    def take(self, device: int):
        with self._lock:
            if self.stop.is_set() or not self._todo:
                return None
            i = next((i for i, (k, _) in enumerate(self._todo) if self._ready(k, device)), 0)
            return self._todo.pop(i)[1]

    def wait_for_every_program(self, devices: int, poll: float = 0.05) -> None:
        """Returns once every program is on each of ``devices`` devices (or failed), or
        the queue is stopped: a lane's start under :func:`programs_first`."""

        def loaded():
            return all(self._ready(k, d) for k in range(self.programs) for d in range(devices))

        while not loaded() and not self.stop.is_set():
            time.sleep(poll)


def _covered(intervals: list[tuple[float, float]]) -> float:
    """Length of the union of ``[start, end]`` intervals."""
    total, end = 0.0, -np.inf
    for a, b in sorted(intervals):
        if b > end:
            total += b - max(a, end)
            end = b
    return total


def run_lanes(args, todo, mesh, times, started, stream=None) -> dict:
    """Runs the chunks ``todo`` on the devices of ``mesh``, one lane per device.

    Args:
        args: the study's options (``chunk``, ``progress``).
        todo: the chunks to run, in study order.
        mesh: the devices (each runs its own single-device programs).
        times: the study's :class:`~mjx_radar.study.driver.StudyTimes`: ``compile_s``,
            ``compile_wall_s``, ``sim_s`` and ``chunks_run`` are added to.
        started: the programs in the making (:func:`mjx_radar.study.schedule.start`).
        stream: the study's :class:`~mjx_radar.study.consolidate.Stream`, or None.

    Returns:
        ``study.json``'s ``host`` section: the host threads, their summed seconds per
        part, the seconds lanes waited for them, the seconds after the last chunk's
        simulation until its files were written, and the per-chunk ``timeline``.
    """
    from mjx_radar.engine.device_lane import run_on_device
    from mjx_radar.engine.threads import Started
    from mjx_radar.study.host_work import HostPool
    from mjx_radar.study.schedule import program_key

    devices = list(mesh.devices.flat)
    queue, t0 = _queue(todo, started), started.t0
    bar = _bar(todo, args.progress)
    bar_lock = threading.Lock()
    timeline: list[dict] = []
    errors: list[BaseException] = []

    def lane(d: int, pool: HostPool) -> None:
        if programs_first():
            queue.wait_for_every_program(len(devices))
        while (c := queue.take(d)) is not None:
            n = c.last - c.first + 1
            key = program_key(c, started.programs)
            t_ask = time.perf_counter()
            prog = _guard_oom(c, args.chunk, started.pending[key].device, d)
            t_run = time.perf_counter()

            def progress(k, n=n):
                with bar_lock:
                    bar.update(k * n)
                    bar.set_postfix_str(f"{c.spec.name} {c.method}", refresh=False)

            ids = np.concatenate([np.arange(c.first, c.last + 1), np.full(args.chunk - n, c.last)])
            run = (prog, c.spec, c.method, c.seed, ids, c.steps, progress)
            res = _guard_oom(c, args.chunk, run_on_device, *run)
            t_end = time.perf_counter()
            pool.submit(*_chunk_job(c, res))
            timeline.append(_entry(d, c.path.name, t0, t_ask, t_run, t_end))

    def guarded(d, pool):
        try:
            lane(d, pool)
        except BaseException as err:  # noqa: BLE001 -- raised in the caller's thread
            errors.append(err)
            queue.stop.set()

    with bar, HostPool(host_workers(len(devices)), stream) as pool:
        lanes = [
            Started(lambda d=d: guarded(d, pool), name=f"lane-{d}") for d in range(len(devices))
        ]
        try:
            for running in lanes:
                running.wait()
        except BaseException:
            queue.stop.set()  # Ctrl-C: no lane takes another chunk
            raise
        if errors:
            raise errors[0]
        t_sim_end = max((e["end_s"] for e in timeline), default=0.0)
        pool.drain()
    return _account(times, started, timeline, pool, t_sim_end)


def _entry(device: int, chunk: str, t0: float, t_ask: float, t_run: float, t_end: float):
    """A chunk's line of the ``timeline``: seconds from the programs' start ``t0``."""
    return {
        "device": device,
        "chunk": chunk,
        "start_s": t_run - t0,
        "end_s": t_end - t0,
        "program_wait_s": t_run - t_ask,
        "host_wait_s": time.perf_counter() - t_end,
    }


def _queue(todo, started) -> _Queue:
    """The chunks' queue: each chunk's program numbered in study order, and whether a
    device's copy of a program is there (or failed)."""
    from mjx_radar.study.schedule import program_key

    order = {}  # program key -> its place in study order
    for c in todo:
        order.setdefault(program_key(c, started.programs), len(order))
    keys = list(order)

    def ready(k: int, d: int) -> bool:  # device d's copy of program k is there (or failed)
        pending = started.pending[keys[k]]
        return d in pending.devices or not pending.started.running()

    return _Queue(todo, lambda c: order[program_key(c, started.programs)], ready)


def _bar(todo, progress: bool):
    """The study's progress bar on stderr, in trial-steps (disabled: no chunk, no progress)."""
    from tqdm import tqdm

    total = sum(c.steps * (c.last - c.first + 1) for c in todo)
    return tqdm(
        total=total,
        unit="trial-step",
        desc="study",
        file=sys.stderr,
        dynamic_ncols=True,
        disable=not todo or not progress,
    )


def _chunk_job(c, res: dict) -> tuple:
    """``(ChunkJob, loop columns, sets)`` of a chunk's result, for the host threads."""
    from mjx_radar.rundir.results import LOOP_COLUMNS
    from mjx_radar.study.host_work import ChunkJob

    s = c.spec
    cfg = (s.timing.dt_filter, s.metrics.gospa_cutoff, s.metrics.gospa_order)
    job = ChunkJob(c.path, s.name, c.method, c.first, c.last, *cfg)
    loop = {k: v for k, v in res.items() if k in LOOP_COLUMNS}
    sets = {k: v for k, v in res.items() if k not in loop}
    return job, loop, sets


def _account(times, started, timeline, pool, t_sim_end: float) -> dict:
    """Adds the lanes' seconds to ``times`` and returns the ``host`` section."""
    running = [(e["start_s"], e["end_s"]) for e in timeline]
    sim = _covered(running)
    times.sim_s += sim
    times.compile_s += max(0.0, t_sim_end - sim) if timeline else 0.0
    times.compile_wall_s = max((p.result()[1] for p in started.pending.values()), default=0.0)
    times.chunks_run += pool.done
    tail = max(0.0, pool.last_done - started.t0 - t_sim_end) if pool.done else 0.0
    return {
        "workers": pool.workers,
        "seconds": {k: round(v, 3) for k, v in sorted(pool.seconds.items())},
        "lanes_waited_s": round(pool.waited_s, 3),
        "after_last_chunk_s": round(tail, 3),
        "timeline": sorted((_rounded(e) for e in timeline), key=lambda e: e["start_s"]),
    }


def _rounded(entry: dict) -> dict:
    return {k: round(v, 3) if isinstance(v, float) else v for k, v in entry.items()}


def _guard_oom(chunk, per_device: int, fn, *args):
    """``fn(*args)``; XLA running out of memory (compiling or running ``chunk``) becomes one
    :class:`~mjx_radar.errors.InputError` line (:mod:`mjx_radar.engine.oom`)."""
    from mjx_radar.engine.oom import oom_line, out_of_memory
    from mjx_radar.errors import InputError

    try:
        return fn(*args)
    except Exception as err:
        if not out_of_memory(err):
            raise
        raise InputError(oom_line(chunk.spec, per_device, err)) from None
