"""Batched trials on the host (engine.runner, engine.programs)."""

import dataclasses
import functools
import re

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_radar.engine import compile_cache, programs, runner
from mjx_radar.engine.run_spec import run_spec
from mjx_radar.rundir import results
from mjx_radar.scenario.reader import load_scenario

STEPS = 8  # two control periods of 4 filter steps
TRIALS = np.arange(2)


@pytest.fixture(scope="module")
def export_dir(tmp_path_factory):
    """The export cache switched on in a fresh directory (XLA's own cache left as it is),
    and an empty in-memory program cache: this module's first run compiles whatever
    other test files ran before it in the same worker process."""
    path = tmp_path_factory.mktemp("cache")
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(compile_cache, "_DIR", [path])
        mp.setattr(programs, "_CACHE", {})
        yield path / "programs"


@pytest.fixture(scope="module")
def first_run(tiny, export_dir):
    phases, progress = [], []
    log_before = len(programs.COMPILE_LOG)
    res = runner.run_trials(run_spec(tiny), "ddr-sfim", 0, TRIALS, STEPS, full=False,
                            progress=progress.append, phase=phases.append)  # fmt: skip
    # this run's entries (a program another test started in the background may land meanwhile)
    log = [e for e in programs.COMPILE_LOG[log_before:] if e["scenario"] == tiny.name]
    return res, phases, progress, log


def test_segment_periods_divide_the_control_periods():
    s = load_scenario("smoke")
    every = s.timing.control_every
    for total in range(1, 301):
        p = runner.segment_periods(s, total * every)
        assert p >= 1 and total % p == 0, (total, p)
        # the largest divisor leaving >= 20 segments (1 when there are fewer periods)
        best = max([q for q in range(1, total + 1) if total % q == 0 and total // q >= 20],
                   default=1)  # fmt: skip
        assert p == best, (total, p, best)
    assert runner.segment_periods(s, 600 * every) == 30
    assert runner.segment_periods(s, 600 * every, target_segments=7) == 75  # 600 / 8


def test_programs_needed_counts_one_per_shape_kind_planner_and_device():
    """What a study keeps alive: the paper study's 3 shapes x 1 program (its five
    methods share one per shape) on 4 devices is 12 programs, not its 15 scenario-method
    pairs (counting pairs had let the study evict and reload programs round after round
    on 4 GPUs)."""
    paper = [load_scenario(n) for n in ("paper_3r4t", "paper_4r4t", "paper_6r3t")]
    methods = ["stationary", "ccr-sfim", "ccr-pfim", "ddr-sfim", "ddr-pfim"]
    jobs = [(run_spec(s), m) for s in paper for m in methods]
    assert runner.programs_needed(jobs, 4) == 12 and runner.programs_needed(jobs, 1) == 3
    smoke = load_scenario("smoke")  # a renamed copy is the same shape; a planner is not
    twin = dataclasses.replace(smoke, name="twin")
    jobs = [
        (run_spec(smoke), "ddr-sfim"),
        (run_spec(twin), "ccr-sfim"),
        (run_spec(smoke), "ddr-sfim+ps"),
    ]
    assert runner.programs_needed(jobs, 2) == 4


def test_metrics_only_output(tiny, first_run):
    res = first_run[0]
    extra = {"placement_ok", "compile_s", "sim_s", "wall_s", "control_hz"}
    assert set(res) == set(results.METRIC_COLUMNS) | extra
    for k in results.METRIC_COLUMNS:
        assert res[k].shape == (2, STEPS), k
        assert np.all(np.isfinite(res[k])), k
    assert res["placement_ok"].shape == (2,) and res["placement_ok"].all()
    np.testing.assert_array_equal(res["visible_pairs"], tiny.n_radars * tiny.n_targets)
    assert res["compile_s"] > 0 and res["sim_s"] > 0
    np.testing.assert_allclose(res["wall_s"], res["compile_s"] + res["sim_s"])
    np.testing.assert_allclose(res["control_hz"], (STEPS // 4) / res["sim_s"])


def test_phases_progress_and_compile_log(first_run):
    _, phases, progress, log = first_run
    assert phases == ["compiling", "simulating"]
    assert sum(progress) == STEPS and len(progress) == 2  # one call per segment (1 period)
    assert len(log) == 1
    entry = log[0]
    assert entry["source"] == "traced"  # a fresh export directory
    assert entry["kind"] == "sfim"  # only the information this method plans with
    assert (entry["n_radars"], entry["n_targets"], entry["batch"], entry["devices"]) == (2, 2, 2, 1)
    assert entry["trace_lower_s"] > 0 and entry["xla_compile_s"] > 0


def test_second_call_reuses_the_program_and_reproduces(tiny, first_run):
    res, log_len = first_run[0], len(programs.COMPILE_LOG)
    phases = []
    again = runner.run_trials(
        run_spec(tiny), "ddr-sfim", 0, TRIALS, STEPS, full=False, phase=phases.append
    )
    assert again["compile_s"] == 0.0 and phases == ["compiling", "simulating"]
    assert len(programs.COMPILE_LOG) == log_len  # nothing compiled
    for k in results.METRIC_COLUMNS:
        np.testing.assert_array_equal(again[k], res[k], err_msg=k)
    # a trial's numbers do not depend on its position in the batch
    rev = runner.run_trials(run_spec(tiny), "ddr-sfim", 0, TRIALS[::-1], STEPS, full=False)
    assert rev["compile_s"] == 0.0
    for k in results.METRIC_COLUMNS:
        np.testing.assert_array_equal(rev[k], res[k][::-1], err_msg=k)
    # the other noise model of the same information kind is a runtime argument of the
    # same program, with other numbers
    other = runner.run_trials(run_spec(tiny), "ccr-sfim", 0, TRIALS, STEPS, full=False)
    assert other["compile_s"] == 0.0
    assert not np.array_equal(other["rmse_pos"], res["rmse_pos"])
    # stationary radars compile their own program, without a planner
    still = runner.run_trials(run_spec(tiny), "stationary", 0, TRIALS, STEPS, full=False)
    assert still["compile_s"] > 0 and programs.COMPILE_LOG[-1]["kind"] == "none"
    assert not np.array_equal(still["rmse_pos"], res["rmse_pos"])


def test_export_cache_round_trip(tiny, first_run, export_dir, monkeypatch):
    # The traced program was exported beside the cache; a process that has not compiled
    # it (here: an emptied in-memory cache) loads it without tracing, same numbers.
    # (two programs: kind "sfim" and, from the test above, the stationary kind "none")
    # (without the executables XLA may have written beside it: engine.executable_cache;
    # their round trip is tests/test_program_lock.py's)
    assert len(list(export_dir.glob("loop-*.jaxexport"))) == 2
    for exe in export_dir.glob("exe-*.bin"):
        exe.unlink()
    monkeypatch.setattr(programs, "_CACHE", {})
    n0 = len(programs.COMPILE_LOG)
    b = runner.run_trials(run_spec(tiny), "ddr-sfim", 0, TRIALS, STEPS, full=False)
    assert b["compile_s"] > 0 and programs.COMPILE_LOG[n0]["source"] == "export cache"
    for k in results.METRIC_COLUMNS:
        np.testing.assert_array_equal(b[k], first_run[0][k], err_msg=k)


def test_programs_started_in_the_background_are_the_ones_run(tiny, first_run, monkeypatch):
    # A run starts loading its programs before its checks (runner.start_programs) and
    # hands them to run_trials, which then neither compiles nor loads them again;
    # programs started for other arguments are not taken (this one is never started).
    from mjx_radar.engine.device_programs import PendingPrograms

    monkeypatch.setattr(programs, "_CACHE", {})
    n0 = len(programs.COMPILE_LOG)
    pending = runner.start_programs(run_spec(tiny), "ddr-sfim", TRIALS, STEPS, full=False)
    again = runner.run_trials(
        run_spec(tiny), "ddr-sfim", 0, TRIALS, STEPS, full=False, programs=pending
    )
    assert len(programs.COMPILE_LOG) == n0 + 1 and again["compile_s"] > 0
    assert programs.COMPILE_LOG[n0]["source"] in ("export cache", "executable cache")
    foreign = PendingPrograms(request=("another shape",), started=None)  # never started
    cached = runner.run_trials(
        run_spec(tiny), "ddr-sfim", 0, TRIALS, STEPS, full=False, programs=foreign
    )
    assert len(programs.COMPILE_LOG) == n0 + 1  # this process's program, not the foreign one
    for res in (again, cached):
        for k in results.METRIC_COLUMNS:
            np.testing.assert_array_equal(res[k], first_run[0][k], err_msg=k)
    with pytest.raises(ValueError, match="steps: 6 must be a multiple of 4"):
        runner.start_programs(run_spec(tiny), "ddr-sfim", TRIALS, 6)  # checked as run_trials checks


def _callsite_depth(mlir: str) -> int:
    """Deepest chain of call-site locations in a StableHLO module's text (the frames of
    the Python traceback an operation carries as its location)."""
    defs = dict(re.findall(r"^(#loc\d+) = (.*)$", mlir, re.M))

    @functools.cache
    def depth(ref):
        text = defs.get(ref, "")
        inner = max((depth(r) for r in re.findall(r"#loc\d+", text)), default=0)
        return inner + text.startswith("loc(callsite(")

    return max(map(depth, defs), default=0)


def test_exported_programs_carry_one_source_line_per_operation(export_dir):
    # Whole Python tracebacks as locations (JAX's default, up to 100 frames; 10-14 deep
    # in these programs) become XLA metadata that a GPU executable turns into profiler
    # annotations on every load; program_trace.short_locations keeps one frame per
    # operation (what is left are the call sites of inlined nested programs: 3).
    from mjx_radar.engine import export_cache, program_trace

    for path in export_dir.glob("loop-*.jaxexport"):
        for exported in export_cache.load(path):
            assert _callsite_depth(exported.mlir_module()) <= 4

    def deep(x, n=8):  # every operation under 8 frames of this function
        return jnp.sin(x) if n == 0 else deep(x, n - 1) + 1.0

    def lowered(f):
        return jax.export.export(jax.jit(f))(jax.ShapeDtypeStruct((3,), "float32")).mlir_module()

    assert _callsite_depth(lowered(lambda x: deep(x))) >= 8  # the control: JAX's default
    with program_trace.short_locations():
        assert _callsite_depth(lowered(lambda x: deep(x) * 2.0)) <= 1


def test_steps_not_a_multiple_of_the_control_period(tiny):
    with pytest.raises(ValueError, match="steps: 6 must be a multiple of 4"):
        runner.run_trials(run_spec(tiny), "ddr-sfim", 0, TRIALS, 6)


@pytest.mark.slow  # a program of its own (30-40 s on 2 cores) for one edge of the records
def test_fewer_mppi_samples_than_kept_samples_runs(tiny):
    # The plan and idle branches of the closed loop record min(32, samples) samples.
    s = dataclasses.replace(tiny, mppi=dataclasses.replace(tiny.mppi, samples=16))
    res = runner.run_trials(run_spec(s), "ddr-sfim", 0, TRIALS, STEPS, full=True)
    assert res["sample_cost"].shape == (2, STEPS // 4, 16)


def test_a_single_trial_run_is_the_plain_loop(tiny):
    """A device running one trial runs the loop itself, not a ``vmap`` of size one
    (``program_trace.flat_programs(single=True)``): the runner's trial equals
    ``jax.jit(closed_loop.simulate)`` of that trial bit for bit. A vmap of size one rounds
    otherwise in float32 (measured: estimates 3e-4 m apart after 40 steps of stationary
    radars, radars 2.1 m apart with MPPI), so a vmapped program fails this comparison."""
    from mjx_radar.loop import closed_loop
    from mjx_radar.task.method import parse_method
    from mjx_radar.task.params import shape_key, task_params
    from mjx_radar.task.task import make_task

    steps = 40
    res = runner.run_trials(run_spec(tiny), "stationary", 0, np.array([1]), steps, full=True)
    assert programs.COMPILE_LOG[-1]["batch"] == 1
    task = make_task(shape_key(tiny), "none")
    params = task_params(tiny, parse_method("stationary"))
    want = jax.jit(lambda: closed_loop.simulate(task, params, 1, steps, "hold"))()
    for k in ("radar", "mean", "cov_diag", "target", "nees"):
        np.testing.assert_array_equal(res[k][0], np.asarray(getattr(want.steps, k)), err_msg=k)
