"""A study's lanes: each device takes the next chunk as soon as it is free and the chunk's
program is ready (study.schedule, study.lanes, study.host_work)."""

from __future__ import annotations

import threading
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from mjx_radar.engine import device_lane, runner
from mjx_radar.engine.run_spec import run_spec
from mjx_radar.env.records import SET_KEYS
from mjx_radar.rundir.results import LOOP_COLUMNS
from mjx_radar.scenario.reader import load_scenario
from mjx_radar.study import driver, lanes, schedule
from mjx_radar.study.chunks import all_chunks
from mjx_radar.study.host_work import ChunkJob, HostPool


class _Pending:
    """A program in the making that becomes ready when its event is set."""

    def __init__(self, t0, n_dev):
        self.ready, self.t0, self.at, self.n_dev = threading.Event(), t0, None, n_dev
        self.started = SimpleNamespace(
            wait=self.ready.wait, running=lambda: not self.ready.is_set()
        )
        self.devices = {}

    def set(self):
        if self.ready.is_set():
            return
        self.at = time.perf_counter() - self.t0
        self.devices.update({d: (f"program {d}", 0.0) for d in range(self.n_dev)})
        self.ready.set()

    def result(self):
        self.ready.wait()
        return [(f"program {d}", 0.0) for d in range(self.n_dev)], self.at

    def device(self, i):
        self.ready.wait()
        return f"program {i}"


def _arrays(m, b, k):
    loop = {c: np.zeros((b, k), np.float32) for c in LOOP_COLUMNS}
    sets = {
        "truth_pos": np.zeros((b, k, m, 3), np.float32),
        "present": np.ones((b, k, m), bool),
        "track_pos": np.ones((b, k, m, 3), np.float32),
        "track_exists": np.ones((b, k, m), bool),
    }
    assert set(sets) == set(SET_KEYS)
    return loop | sets


@pytest.fixture
def study(monkeypatch, tmp_path):
    """Two scenario shapes x two methods, two chunks each, on 2 (fake) devices; the first
    program is ready 0.2 s after the start, the second when the test says so; a chunk
    takes 50 ms on its device."""
    shapes = [(run_spec(load_scenario(n)), None, 8, 0) for n in ("smoke", "paper_3r4t")]
    todo = all_chunks(shapes, ["ddr-sfim", "stationary"], 4, 2, Path(tmp_path))
    t0 = time.perf_counter()
    started, ran = [], []

    def start_programs(spec, method, trials, steps, full, mesh, program):
        assert len(trials) == 4 and not full and program == ("sfim+none", "mppi")
        started.append(_Pending(t0, 2))
        if len(started) == 1:
            threading.Timer(0.2, started[0].set).start()
        return started[-1]

    def run_on_device(prog, spec, method, seed, ids, steps, progress):
        second_ready = started[1].ready.is_set()
        ran.append((spec.name, method, prog, second_ready))
        time.sleep(0.05)
        if len(ran) == 4:  # the first shape is done: its program comes 0.3 s later
            threading.Timer(0.3, started[1].set).start()
        progress(steps)
        return _arrays(spec.size.n_targets, len(ids), steps)

    monkeypatch.setattr(runner, "start_programs", start_programs)
    monkeypatch.setattr(device_lane, "run_on_device", run_on_device)
    mesh = SimpleNamespace(devices=np.array(["d0", "d1"]), size=2)
    return todo, started, ran, mesh


def test_lanes_run_each_chunk_once_as_soon_as_its_program_is_ready(study):
    todo, started, ran, mesh = study
    times = driver.StudyTimes()
    programs = schedule.start(todo, 4, mesh)
    assert len(programs) == 2 and len(started) == 2  # one per shape, in study order
    args = SimpleNamespace(chunk=2, progress=False)
    host = lanes.run_lanes(args, todo, mesh, times, programs)
    assert sorted(r[:2] for r in ran) == sorted((c.spec.name, c.method) for c in todo)
    # the first shape ran (on both devices) while the second program was still compiling,
    # the planning method's chunks before the stationary ones (the costliest first)
    assert [r[3] for r in ran] == [False] * 4 + [True] * 4
    assert [r[1] for r in ran[:4]] == ["ddr-sfim"] * 2 + ["stationary"] * 2
    assert {r[2] for r in ran[:4]} == {"program 0", "program 1"}
    assert all(c.path.exists() for c in todo) and times.chunks_run == len(todo)
    # held back: 0.2 s to the first chunk, then ~0.3 s with no device running
    assert 0.45 < times.compile_s < 2.0, times.compile_s
    assert times.compile_wall_s == pytest.approx(max(p.at for p in started))
    # 8 chunks of 50 ms on 2 devices: ~0.2 s of simulation, not 0.4
    assert 0.18 < times.sim_s < 0.35, times.sim_s
    assert len(host["timeline"]) == len(todo) and {e["device"] for e in host["timeline"]} == {0, 1}


def test_programs_first_holds_every_lane_until_every_program_is_loaded(study, monkeypatch):
    todo, started, ran, mesh = study
    monkeypatch.setenv(lanes.PROGRAMS_FIRST_ENV, "1")
    programs = schedule.start(todo, 4, mesh)
    threading.Timer(0.3, started[1].set).start()  # the second program, before any chunk
    times = driver.StudyTimes()
    lanes.run_lanes(SimpleNamespace(chunk=2, progress=False), todo, mesh, times, programs)
    assert len(ran) == len(todo) and all(r[3] for r in ran)  # none ran beside a compile
    assert times.compile_s > 0.28 and times.compile_wall_s == pytest.approx(started[1].at)
    monkeypatch.setenv(lanes.PROGRAMS_FIRST_ENV, "0")
    assert not lanes.programs_first()


def test_a_failing_chunk_stops_the_lanes_and_is_raised(study, monkeypatch):
    todo, _, ran, mesh = study

    def broken(prog, scenario, method, seed, ids, steps, progress):
        ran.append(method)
        raise OSError("device lost")

    monkeypatch.setattr(device_lane, "run_on_device", broken)
    args = SimpleNamespace(chunk=2, progress=False)
    programs = schedule.start(todo, 4, mesh)
    with pytest.raises(OSError, match="device lost"):
        lanes.run_lanes(args, todo, mesh, driver.StudyTimes(), programs)
    assert len(ran) <= 2  # one chunk per lane at most, no further chunk taken


def _job(tmp_path, i, scenario):
    s = scenario
    cfg = (s.timing.dt_filter, s.metrics.gospa_cutoff, s.metrics.gospa_order)
    return ChunkJob(tmp_path / f"c{i}.parquet", s.name, "stationary", 2 * i, 2 * i + 1, *cfg)


def test_host_pool_finishes_every_chunk_and_raises_a_failed_write(tmp_path):
    s = load_scenario("smoke")
    arrays = _arrays(s.n_targets, 2, 8)
    loop = {k: arrays[k] for k in LOOP_COLUMNS}
    sets = {k: arrays[k] for k in SET_KEYS}
    with HostPool(3, limit=2) as pool:
        for i in range(6):
            pool.submit(_job(tmp_path, i, s), loop, sets)
    assert pool.done == 6 and all((tmp_path / f"c{i}.parquet").exists() for i in range(6))
    assert set(pool.seconds) == {"set_metrics_s", "table_s", "write_s", "stream_s"}
    (tmp_path / "file").write_text("")
    bad = ChunkJob(tmp_path / "file" / "c.parquet", s.name, "stationary", 0, 1, 0.025, 10.0, 1)
    with pytest.raises(OSError), HostPool(1) as pool:
        pool.submit(bad, loop, sets)


def test_covered_is_the_union_of_intervals():
    assert lanes._covered([(0, 1), (0.5, 2), (3, 4), (3.5, 3.7)]) == pytest.approx(3.0)
    assert lanes._covered([]) == 0.0


def test_xla_out_of_memory_in_a_lane_is_one_line(study, monkeypatch):
    """A chunk that runs out of device memory stops the study with one InputError line
    naming the chunk size (engine.oom), never XLA's traceback."""
    import jax

    from mjx_radar.errors import InputError

    todo, _, _, mesh = study

    def exhausted(prog, scenario, method, seed, ids, steps, progress):
        raise jax.errors.JaxRuntimeError("RESOURCE_EXHAUSTED: Out of memory allocating 9 bytes")

    monkeypatch.setattr(device_lane, "run_on_device", exhausted)
    args = SimpleNamespace(chunk=2, progress=False)
    programs = schedule.start(todo, 4, mesh)
    with pytest.raises(InputError) as err:
        lanes.run_lanes(args, todo, mesh, driver.StudyTimes(), programs)
    line = str(err.value)
    assert "\n" not in line and "out of memory running 2 trial(s) per device" in line, line
