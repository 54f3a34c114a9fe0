"""At most a few compiled programs stay alive in a process (issue 36: a long script died
with `LLVM compilation error: Cannot allocate memory` at vm.max_map_count)."""

from __future__ import annotations

import io

from mjx_radar.engine import live_programs, programs


def test_program_cache_is_a_bounded_lru(monkeypatch):
    monkeypatch.setenv("MJX_RADAR_LIVE_PROGRAMS", "3")
    monkeypatch.setattr(live_programs, "warn_near_map_limit", lambda: False)
    cache = live_programs.LiveCache()
    for k in range(3):
        cache[k] = object()
    cache[0]  # used again: now the most recent
    cache[3] = object()
    assert list(cache) == [2, 0, 3]
    assert 1 not in cache and len(cache) == 3
    assert isinstance(programs._CACHE, live_programs.LiveCache)
    monkeypatch.setenv("MJX_RADAR_LIVE_PROGRAMS", "junk")
    assert live_programs.capacity() == live_programs.DEFAULT_LIVE


def test_one_line_near_the_map_limit(monkeypatch):
    monkeypatch.setattr(live_programs, "_warned", [])
    monkeypatch.setattr(live_programs, "map_usage", lambda: (100, 65530))
    assert not live_programs.warn_near_map_limit(io.StringIO())
    monkeypatch.setattr(live_programs, "map_usage", lambda: (60000, 65530))
    out = io.StringIO()
    assert live_programs.warn_near_map_limit(out)
    line = out.getvalue()
    assert line.count("\n") == 1 and "vm.max_map_count = 65530" in line and "sysctl" in line
    assert not live_programs.warn_near_map_limit(io.StringIO())  # once per process
    assert live_programs.map_usage() is None or live_programs.map_usage()[0] > 0


def test_a_study_keeps_all_its_programs_alive(monkeypatch):
    """keep_alive(n) raises the capacity for the block: a study's programs, compiled at
    once, are not evicted (and loaded again) before their chunks run."""
    from mjx_radar.engine import live_programs

    monkeypatch.setenv("MJX_RADAR_LIVE_PROGRAMS", "2")
    cache = live_programs.LiveCache()
    with live_programs.keep_alive(5):
        assert live_programs.capacity() == 5
        for k in range(5):
            cache[k] = object()
        assert list(cache) == [0, 1, 2, 3, 4]
    assert live_programs.capacity() == 2
    cache["new"] = object()  # back to the user's bound at the next insertion
    assert list(cache) == [4, "new"]
