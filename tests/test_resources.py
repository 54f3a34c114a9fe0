"""The memory estimate (``engine/resources.py``) against XLA's own figures (issue 26).

XLA's figure for a program is ``compiled.memory_analysis()`` of the segment ("step")
program: temporaries + arguments + outputs - donated aliases (what XLA allocates at
once; a 300-target joint run asked for exactly its temporaries, 26.8 GB, and died).
``CPU_MEASURED`` / ``CPU_BUNDLED`` hold it for small shapes and two bundled scenes on
the CPU (jax 0.10.2), ``GPU_MEASURED`` for the bundled scenarios at study sizes on one
H100 (jax 0.11.2), all from ``scripts/measure_memory.py``. The estimate must lie within
``resources.MEASURED_FACTOR`` of each; two CPU shapes are compiled here again.
"""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from mjx_radar.engine import resources
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
    est = sum(resources.device_terms(s, trials, "cpu").values())
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
    est = sum(resources.device_terms(s, trials, platform).values())
    # a program of a few MB (smoke: 1.6x) is fused more tightly on the GPU; never below
    assert LO <= est / xla and (est / xla <= HI or xla < 10e6), (case, est / xla)


@pytest.mark.slow  # a 4-radar program compiled cold (45-65 s on 2 cores); the model stays in CI
# through the recorded XLA figures (test_estimate_within_factor_of_bundled_scenarios)
@pytest.mark.parametrize("structure", ["joint", "per-target"])
def test_estimate_matches_a_fresh_compilation(tmp_path, structure):
    """Compiles a small shape's step program now and compares with XLA's figure."""
    from mjx_radar.engine import programs, runner

    s = _shape(tmp_path, 4, 2, 64, 8, structure, "analytic", False, False)
    progs, _ = programs.compile_programs(s, 2, runner.segment_periods(s, 8), full=True)
    ma = progs.step.memory_analysis()
    xla = (ma.temp_size_in_bytes + ma.argument_size_in_bytes + ma.output_size_in_bytes
           - ma.alias_size_in_bytes)  # fmt: skip
    est = sum(resources.device_terms(s, 2, "cpu").values())
    assert LO <= est / xla <= HI, (structure, est, xla)


def test_300_targets_joint_refused_before_compiling(tmp_path):
    """The run that died in XLA asking for 26.8 GB: one line, exit 2, in seconds."""
    path = tmp_path / "many.toml"
    path.write_text(_scenario_text(300, 4, 0, 15, "joint", "mjx", name="many"))  # S = 200
    s = load_scenario(path)
    need = sum(resources.estimate(s, 1, 80).device.values())
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
        resources.check(s, chunk, s.timing.steps, full=False, batch_option="--chunk")


def test_every_bundled_scenario_runs_on_a_24gb_cpu(monkeypatch):
    monkeypatch.setattr(resources, "_platform", lambda: "cpu")
    monkeypatch.setattr(resources, "host_available", lambda: 20 * 2**30)
    for path in sorted((REPO / "scenarios").glob("*.toml")):
        s = load_scenario(path)
        resources.check(s, 1, s.timing.steps)


def test_joint_swarm_chunk_refused_naming_per_target_and_chunk(monkeypatch):
    _gpu(monkeypatch, 60)
    s = load_scenario("swarm_32r32t")
    with pytest.raises(InputError) as err:
        resources.check(s, 100, 600, 2, full=False, batch_option="--chunk")
    line = str(err.value)
    assert "\n" not in line and "--chunk 50" in line and "on the device" in line, line
    assert 'set [filter] structure = "per-target"' in line and "or --chunk" in line, line
    resources.check(_with(s, "per-target"), 100, 600, 2, full=False, batch_option="--chunk")


def test_float64_doubles_the_estimate(monkeypatch):
    import jax

    s = load_scenario("smoke")
    f32 = resources.device_terms(s, 4, "cpu")
    with jax.enable_x64(True):
        assert resources.float_bytes() == 8
        f64 = resources.device_terms(s, 4, "cpu")
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
