"""The memory estimate (``engine/resources.py``) against XLA's own figures (issue 26).

XLA's figure for a program is ``compiled.memory_analysis()`` of the segment ("step")
program: temporaries + arguments + outputs - donated aliases (what XLA allocates at
once; a 300-target joint run asked for exactly its temporaries, 26.8 GB, and died).
``CPU_KINDS`` holds it for every bundled scenario x program kind a run compiles (the
CPU, 2 trials; the estimate within 25 %), ``CPU_MEASURED`` / ``CPU_BUNDLED`` for small
shapes and two bundled scenes compiled with every method (kind ``"all"``, jax 0.10.2),
``GPU_MEASURED`` for the bundled scenarios at study sizes on one H100 (jax 0.11.2), all
from ``scripts/measure_memory.py``. The estimate must lie within
``resources.MEASURED_FACTOR`` of the last three; two CPU shapes are compiled here again.
On one H200 (``benchmarks/results/memory_model_gpu_h200_rows.json``: every bundled
scenario x program kind at 64 trials, SFIM at 16, a study's program) the GPU terms must
lie within 25 % of XLA's figure and the device's peak (``GPU_XLA_MISSES``,
``GPU_PEAK_MISSES``: the rows where they do not, pinned as they are).
"""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from mjx_radar.engine import memory_model, resources
from mjx_radar.engine.run_spec import program_size, run_spec
from mjx_radar.errors import InputError
from mjx_radar.scenario.reader import load_scenario

REPO = Path(__file__).resolve().parent.parent
LO, HI = resources.MEASURED_FACTOR

# (targets M, radars N, samples S, horizon H, filter, rollouts, trials T, azimuth, a box
# obstacle, XLA bytes)
CPU_MEASURED = [
    (2, 2, 64, 8, "joint", "analytic", 1, False, False, 1_361_412),
    (4, 2, 64, 8, "joint", "analytic", 1, False, False, 4_955_076),
    (8, 2, 64, 8, "joint", "analytic", 1, False, False, 19_284_636),
    (16, 2, 64, 8, "joint", "analytic", 1, False, False, 76_546_716),
    (8, 4, 64, 8, "joint", "analytic", 1, False, False, 20_928_540),
    (8, 2, 128, 8, "joint", "analytic", 1, False, False, 38_386_716),
    (8, 2, 64, 15, "joint", "analytic", 1, False, False, 36_049_148),
    (8, 2, 64, 8, "joint", "analytic", 4, False, False, 76_776_391),
    (8, 2, 64, 8, "per-target", "analytic", 1, False, False, 2_629_132),
    (16, 2, 64, 8, "per-target", "analytic", 1, False, False, 5_174_668),
    (8, 2, 64, 8, "joint", "mjx", 1, False, False, 19_299_356),
    (8, 2, 256, 8, "joint", "mjx", 1, False, False, 76_723_228),
    (24, 48, 16, 1, "joint", "analytic", 1, False, False, 52_810_764),  # filter-bound
    (24, 48, 16, 1, "per-target", "analytic", 1, False, False, 3_121_388),
    (8, 2, 64, 8, "joint", "analytic", 1, True, False, 20_828_940),
    (4, 2, 64, 8, "joint", "analytic", 1, False, True, 4_963_396),
    (4, 6, 64, 8, "joint", "analytic", 1, False, True, 7_295_916),
    (8, 2, 64, 8, "per-target", "analytic", 1, False, True, 2_641_260),
    (300, 2, 64, 8, "joint", "mjx", 1, False, False, 26_786_447_872),  # RESOURCE_EXHAUSTED
]
# (bundled scenario, filter, rollouts, trials per device, XLA bytes): the CPU (analytic
# rollouts, full program) and one H100 (the study's metrics-only program)
CPU_BUNDLED = [
    ("city_4r4t", "joint", "analytic", 1, 96_209_868),  # 12 meshes: line of sight
    ("forest_4r4t", "joint", "analytic", 1, 136_450_636),  # 150 trees
]
GPU_MEASURED = [
    ("smoke", "joint", "analytic", 1, 713_692),
    ("paper_3r4t", "joint", "mjx", 500, 10_585_344_891),
    ("paper_4r4t", "joint", "mjx", 256, 6_034_935_955),
    ("city_4r4t", "joint", "mjx", 256, 12_105_767_139),
    ("swarm_8r8t", "joint", "mjx", 50, 6_514_868_373),
    ("swarm_16r16t", "per-target", "mjx", 100, 5_193_136_583),
    ("swarm_32r32t", "per-target", "mjx", 100, 19_727_482_119),
    ("swarm_32r32t", "joint", "mjx", 1, 5_612_974_700),
]

# What a run compiles (one information kind; issue 56): XLA's figure for every bundled
# scenario x program kind (none: stationary; sfim, pfim: the planning methods), 2 trials,
# run's program (trajectories, segments of one control period), MJX rollouts, the CPU
# (jax 0.10.2): JAX_PLATFORMS=cpu MJX_RADAR_CACHE_DIR=off python scripts/measure_memory.py
CPU_KINDS = [
    ("city_4r4t", "none", "joint", 284_309),
    ("city_4r4t", "sfim", "joint", 53_472_021),
    ("city_4r4t", "pfim", "joint", 68_334_741),
    ("clutter_3r4t", "none", "per-target", 132_073),
    ("clutter_3r4t", "sfim", "per-target", 33_186_473),
    ("clutter_3r4t", "pfim", "per-target", 36_971_305),
    ("faint_3r4t", "none", "per-target", 125_953),
    ("faint_3r4t", "sfim", "per-target", 15_903_937),
    ("faint_3r4t", "pfim", "per-target", 19_688_769),
    ("forest_4r4t", "none", "joint", 293_565),
    ("forest_4r4t", "sfim", "joint", 53_467_453),
    ("forest_4r4t", "pfim", "joint", 68_331_709),
    ("hills_4r4t", "none", "joint", 181_525),
    ("hills_4r4t", "sfim", "joint", 53_413_589),
    ("hills_4r4t", "pfim", "joint", 67_804_373),
    ("mixed_6r4t", "none", "joint", 239_233),
    ("mixed_6r4t", "sfim", "joint", 72_958_017),
    ("mixed_6r4t", "pfim", "joint", 87_373_249),
    ("paper_3r4t", "none", "joint", 151_081),
    ("paper_3r4t", "sfim", "joint", 43_658_537),
    ("paper_3r4t", "pfim", "joint", 57_811_369),
    ("paper_4r4t", "none", "joint", 181_077),
    ("paper_4r4t", "sfim", "joint", 53_411_285),
    ("paper_4r4t", "pfim", "joint", 67_609_941),
    ("paper_6r3t", "none", "joint", 201_249),
    ("paper_6r3t", "sfim", "joint", 42_641_953),
    ("paper_6r3t", "pfim", "joint", 50_951_777),
    ("raid_4r8t", "none", "joint", 851_549),
    ("raid_4r8t", "sfim", "joint", 206_443_165),
    ("raid_4r8t", "pfim", "joint", 262_344_349),
    ("smoke", "none", "joint", 59_141),
    ("smoke", "sfim", "joint", 1_644_485),
    ("smoke", "pfim", "joint", 2_265_029),
    ("swarm_16r16t", "none", "joint", 3_837_133),
    ("swarm_16r16t", "sfim", "joint", 2_592_813_517),
    ("swarm_16r16t", "pfim", "joint", 2_817_791_885),
    ("swarm_32r32t", "none", "per-target", 3_319_597),
    ("swarm_32r32t", "sfim", "per-target", 693_374_253),
    ("swarm_32r32t", "pfim", "per-target", 695_226_541),
    ("swarm_8r8t", "none", "joint", 608_485),
    ("swarm_8r8t", "sfim", "joint", 355_679_013),
    ("swarm_8r8t", "pfim", "joint", 412_094_949),
    ("town_4r4t", "none", "joint", 617_911),
    ("town_4r4t", "sfim", "joint", 53_615_223),
    ("town_4r4t", "pfim", "joint", 69_055_543),
    ("waypoints_3r4t", "none", "joint", 326_125),
    ("waypoints_3r4t", "sfim", "joint", 43_833_517),
    ("waypoints_3r4t", "pfim", "joint", 57_986_541),
    ("yard_3r4t", "none", "joint", 276_353),
    ("yard_3r4t", "sfim", "joint", 43_691_777),
    ("yard_3r4t", "pfim", "joint", 58_341_569),
]
# The miss of issue 56: the joint swarm_32r32t, one trial, kind sfim, the CPU: XLA keeps
# 65 arrays f32[200, 15, 12288] (two per radar; the old model counted 27)
CPU_JOINT_SWARM = ("swarm_32r32t", "joint", "sfim", 1, 9_896_884_990)
# An H200 ran out of memory at 16 trials of the joint swarm_32r32t, run --method ddr-sfim:
# XLA asked for 110.00 GiB of temporaries. Which program kind run compiled then is not
# recorded; the SFIM program measured since fuses the joint expectations (tens of MB at
# 16 trials of swarm_16r16t), so it was not that one: the largest kind's estimate covers
# the request within 25 %
GPU_OOM = ("swarm_32r32t", "joint", 16, 110 * 2**30)

# One H200 (jax 0.11.2): XLA's figure and the device's peak of every bundled scenario x
# program kind (benchmarks/memory_gpu_result.py from scripts/measure_memory.py --peak)
GPU_ROWS = json.loads((REPO / "benchmarks/results/memory_model_gpu_h200_rows.json").read_text())
# (scenario, kind, program, trials) outside 25 %: of XLA's figure, smoke's programs of 1.4-24
# MB (XLA keeps its SFIM arrays at 64 trials and fuses them at 16; the device's peak is the
# runtime's floor, within 25 %); of the device's peak, clutter_3r4t's stationary and
# 16-trial SFIM programs, whose peak lies ~230 MB above the step program's figure (the same
# figure as faint_3r4t's, whose peak does not)
GPU_XLA_MISSES = {
    ("smoke", "none", "run", 64): (1.2, 1.4),
    ("smoke", "sfim", "run", 64): (0.25, 0.4),
    ("smoke", "sfim", "run", 16): (1.2, 1.4),
}
GPU_PEAK_MISSES = {
    ("clutter_3r4t", "none", "run", 64): (0.55, 0.75),
    ("clutter_3r4t", "sfim", "run", 16): (0.55, 0.75),
}


def _scenario_text(m, n, s, h, structure, rollout, azimuth=False, box=False, name="shape"):
    rng = np.random.default_rng(0)
    rows = []
    for _ in range(m):
        x, y = rng.uniform(-300, 300, 2)
        vx, vy = rng.uniform(-15, 15, 2)
        rows.append(f"  [{x:.2f}, {y:.2f}, {rng.uniform(40, 80):.2f}, {vx:.2f}, {vy:.2f}, 0.0],")
    text = f'name = "{name}"\nn_radars = {n}\nseed = 0\ntargets = [\n' + "\n".join(rows) + "\n]\n"
    if box:  # radars are then placed by hand, clear of it
        text += f"radars = [{', '.join(f'[{30 * i - 400}.0, -400.0, 0.0]' for i in range(n))}]\n"
        text += '\n[[obstacles]]\nkind = "box"\npos = [250.0, -150.0, 10.0]\n'
        text += "size = [30.0, 6.0, 10.0]\n"
    text += "\n[timing]\ndt_filter = 0.025\ndt_control = 0.1\nsteps = 80\n"
    text += f'\n[mpc]\nhorizon = {h}\nrollout = "{rollout}"\n'
    text += f"\n[mppi]\nsamples = {s}\niterations = 3\n" if s else ""
    text += f'\n[filter]\nstructure = "{structure}"\n'
    return text + ('\n[measurement]\nmodel = "range-azimuth"\n' if azimuth else "")


def _shape(tmp_path, *shape):
    path = tmp_path / f"shape_{'_'.join(map(str, shape))}.toml"
    path.write_text(_scenario_text(*shape))
    return load_scenario(path)


def _with(s, structure):
    return dataclasses.replace(s, filter=dataclasses.replace(s.filter, structure=structure))


@pytest.mark.parametrize("case", CPU_MEASURED, ids=lambda c: "-".join(map(str, c[:9])))
def test_estimate_within_factor_of_cpu_measurements(tmp_path, case):
    *shape, trials, azimuth, box, xla = case
    s = _shape(tmp_path, *shape, azimuth, box)
    est = sum(resources.device_terms(program_size(s), trials, "cpu").values())
    assert LO <= est / xla <= HI, (case, est / xla)


@pytest.mark.parametrize(
    "platform, case",
    [("cpu", c) for c in CPU_BUNDLED] + [("gpu", c) for c in GPU_MEASURED],
    ids=lambda c: c if isinstance(c, str) else "-".join(map(str, c[:4])),
)
def test_estimate_within_factor_of_bundled_scenarios(platform, case):
    name, structure, rollout, trials, xla = case
    s = _with(load_scenario(name), structure)
    s = dataclasses.replace(s, mpc=dataclasses.replace(s.mpc, rollout=rollout))
    full = platform == "cpu"  # the GPU figures are a study's (metrics-only) programs
    est = sum(resources.device_terms(program_size(s), trials, platform, "all", full).values())
    # a program of a few MB (smoke: 1.3x) is fused more tightly on the GPU; never below
    assert LO <= est / xla and (est / xla <= HI or xla < 10e6), (case, est / xla)


@pytest.mark.parametrize("case", CPU_KINDS, ids=lambda c: "-".join(map(str, c[:2])))
def test_estimate_within_25_percent_for_every_bundled_scenario_and_method(case):
    name, kind, structure, xla = case
    s = load_scenario(name)
    assert s.filter.structure == structure  # the bundled file as measured
    seg = s.timing.control_every  # 8 steps: segments of one control period
    est = sum(resources.device_terms(program_size(s), 2, "cpu", kind, True, seg).values())
    lo, hi = memory_model.BUNDLED_FACTOR
    assert lo <= est / xla <= hi, (case, est / xla)


def test_estimate_of_the_joint_swarm_within_25_percent():
    name, structure, kind, trials, xla = CPU_JOINT_SWARM
    s = _with(load_scenario(name), structure)
    est = sum(resources.device_terms(program_size(s), trials, "cpu", kind, True, 4).values())
    lo, hi = memory_model.BUNDLED_FACTOR
    assert lo <= est / xla <= hi, est / xla


def test_estimate_covers_the_h200s_out_of_memory_request():
    name, structure, trials, asked = GPU_OOM
    s = _with(load_scenario(name), structure)
    kinds = ("sfim", "pfim", "all", "sfim+pfim+none")
    est = max(
        sum(resources.device_terms(program_size(s), trials, "gpu", k).values()) for k in kinds
    )
    lo, hi = memory_model.BUNDLED_FACTOR
    assert lo <= est / asked <= hi, est / asked


# The joint filter's SFIM of 20, 24 and 32 drones on one H200 (XLA fuses its expectations
# up to 20 drones, not from 24 on): GPU_JOINT_FUSED_TARGETS and GPU_JOINT_UNFUSED
JOINT_SWARM_ROWS = json.loads(
    (REPO / "benchmarks/results/memory_model_gpu_joint_swarm_h200.json").read_text()
)["rows"]


@pytest.fixture(scope="module")
def swarm_files(tmp_path_factory):
    """The swarms of the rows as scripts/make_swarm.py writes them (seed 0)."""
    folder = tmp_path_factory.mktemp("swarms")
    for m in (20, 24):
        cmd = [sys.executable, str(REPO / "scripts/make_swarm.py"), "--radars", str(m)]
        cmd += ["--targets", str(m), "--seed", "0", "--out", str(folder / f"swarm_{m}r{m}t.toml")]
        subprocess.run(cmd, check=True, capture_output=True)
    return folder


@pytest.mark.parametrize("row", JOINT_SWARM_ROWS, ids=lambda r: f"{r[0]}-{r[4]}")
def test_gpu_estimate_of_the_joint_swarms_within_25_percent(row, swarm_files):
    name, structure, kind, _, trials, xla, peak = row
    path = swarm_files / f"{name}.toml"
    s = _with(load_scenario(path if path.exists() else name), structure)
    est = sum(
        resources.device_terms(
            program_size(s), trials, "gpu", kind, True, runner_segment(s)
        ).values()
    )
    lo, hi = memory_model.BUNDLED_FACTOR
    assert lo <= est / xla <= hi, (name, trials, est / xla)
    if peak:
        assert lo <= memory_model.device_peak(est, "gpu") / peak <= hi


@pytest.mark.parametrize("row", GPU_ROWS["rows"], ids=lambda r: "-".join(map(str, r[:5])))
def test_gpu_estimate_within_25_percent_of_the_h200(row):
    """The GPU terms against XLA's figure, the runtime's floor against the device's peak."""
    name, structure, kind, program, trials, xla, peak = row
    s = load_scenario(name)
    assert s.filter.structure == structure  # the bundled file as measured
    seg = runner_segment(s)
    est = sum(
        resources.device_terms(program_size(s), trials, "gpu", kind, program == "run", seg).values()
    )
    case = (name, kind, program, trials)
    lo, hi = GPU_XLA_MISSES.get(case, memory_model.BUNDLED_FACTOR)
    assert lo <= est / xla <= hi, (case, est / xla)
    lo, hi = GPU_PEAK_MISSES.get(case, memory_model.BUNDLED_FACTOR)
    ratio = memory_model.device_peak(est, "gpu") / peak
    assert lo <= ratio <= hi, (case, ratio)


def runner_segment(s) -> int:
    """Filter steps of the measured segment program (``--steps 8``)."""
    from mjx_radar.engine import runner

    return runner.segment_periods(s, 8) * s.timing.control_every


def test_gpu_estimate_and_refusal_use_the_gpu_terms_and_floor(monkeypatch):
    """On a GPU the estimate is the model's device peak (its GPU terms and the runtime's
    floor); the refusal names the largest --trials that fits by it."""
    _gpu(monkeypatch, 1.0)
    s = load_scenario("paper_3r4t")
    seg = runner_segment(s)
    for kind, trials in (("none", 4), ("sfim", 64), ("pfim", 64)):
        est = resources.estimate(run_spec(s), trials, 8, kind=kind)
        xla = sum(
            memory_model.device_terms(program_size(s), trials, "gpu", kind, True, seg).values()
        )
        assert est.device_bytes == memory_model.device_peak(xla, "gpu"), kind
        assert ("GPU runtime" in est.device) == (kind != "pfim"), est.device
    with pytest.raises(InputError) as err:
        resources.check(run_spec(s), 256, 8, kind="pfim")  # ~1.9 GB of PFIM arrays, 1 GiB free
    fit = int(str(err.value).split("; --trials ")[1].split()[0])
    resources.check(run_spec(s), fit, 8, kind="pfim")
    with pytest.raises(InputError):
        resources.check(run_spec(s), fit + 1, 8, kind="pfim")
    resources.check(run_spec(s), 256, 8, kind="sfim")  # the joint SFIM is fused on a GPU


@pytest.mark.slow  # a 4-radar program compiled cold (45-65 s on 2 cores); the model stays in CI
# through the recorded XLA figures (test_estimate_within_factor_of_bundled_scenarios)
@pytest.mark.parametrize("structure", ["joint", "per-target"])
def test_estimate_matches_a_fresh_compilation(tmp_path, structure):
    """Compiles a small shape's step program now and compares with XLA's figure."""
    from mjx_radar.engine import programs, runner

    s = _shape(tmp_path, 4, 2, 64, 8, structure, "analytic", False, False)
    progs, _ = programs.compile_programs(run_spec(s), 2, runner.segment_periods(s, 8), full=True)
    ma = progs.step.memory_analysis()
    xla = (ma.temp_size_in_bytes + ma.argument_size_in_bytes + ma.output_size_in_bytes
           - ma.alias_size_in_bytes)  # fmt: skip
    est = sum(resources.device_terms(program_size(s), 2, "cpu").values())
    assert LO <= est / xla <= HI, (structure, est, xla)


def test_300_targets_joint_refused_before_compiling(tmp_path):
    """The run that died in XLA asking for 26.8 GB: one line, exit 2, in seconds."""
    path = tmp_path / "many.toml"
    path.write_text(_scenario_text(300, 4, 0, 15, "joint", "mjx", name="many"))  # S = 200
    s = load_scenario(path)
    need = sum(resources.estimate(run_spec(s), 1, 80).device.values())
    if (resources.host_available() or 0) > need:
        pytest.skip(f"this machine has more than {resources.fmt_bytes(need)} free")
    out = tmp_path / "out"
    env = {**os.environ, "JAX_PLATFORMS": "cpu", "PYTHONPATH": str(REPO)}
    t0 = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-m", "mjx_radar", "run", str(path), "--out", str(out), "--no-cache"],
        capture_output=True, text=True, timeout=120, env=env, cwd=REPO,
    )  # fmt: skip
    err = proc.stderr.strip()
    assert proc.returncode == 2, err[-2000:]
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    assert "planner expectations" in err and 'structure = "per-target"' in err, err
    assert "300 targets x 3600 cubature points" in err and "--trials 1" in err, err
    assert not out.exists() and time.perf_counter() - t0 < 60


def _gpu(monkeypatch, free_gib: float) -> None:
    monkeypatch.setattr(resources, "_platform", lambda: "gpu")
    monkeypatch.setattr(resources, "_device_available", lambda: (False, int(free_gib * 2**30)))
    monkeypatch.setattr(resources, "host_available", lambda: 128 * 2**30)


def test_usual_study_sizes_fit_an_80gb_gpu(monkeypatch):
    """JAX takes 75% of an 80 GB GPU (60 GB): the paper studies' chunks of 500 trials
    per device, the swarms at their documented sizes all pass."""
    _gpu(monkeypatch, 60 * 1e9 / 2**30)
    usual = {"swarm_8r8t": ("joint", 50), "swarm_16r16t": ("per-target", 256),
             "swarm_32r32t": ("per-target", 256)}  # fmt: skip
    for path in sorted((REPO / "scenarios").glob("*.toml")):
        s = load_scenario(path)
        structure, chunk = usual.get(s.name, (s.filter.structure, 500))
        s = _with(s, structure)
        resources.check(run_spec(s), chunk, s.timing.steps, full=False, batch_option="--chunk")


def test_every_bundled_scenario_runs_on_a_24gb_cpu(monkeypatch):
    monkeypatch.setattr(resources, "_platform", lambda: "cpu")
    monkeypatch.setattr(resources, "host_available", lambda: 20 * 2**30)
    for path in sorted((REPO / "scenarios").glob("*.toml")):
        s = load_scenario(path)
        resources.check(run_spec(s), 1, s.timing.steps)


def test_joint_swarm_chunk_refused_naming_per_target_and_chunk(monkeypatch):
    _gpu(monkeypatch, 60)
    s = _with(load_scenario("swarm_32r32t"), "joint")
    with pytest.raises(InputError) as err:
        resources.check(run_spec(s), 100, 600, 2, full=False, batch_option="--chunk")
    line = str(err.value)
    assert "\n" not in line and "--chunk 50" in line and "on the device" in line, line
    assert 'set [filter] structure = "per-target"' in line and "or --chunk" in line, line
    # the largest chunk that fits, by the same estimate
    fit = int(line.split("; --chunk ")[1].split()[0])
    resources.check(run_spec(s), 2 * fit, 600, 2, full=False, batch_option="--chunk")
    with pytest.raises(InputError):
        resources.check(run_spec(s), 2 * fit + 2, 600, 2, full=False, batch_option="--chunk")
    resources.check(
        run_spec(_with(s, "per-target")), 100, 600, 2, full=False, batch_option="--chunk"
    )


def test_bundled_swarm_32r32t_uses_the_per_target_filter():
    """The joint CKF of 32 drones keeps ~10 GB a trial on the CPU, ~5 GB for PFIM on a GPU
    (planner expectations quadratic in M); the bundled file runs the per-target bank,
    linear in M, 64 trials on one H200."""
    s = load_scenario("swarm_32r32t")
    assert s.filter.structure == "per-target"
    for kind in ("sfim", "pfim"):
        per_trial = sum(resources.device_terms(program_size(s), 1, "gpu", kind).values())
        assert 64 * per_trial < 40e9, (kind, per_trial)
    cpu = sum(resources.device_terms(program_size(s), 1, "cpu", "sfim").values())
    joint_cpu = sum(
        resources.device_terms(program_size(_with(s, "joint")), 1, "cpu", "sfim").values()
    )
    joint_gpu = sum(
        resources.device_terms(program_size(_with(s, "joint")), 1, "gpu", "pfim").values()
    )
    assert joint_cpu > 20 * cpu and joint_gpu > 20 * per_trial, (cpu, joint_cpu, joint_gpu)


def test_memory_limit_parsing(monkeypatch):
    for raw, value in (
        ("6G", 6 * 2**30),
        ("512M", 512 * 2**20),
        ("2e9", 2e9),
        ("1.5GiB", 1.5 * 2**30),
    ):
        monkeypatch.setenv(resources.LIMIT_ENV, raw)
        assert resources.memory_limit() == int(value), raw
    monkeypatch.setenv(resources.LIMIT_ENV, "lots")
    with pytest.raises(InputError, match="MJX_RADAR_MEMORY_LIMIT"):
        resources.memory_limit()


def test_over_large_run_refused_in_one_line_before_compiling(tmp_path, monkeypatch, capsys):
    """A forced budget of 64 MiB: `run smoke --trials 4096` is refused on one line naming
    the largest --trials that fits, exit 2, nothing compiled, nothing written."""
    import mjx_radar.cli.main as cli
    from mjx_radar.engine import programs

    monkeypatch.setenv(resources.LIMIT_ENV, "64M")
    compiled = len(programs.COMPILE_LOG)
    out = tmp_path / "run"
    t0 = time.perf_counter()
    code = cli.main(["run", "smoke", "--trials", "4096", "--out", str(out), "--no-cache"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and "Traceback" not in err, err
    assert "64.0 MiB free in host RAM" in err and "planner expectations" in err, err
    fit = int(err.split("; --trials ")[1].split()[0])
    s = load_scenario("smoke")
    steps = s.timing.steps
    resources.check(run_spec(s), fit, steps, kind="sfim")  # it fits, one more does not
    with pytest.raises(InputError):
        resources.check(run_spec(s), fit + 1, steps, kind="sfim")
    assert len(programs.COMPILE_LOG) == compiled and not out.exists()
    assert time.perf_counter() - t0 < 30


def test_study_refused_naming_a_chunk_that_fits(tmp_path, monkeypatch, capsys):
    import mjx_radar.cli.main as cli

    monkeypatch.setenv(resources.LIMIT_ENV, "64M")
    out = tmp_path / "study"
    argv = ["study", "smoke", "--methods", "stationary,ddr-sfim", "--trials", "1000"]
    code = cli.main([*argv, "--chunk", "1000", "--steps", "8", "--out", str(out)])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1, err
    assert "--chunk 1000" in err and "--chunk" in err.split("free in host RAM; ")[1], err
    assert not (out / "chunks").exists()


def test_out_of_memory_in_xla_becomes_one_input_error_line(monkeypatch):
    """XLA's RESOURCE_EXHAUSTED (compiling or running) never reaches the user as a
    traceback: simulate() raises InputError naming the batch and what to reduce."""
    import jax

    import mjx_radar
    from mjx_radar.engine import oom, programs

    def exhausted(*a, **k):
        raise jax.errors.JaxRuntimeError(
            "RESOURCE_EXHAUSTED: Out of memory allocating 59359742032 bytes.\nmore detail"
        )

    monkeypatch.setattr(programs, "_compile", exhausted)
    s = _with(load_scenario("swarm_8r8t"), "joint")
    with pytest.raises(InputError) as err:
        mjx_radar.simulate(s, "ddr-sfim", trials=6, steps=4, progress=False, cache=False)
    line = str(err.value)
    assert "\n" not in line and "out of memory running 6 trial(s) per device" in line, line
    assert "allocating 59359742032 bytes" in line and "to 3 or fewer" in line, line
    assert 'structure = "per-target"' in line, line
    assert not oom.out_of_memory(ValueError("RESOURCE_EXHAUSTED"))  # XLA's errors only


def test_float64_doubles_the_estimate(monkeypatch):
    import jax

    s = load_scenario("smoke")
    f32 = resources.device_terms(program_size(s), 4, "cpu")
    with jax.enable_x64(True):
        assert resources.float_bytes() == 8
        f64 = resources.device_terms(program_size(s), 4, "cpu")
    assert all(f64[k] == pytest.approx(2 * f32[k], rel=1e-6) for k in f32)


def test_run_takes_gpu_memory_on_demand_unless_the_user_chose(monkeypatch, capsys):
    # `mjx-radar run` asks JAX not to reserve 75 % of a GPU at the first transfer (1 s
    # of a warm run on an H100), before anything starts JAX's backend; a user's own
    # setting stays. (A scenario that does not exist: the command stops after the setting.)
    import mjx_radar.cli.main as cli

    monkeypatch.delenv("XLA_PYTHON_CLIENT_PREALLOCATE", raising=False)
    assert cli.main(["run", "no_such_scenario"]) == 2
    assert os.environ["XLA_PYTHON_CLIENT_PREALLOCATE"] == "false"
    assert "no_such_scenario" in capsys.readouterr().err
    monkeypatch.setenv("XLA_PYTHON_CLIENT_PREALLOCATE", "true")
    resources.allocate_gpu_memory_on_demand()
    assert os.environ["XLA_PYTHON_CLIENT_PREALLOCATE"] == "true"


# The MHT's terms (benchmarks/mht_memory.py): clutter_3r4t with K = 16-1024 hypotheses,
# settling and label-free merging, a run's stationary program and a study's, against XLA's
# figure on the CPU (2 trials) and one H200 (64 trials)
MHT_ROWS = {
    plat: json.loads((REPO / f"benchmarks/results/memory_model_mht_{f}.json").read_text())["rows"]
    for plat, f in (("cpu", "cpu"), ("gpu", "h200"))
}


@pytest.mark.parametrize(
    "platform, row",
    [(p, r) for p, rows in MHT_ROWS.items() for r in rows],
    ids=lambda r: r if isinstance(r, str) else "-".join(map(str, r[:2])),
)
def test_mht_terms_against_xla(platform, row):
    """Within 25 % on the CPU, and on the GPU where the MHT's arrays dominate (XLA's
    figure above 1 GB); below that the GPU fuses more (up to 1.9x), never under 0.9."""
    sys.path.insert(0, str(REPO / "benchmarks"))
    from mht_memory import scenario

    name, kind, program, trials, xla, _ = row
    s = scenario(name)
    est = sum(
        resources.device_terms(
            program_size(s), trials, platform, kind, program == "run", runner_segment(s)
        ).values()
    )
    lo, hi = memory_model.BUNDLED_FACTOR
    if platform == "gpu" and xla < 1e9:
        hi = 1.9
    assert lo <= est / xla <= hi and est / xla >= 0.9, (platform, row, est / xla)


def test_mht_label_merging_chunk_refused_naming_the_hypotheses(monkeypatch):
    """K = 1024 with label-free merging needs ~1 GB a trial: 200 trials do not fit 100 GiB
    and the line names the MHT's settings and the chunk that fits."""
    _gpu(monkeypatch, 100)
    s = load_scenario("clutter_3r4t").replace(
        tracker={"association": "mht", "hypotheses": 1024, "merge_screen": 2, "merge_labels": True}
    )
    assert program_size(s).merge_pairs == 2048
    with pytest.raises(InputError) as err:
        resources.check(run_spec(s), 200, 600, full=False, batch_option="--chunk")
    line = str(err.value)
    assert "\n" not in line and "the MHT hypotheses need" in line, line
    assert "tracker.hypotheses = 1024 of 625 joint events" in line, line
    assert "set tracker.merge_labels = false" in line, line
    fit = int(line.split("; --chunk ")[1].split()[0])
    assert 50 <= fit < 200, fit
    resources.check(run_spec(s), fit, 600, full=False, batch_option="--chunk")
    no_labels = s.replace(tracker={"merge_labels": False})
    resources.check(run_spec(no_labels), 200, 600, full=False, batch_option="--chunk")
