"""A study's programs, all started at once in the order its chunks need them.

A study needs one compiled program per scenario shape, program kind, planner and segment
length (:func:`mjx_radar.engine.runner.program_map`: the built-in methods of a shape
share one). :func:`start` starts them all in the background, in the order the chunks
need them (:func:`mjx_radar.engine.runner.start_programs`); the devices' lanes
(:mod:`mjx_radar.study.lanes`) run the chunks in study order, each as soon as its own
program is there. So the devices simulate the first shape while XLA still compiles the
others: a process traces one program at a time (tracing holds the GIL;
:mod:`mjx_radar.engine.programs`), and the first program goes to XLA after its own
tracing, not after everyone's.

The study's ``compile_s`` counts the seconds compilation held the devices back: from the
programs' start to the first chunk (the placement check runs meanwhile), then the
seconds no device ran a chunk while waiting for a program; ``compile_wall_s`` is the
time from the start until the last program was ready, which overlaps the simulation.
Same programs, same numbers: only when they run changes.
"""

from __future__ import annotations

import time

import numpy as np

__all__ = ["StudyPrograms", "program_key", "start"]


def program_key(chunk, programs: dict) -> tuple:
    """What identifies the program a chunk runs in a study: ``(shape, (kind, planner),
    steps)`` (the batch, device mesh and output kind are the study's own)."""
    shape = chunk.spec.shape
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
    programs = runner.program_map([(c.spec, c.method) for c in todo])
    pending: dict = {}
    ids = np.zeros(batch, np.int32)  # only their number matters
    for c in todo:
        key = program_key(c, programs)
        if key not in pending:
            pending[key] = runner.start_programs(
                c.spec, c.method, ids, c.steps, full=False, mesh=mesh, program=key[1]
            )
    return StudyPrograms(pending, programs, t0)
