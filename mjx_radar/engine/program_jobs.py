"""Which compiled programs a set of study jobs needs (:func:`mjx_radar.engine.runner.precompile`).

A job is a ``(spec, method)`` pair or a spec alone (every method; a
:class:`~mjx_radar.engine.run_spec.RunSpec`). Programs are per scenario shape, program
kind and planner; per shape the built-in methods share one program
(:func:`mjx_radar.task.method.shared_programs`).
"""

from __future__ import annotations

from mjx_radar.task.method import METHODS, parse_method, shared_programs

__all__ = ["program_jobs", "program_map", "programs_needed"]


def program_map(jobs) -> dict[tuple, tuple[str, str]]:
    """``{(shape, method name): (program kind, planner)}`` of ``jobs``: per scenario
    shape, the built-in methods share one program
    (:func:`mjx_radar.task.method.shared_programs`)."""
    by_shape: dict = {}
    for job in jobs:
        s, methods = (job[0], job[1:2]) if isinstance(job, tuple) else (job, ())
        names = [parse_method(m).name for m in methods] or list(METHODS)
        by_shape.setdefault(s.shape, {}).update(dict.fromkeys(names))
    return {
        (shape, name): program
        for shape, names in by_shape.items()
        for name, program in shared_programs(names).items()
    }


def program_jobs(jobs) -> list[tuple]:
    """``(spec, kind, planner)`` of each distinct program of ``jobs``: one per shape,
    program kind and planner (:func:`program_map`)."""
    programs = program_map(jobs)
    out = {}
    for job in jobs:
        s = job[0] if isinstance(job, tuple) else job
        own = s.shape
        for (shape, _), (kind, planner) in programs.items():
            if shape == own:
                out.setdefault((shape, kind, planner), (s, kind, planner))
    return list(out.values())


def programs_needed(jobs, n_devices: int) -> int:
    """How many compiled programs ``jobs`` hold alive on ``n_devices`` devices: one per
    shape, program kind and planner *per device*
    (:func:`~mjx_radar.engine.device_programs.device_programs`), the count a study keeps alive
    (:func:`mjx_radar.engine.live_programs.keep_alive`)."""
    return len(program_jobs(jobs)) * n_devices
