"""The programs of a run's devices: compiled or loaded now, or in the background.

:func:`device_programs` gives every device of a run the same single-device program
(:func:`mjx_radar.engine.programs.compile_programs`). :func:`start` does the
same in a background thread and returns a :class:`PendingPrograms` that
:func:`mjx_radar.engine.runner.run_trials` takes instead of asking again.

Why in the background: a warm run's programs come from the executable cache, and XLA
deserialises and loads them without holding the GIL (2.4 s on an H100 for a paper
shape, 0.4 s on the CPU for smoke). Meanwhile the caller goes on: a run imports its
result writer, a study checks placement for all its shapes and starts its other programs.
"""

from __future__ import annotations

import dataclasses
import time

from mjx_radar.engine import compile_cache, trace_queue
from mjx_radar.engine.programs import compile_programs, device_mesh
from mjx_radar.engine.threads import Started, parallel


def device_programs(
    spec,
    batch: int,
    periods: int,
    full: bool,
    devices,
    kind: str = "all",
    planner: str = "mppi",
    masks: bool = False,
    ready=None,
) -> list:
    """``[(programs, seconds)]``: the single-device program of each device, each for
    ``batch`` trials of the run ``spec`` (:class:`~mjx_radar.engine.run_spec.RunSpec`).
    Every device runs the same per-device program, so a trial's numbers never depend on
    the number of devices.

    On GPUs with the persistent compilation cache on, the first device compiles alone
    and the others then load XLA's result from the cache in parallel threads (JAX's
    GPU cache key holds the device kind, not the device id): one compilation for a
    host's GPUs, where compiling the same program once per GPU in parallel had made
    2 H200s compile longer than one (57 s vs 42 s). Elsewhere (CPU devices, whose key
    holds the device, or no cache) every device compiles, in parallel threads.

    ``ready(i, (programs, seconds))``, if given, is called as soon as device ``i``'s
    program is there (a study's lane starts on it while the others still load).
    """

    def one(i, d):
        mesh = device_mesh([d])
        out = compile_programs(spec, batch, periods, full, mesh, kind, planner, masks)
        if ready is not None:
            ready(i, out)
        return out

    devices = list(devices)
    if not (compile_cache.enabled() and devices[0].platform == "gpu") or len(devices) == 1:
        return parallel([lambda i=i, d=d: one(i, d) for i, d in enumerate(devices)])
    first = parallel([lambda: one(0, devices[0])])
    rest = list(enumerate(devices))[1:]
    return first + parallel([lambda i=i, d=d: one(i, d) for i, d in rest])


def request(spec, batch, periods, full, devices, kind, planner, masks) -> tuple:
    """What identifies the programs :func:`device_programs` gives for these arguments."""
    return (spec.shape, batch, periods, full, tuple(devices), kind, planner, masks)


@dataclasses.dataclass(frozen=True, eq=False)
class PendingPrograms:
    """Programs being compiled or loaded in a background thread (:func:`start`).

    Attributes:
        request: what they are (:func:`request`); a run asking for others ignores them.
        started: the thread; ``started.result()`` is ``(device programs, seconds they
            took)``, waiting for them (an error of the thread is raised there).
        devices: ``{i: (programs, seconds)}`` of the devices whose program is there.
    """

    request: tuple
    started: Started
    devices: dict = dataclasses.field(default_factory=dict)

    def result(self) -> tuple[list, float]:
        """``(device programs, seconds they took)``, once they are there."""
        return self.started.result()

    def device(self, i: int, poll: float = 0.05):
        """Device ``i``'s ``programs``, as soon as they are there (the other devices' may
        still be loading); the thread's error is raised here."""
        while i not in self.devices and self.started.running():
            time.sleep(poll)
        if i not in self.devices:
            self.started.result()  # raises the thread's error, if any
        return self.devices[i][0]


def start(spec, batch, periods, full, devices, kind, planner, masks) -> PendingPrograms:
    """:func:`device_programs` of these arguments, started in a background thread."""
    args = (spec, batch, periods, full, devices, kind, planner, masks)
    ready: dict = {}

    def timed():
        t0 = time.perf_counter()
        out = device_programs(*args, ready=ready.__setitem__)
        return out, time.perf_counter() - t0

    drawn = trace_queue.QUEUE.drawn
    started = Started(timed, name="programs")
    # its place in the tracing order is taken now (engine.trace_queue), not at the
    # thread's leisure: programs started one after the other trace in that order
    trace_queue.QUEUE.wait_drawn(drawn + 1, alive=started.running)
    return PendingPrograms(request(*args), started, ready)
