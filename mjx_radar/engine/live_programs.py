"""The compiled programs kept alive in one process: a bounded LRU, and a warning near
the kernel's memory-map limit.

XLA's CPU JIT maps memory for every executable, and a compiled program lives as long
as something holds it. A script that loops over many scenarios and methods in one
process used to keep every program it ever compiled (``LLVM compilation error: Cannot
allocate memory`` after ~28 programs at ``vm.max_map_count = 65530``). At most
:func:`capacity` programs stay alive (``$MJX_RADAR_LIVE_PROGRAMS``, default 8); an
evicted one is loaded again from the persistent compilation cache when needed.
"""

from __future__ import annotations

import contextlib
import os
import sys
from collections import OrderedDict
from pathlib import Path

DEFAULT_LIVE = 8
MAP_WARN_FRACTION = 0.8
_warned: list[bool] = []
_floors: list[int] = []  # the programs that running studies need alive at once


def capacity() -> int:
    """Programs kept alive: ``$MJX_RADAR_LIVE_PROGRAMS`` (an integer >= 1), else 8; at
    least what a running study holds (:func:`keep_alive`)."""
    try:
        cap = max(1, int(os.environ.get("MJX_RADAR_LIVE_PROGRAMS", DEFAULT_LIVE)))
    except ValueError:
        cap = DEFAULT_LIVE
    return max([cap, *_floors])


@contextlib.contextmanager
def keep_alive(programs: int):
    """Raises the capacity to ``programs`` while the block runs.

    A study compiles all its programs at once and then runs them one after the other;
    with fewer alive than it compiled, each evicted program would be loaded again
    (about 10 s apiece on an H100: 21 programs of a planner study spent 205 s so). The
    memory-map warning still fires near the kernel's limit.
    """
    _floors.append(int(programs))
    try:
        yield
    finally:
        _floors.remove(int(programs))


class LiveCache(OrderedDict):
    """A dict of the live programs, least recently used first, at most :func:`capacity`."""

    def __getitem__(self, key):
        value = super().__getitem__(key)
        self.move_to_end(key)
        return value

    def __setitem__(self, key, value):
        super().__setitem__(key, value)
        self.move_to_end(key)
        while len(self) > capacity():
            self.popitem(last=False)  # the program is freed once no run holds it
        warn_near_map_limit()


def map_usage() -> tuple[int, int] | None:
    """``(memory maps of this process, vm.max_map_count)`` on Linux, else None."""
    try:
        limit = int(Path("/proc/sys/vm/max_map_count").read_text())
        with open("/proc/self/maps", "rb") as f:
            used = sum(1 for _ in f)
    except (OSError, ValueError):
        return None
    return used, limit


def warn_near_map_limit(stream=None) -> bool:
    """One line (once per process) when the maps in use pass 80 % of the kernel's limit."""
    usage = map_usage()
    if _warned or usage is None or usage[0] < MAP_WARN_FRACTION * usage[1]:
        return False
    _warned.append(True)
    print(
        f"warning: {usage[0]} of vm.max_map_count = {usage[1]} memory maps in use (XLA's "
        "compiled programs); run fewer scenarios per process, lower MJX_RADAR_LIVE_PROGRAMS "
        "or raise the limit (sudo sysctl -w vm.max_map_count=262144)",
        file=stream or sys.stderr,
        flush=True,
    )
    return True
