"""A study runs each round as soon as its own program is ready (study.schedule)."""

from __future__ import annotations

import threading
import time
from pathlib import Path
from types import SimpleNamespace

import pytest

from mjx_radar.engine import runner
from mjx_radar.scenario.reader import load_scenario
from mjx_radar.study import driver, schedule
from mjx_radar.study.chunks import all_chunks


class _Pending:
    """A program in the making that becomes ready when its event is set."""

    def __init__(self, t0):
        self.ready, self.t0, self.at = threading.Event(), t0, None
        self.started = SimpleNamespace(wait=self.ready.wait)

    def set(self):
        self.at = time.perf_counter() - self.t0
        self.ready.set()

    def result(self):
        self.ready.wait()
        return [], self.at


@pytest.fixture
def study(monkeypatch, tmp_path):
    """Two scenario shapes x two methods, two chunks each; the programs are fakes: the
    first is ready 0.2 s after the start, the second when the test says so."""
    shapes = [(load_scenario("smoke"), None, 8, 0), (load_scenario("paper_3r4t"), None, 8, 0)]
    todo = all_chunks(shapes, ["ddr-sfim", "stationary"], 4, 2, Path(tmp_path))
    t0 = time.perf_counter()
    started = []

    def start_programs(scenario, method, trials, steps, full, mesh, program):
        assert len(trials) == 2 and not full and program == ("sfim+none", "mppi")
        started.append(_Pending(t0))
        if len(started) == 1:
            threading.Timer(0.2, started[0].set).start()
        return started[-1]

    monkeypatch.setattr(runner, "start_programs", start_programs)
    rounds = []

    def run_round(group, chunk, n_dev, mesh, progress, times, program, writer, programs, stream):
        second_ready = len(started) > 1 and started[1].ready.is_set()
        rounds.append((group[0].scenario.name, group[0].method, second_ready))
        assert programs.ready.is_set()  # never before its own program
        if len(rounds) == 4:  # the first shape is done: its program comes 0.3 s later
            threading.Timer(0.3, started[1].set).start()

    monkeypatch.setattr(driver, "run_round", run_round)
    return todo, started, rounds


def test_rounds_start_as_their_own_program_is_ready(study):
    todo, started, rounds = study
    times = driver.StudyTimes()
    programs = schedule.start(todo, 2, mesh=None)
    assert len(programs) == 2 and len(started) == 2  # one per shape, in study order
    args = SimpleNamespace(chunk=2, progress=False)
    schedule.run_rounds(args, todo, 1, None, times, programs)
    assert [r[:2] for r in rounds] == [(c.scenario.name, c.method) for c in todo]
    # the first shape ran while the second program was still compiling
    assert [r[2] for r in rounds] == [False] * 4 + [True] * 4
    # held back: 0.2 s to the first round, then 0.3 s before the second shape's
    assert 0.45 < times.compile_s < 2.0, times.compile_s
    assert times.compile_wall_s == pytest.approx(max(p.at for p in started))
    assert times.compile_wall_s > 0.45
