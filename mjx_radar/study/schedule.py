"""A study's programs, all started at once, and its rounds, each run once its program is ready.

A study needs one compiled program per scenario shape, program kind, planner and segment
length (:func:`mjx_radar.engine.runner.program_map`: the built-in methods of a shape
share one). :func:`start` starts them all in the background, in the order the rounds
need them (:func:`mjx_radar.engine.runner.start_programs`); :func:`run_rounds` runs the
rounds of chunks in study order, each as soon as its own program is there. So the
devices simulate the first shape while XLA still compiles the others: a process traces
one program at a time (tracing holds the GIL; :mod:`mjx_radar.engine.programs`), and the
first program goes to XLA after its own tracing, not after everyone's.

The study's ``compile_s`` counts the seconds compilation held the devices back: from the
programs' start to the first round (the placement check runs meanwhile), then what later
rounds waited for theirs; ``compile_wall_s`` is the time from the start until the last
program was ready, which overlaps the simulation. Same programs, same numbers: only
when they run changes.
"""

from __future__ import annotations

import sys
import time

import numpy as np

__all__ = ["StudyPrograms", "program_key", "run_rounds", "start"]


def program_key(chunk, programs: dict) -> tuple:
    """What identifies the program a chunk runs in a study: ``(shape, (kind, planner),
    steps)`` (the batch, device mesh and output kind are the study's own)."""
    from mjx_radar.task.params import shape_key

    shape = shape_key(chunk.scenario)
    return shape, programs[(shape, chunk.method)], chunk.steps


class StudyPrograms:
    """A study's programs in the making: ``pending`` ``{program_key: PendingPrograms}``,
    ``programs`` the chunks' :func:`mjx_radar.engine.runner.program_map`, ``t0`` when
    they were started (``time.perf_counter``)."""

    def __init__(self, pending: dict, programs: dict, t0: float):
        self.pending, self.programs, self.t0 = pending, programs, t0

    def __len__(self) -> int:
        return len(self.pending)


def start(todo, batch: int, mesh) -> StudyPrograms:
    """The programs of the chunks ``todo`` (``batch`` trials per call over ``mesh``),
    started in background threads in the order of the chunks (and traced in that order:
    :mod:`mjx_radar.engine.trace_queue`)."""
    from mjx_radar.engine import runner

    t0 = time.perf_counter()
    programs = runner.program_map([(c.scenario, c.method) for c in todo])
    pending: dict = {}
    ids = np.zeros(batch, np.int32)  # only their number matters
    for c in todo:
        key = program_key(c, programs)
        if key not in pending:
            pending[key] = runner.start_programs(
                c.scenario, c.method, ids, c.steps, full=False, mesh=mesh, program=key[1]
            )
    return StudyPrograms(pending, programs, t0)


def run_rounds(args, todo, n_dev: int, mesh, times, started: StudyPrograms, stream=None) -> None:
    """Runs the chunks ``todo`` in rounds of one per device (study order), each round as
    soon as its program (of ``started``) is ready, the chunk files written in the
    background (:class:`mjx_radar.study.chunks.Background`). Adds the seconds compilation
    held the devices back to ``times.compile_s`` (from the programs' start to the first
    round, then what later rounds waited) and sets ``times.compile_wall_s``. ``stream``:
    a :class:`~mjx_radar.study.consolidate.Stream` that gets each chunk's table."""
    from tqdm import tqdm

    from mjx_radar.study import chunks as chunks_of
    from mjx_radar.study import driver

    total = sum(c.steps * (c.last - c.first + 1) for c in todo)
    bar = tqdm(
        total=total,
        unit="trial-step",
        desc="study",
        file=sys.stderr,
        dynamic_ncols=True,
        disable=not todo or not args.progress,
    )
    first = True
    with bar, chunks_of.Background() as writer:  # host metrics and files beside the next round
        for group in chunks_of.rounds(todo, n_dev):
            key = program_key(group[0], started.programs)
            programs = started.pending[key]
            t_wait = started.t0 if first else time.perf_counter()
            programs.started.wait()
            times.compile_s += time.perf_counter() - t_wait
            first = False
            bar.set_postfix_str(f"{group[0].scenario.name} {group[0].method}")
            done = sum(c.last - c.first + 1 for c in group)
            progress = lambda k, n=done: bar.update(k * n)  # noqa: E731
            driver.run_round(
                group, args.chunk, n_dev, mesh, progress, times, key[1], writer, programs, stream
            )
    # each program's seconds from its start (all started together) to ready
    times.compile_wall_s = max((p.result()[1] for p in started.pending.values()), default=0.0)
