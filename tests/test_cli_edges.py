"""Hard edges of the command line: every bad input a clear refusal, never a hang.

Each refusal is exit 2 with one line on stderr before any simulation; Ctrl-C is exit
130 with no result file; diverged trials are exit 1 (results written) unless
``--keep-diverged``; a run directory is self-contained (scenario + meshes).
"""

from __future__ import annotations

import ctypes.util
import dataclasses
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest

from mjx_radar.cli import run_output
from mjx_radar.cli.main import main
from mjx_radar.engine import resources
from mjx_radar.engine.run_spec import run_spec
from mjx_radar.rundir import results

REPO = Path(__file__).resolve().parent.parent
SMOKE = str(REPO / "scenarios" / "smoke.toml")
FAST = ["--steps", "8", "--rollouts", "analytic"]
ENV = {**os.environ, "JAX_PLATFORMS": "cpu", "PYTHONPATH": str(REPO)}


def _cli(*args, env=None, timeout=120):
    cmd = [sys.executable, "-m", "mjx_radar", *args]
    return subprocess.run(
        cmd, capture_output=True, text=True, timeout=timeout, env=env or ENV, cwd=REPO
    )


def _one_line_exit2(capsys, argv, needle):
    t0 = time.perf_counter()
    code = main(argv)
    err = capsys.readouterr().err.strip()
    assert code == 2, err
    assert len(err.splitlines()) == 1 and needle in err and "Traceback" not in err, err
    return time.perf_counter() - t0


# --- 1. --out refused before any simulation -------------------------------------------


def test_out_is_a_file(tmp_path, capsys):
    f = tmp_path / "file"
    f.write_text("x")
    _one_line_exit2(capsys, ["run", SMOKE, "--out", str(f)], "not a directory")
    assert f.read_text() == "x"


@pytest.mark.parametrize("where", ["under_a_file", "proc"])
def test_out_cannot_be_created(tmp_path, capsys, where):
    (tmp_path / "file").write_text("x")
    out = tmp_path / "file" / "sub" if where == "under_a_file" else Path("/proc/mjx_radar/x")
    # Refused before the scenario is simulated or even placed: well under a compile.
    assert _one_line_exit2(capsys, ["run", SMOKE, "--out", str(out)], "cannot create") < 20


# --- 4. resources: refusal before compiling ------------------------------------------


def test_million_samples_refused(tmp_path):
    text = (
        (REPO / "scenarios" / "smoke.toml").read_text().replace("samples = 64", "samples = 1000000")
    )
    path = tmp_path / "big.toml"
    path.write_text(text)
    out = tmp_path / "out"
    t0 = time.perf_counter()
    proc = _cli("run", str(path), "--out", str(out), timeout=60)
    assert proc.returncode == 2, proc.stderr
    err = proc.stderr.strip()
    assert len(err.splitlines()) == 1, err
    assert "mppi.samples = 1000000" in err and "reduce mppi.samples" in err, err
    assert "TiB" in err
    assert not out.exists()  # the directory it created for the probe is removed again
    assert time.perf_counter() - t0 < 60


def test_estimate_sampling_term_matches_xla():
    # XLA asked for 24001128036752 bytes for the planner of smoke with S = 10^6 (the run
    # before this check existed): the S x S proposal noise, 24 bytes per entry.
    from mjx_radar.scenario.reader import load_scenario

    s = load_scenario(SMOKE)
    s = dataclasses.replace(s, mppi=dataclasses.replace(s.mppi, samples=10**6))
    est = resources.estimate(run_spec(s), trials=1, steps=8)
    assert est.device["MPPI sampling"] == pytest.approx(24001128036752, rel=1e-3)


def test_check_refuses_when_memory_is_short(monkeypatch):
    from mjx_radar.errors import InputError
    from mjx_radar.scenario.reader import load_scenario

    s = load_scenario(SMOKE)
    monkeypatch.setattr(resources, "host_available", lambda: 2**30)  # 1 GiB
    # trajectories: 2 * 100 * (1e5 * 70 + 25000 * 1124) floats = 28.1 GB, planner ~8 MB
    with pytest.raises(InputError, match=r"the trajectories need ~26.2 GiB.*--steps or --trials"):
        resources.check(run_spec(s), trials=100, steps=100_000)
    monkeypatch.setattr(resources, "host_available", lambda: 64 * 2**30)
    assert resources.check(run_spec(s), trials=100, steps=100_000).host_bytes == pytest.approx(
        28.1e9, 1e-2
    )


def test_500_radars_warned_and_interruptible(tmp_path):
    path = tmp_path / "wide.toml"
    path.write_text(
        'name = "wide"\nn_radars = 500\ntargets = [[0, 0, 55, 20, 10, 0]]\n'
        "placement_half_width = 5000.0\n[timing]\nsteps = 8\n"
    )
    est = resources.estimate(run_spec(__import__("mjx_radar").load_scenario(path)), 1, 8)
    assert est.large and est.compile_s > 300
    out = tmp_path / "out"
    _interrupt_after_compile_line(["run", str(path), "--out", str(out), *FAST], "can take minutes")
    assert not out.exists()


# --- 3. Ctrl-C ------------------------------------------------------------------------


def _interrupt_after_compile_line(argv, needle="compiling (", sig=signal.SIGINT):
    # Ctrl-C's default handler even when the test runner was started as a background
    # job (which ignores SIGINT, and Python then keeps ignoring it); a cold compilation
    # cache of its own (a warm one can finish the run before the signal arrives).
    boot = (
        "import runpy, signal, sys; signal.signal(signal.SIGINT, signal.default_int_handler); "
        "sys.argv[0] = 'mjx_radar'; runpy.run_module('mjx_radar', run_name='__main__')"
    )
    cmd = [sys.executable, "-c", boot, *argv]
    t0 = time.perf_counter()
    env = {**ENV, "MJX_RADAR_CACHE_DIR": tempfile.mkdtemp(prefix="mjx_radar_cache_")}
    proc = subprocess.Popen(
        cmd, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        env=env, cwd=REPO, text=True,
    )  # fmt: skip
    seen = []
    for line in proc.stderr:
        seen.append(line)
        if needle in line:
            break
    assert any(needle in line for line in seen), "".join(seen)
    time.sleep(1.0)  # inside the compilation now
    t_sig = time.perf_counter()
    proc.send_signal(sig)
    rest = proc.stderr.read()
    rc = proc.wait(timeout=30)
    assert rc == 130, rest
    assert time.perf_counter() - t_sig < 10  # at once, not after the compilation
    assert rest.strip().splitlines()[-1] == "interrupted: no results written", rest
    assert time.perf_counter() - t0 < 90


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_interrupt_writes_nothing(tmp_path, sig):
    out = tmp_path / "run"
    _interrupt_after_compile_line(["run", SMOKE, "--out", str(out), *FAST], sig=sig)
    assert not out.exists()


def test_interrupted_overwrite_leaves_no_run_json(tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    (out / "run.json").write_text("{}")  # an old complete run
    _interrupt_after_compile_line(["run", SMOKE, "--out", str(out), "--force", *FAST])
    names = {p.name for p in out.iterdir()}
    assert "run.json" not in names
    assert not [n for n in names if n.endswith(".part") or n.startswith(".probe")]


# --- 5. diverged trials ---------------------------------------------------------------


def test_diverged_line():
    div = np.zeros((4, 8), bool)
    assert run_output.diverged_line(div, np.arange(4), Path("d"), False) is None
    assert run_output.diverged_line(None, np.arange(4), Path("d"), False) is None
    div[3, 2:] = True  # trial 3 from step 3 (1-based)
    div[1, 5:] = True  # trial 1 from step 6
    line = run_output.diverged_line(div, np.arange(10, 14), Path("d"), False)
    assert line == (
        "error: 2 of 4 trials diverged (first at trial 13, step 3); results in d; "
        "pass --keep-diverged to accept"
    )
    assert run_output.diverged_line(div, np.arange(4), Path("d"), True).startswith(
        "warning: 2 of 4"
    )


def _fake_trials(scenario, method, seed, trials, steps, full=True, progress=None, **kw):
    t, k = len(trials), steps
    res = {name: np.ones((t, k)) for name in results.METRIC_COLUMNS}
    res |= {"target": np.zeros((t, k, 2, 6)), "wall_s": 1.0, "control_hz": 10.0}
    res |= {"compile_s": 0.5, "sim_s": 0.5}
    div = np.zeros((t, k), bool)
    div[1, 4:] = True
    return res | {"diverged": div}


@pytest.mark.parametrize("keep", [False, True])
def test_diverged_trials_exit_1_with_results(tmp_path, capsys, monkeypatch, keep):
    from mjx_radar.engine import runner

    monkeypatch.setattr(runner, "run_trials", _fake_trials)
    out = tmp_path / "run"
    argv = ["run", SMOKE, "--out", str(out), "--trials", "3", *FAST]
    code = main(argv + (["--keep-diverged"] if keep else []))
    err = capsys.readouterr().err.strip().splitlines()
    assert code == (0 if keep else 1)
    want = "warning: " if keep else "error: "
    assert err[-1].startswith(want + "1 of 3 trials diverged (first at trial 1, step 5)"), err
    meta = json.loads((out / "run.json").read_text())
    assert meta["diverged_trials"] == [1]
    assert meta["scenario_file"] == "scenario.toml"
    assert meta["source_scenario"] == str(Path(SMOKE).resolve())


# --- 2. self-contained run directory --------------------------------------------------

CUBE = (REPO / "scenarios" / "meshes" / "tower.obj").read_text()
MESH_SCENARIO = """# tiny scenario with a mesh obstacle
name = "meshy"
n_radars = 2
targets = [[0, 0, 55, 20, 10, 0]]
radars = [[300, 0, 3.14], [-300, 0, 0]]
[timing]
steps = 8
[mppi]
samples = 16
iterations = 2
[mpc]
horizon = 4
[[obstacles]]
kind = "mesh"
path = "meshes/cube.obj"   # relative to this file
pos = [100.0, 100.0, 0.0]
[[obstacles]]
kind = "mesh"
path = 'other/cube.obj'
pos = [-100.0, -100.0, 0.0]
"""


def _mesh_scenario(root: Path) -> Path:
    for sub in ("meshes", "other"):
        (root / sub).mkdir(parents=True)
        (root / sub / "cube.obj").write_text(CUBE + f"# {sub}\n")
    (root / "s.toml").write_text(MESH_SCENARIO)
    return root / "s.toml"


def test_bundle_is_self_contained(tmp_path, monkeypatch):
    from mjx_radar.scenario.bundle import bundle_scenario, dumps
    from mjx_radar.scenario.reader import load_scenario

    src = _mesh_scenario(tmp_path / "src")
    written = bundle_scenario(src, tmp_path / "run")
    assert [p.name for p in written] == ["cube.obj", "cube_1.obj", "scenario.toml"]
    copy = (tmp_path / "run" / "scenario.toml").read_text()
    assert "# relative to this file" in copy  # rewritten in place, comments kept
    shutil.move(tmp_path / "run", tmp_path / "moved")
    shutil.rmtree(tmp_path / "src")
    monkeypatch.chdir("/")
    s = load_scenario(tmp_path / "moved" / "scenario.toml")
    paths = [o.path for o in s.obstacles]
    assert paths == [str(tmp_path / "moved" / "meshes" / n) for n in ("cube.obj", "cube_1.obj")]
    import tomllib

    raw = tomllib.loads(copy)
    assert tomllib.loads(dumps(raw)) == raw  # the fallback writer round-trips


@pytest.mark.slow
def test_run_dir_moves(tmp_path, monkeypatch):
    from mjx_radar.scenario.reader import load_scenario

    src = _mesh_scenario(tmp_path / "src")
    proc = _cli("run", str(src), "--out", str(tmp_path / "run"), *FAST, timeout=600)
    assert proc.returncode == 0, proc.stderr
    shutil.move(tmp_path / "run", tmp_path / "moved")
    shutil.rmtree(tmp_path / "src")
    monkeypatch.chdir("/")
    s = load_scenario(tmp_path / "moved" / "scenario.toml")
    assert all(Path(o.path).is_file() for o in s.obstacles)
    meta = json.loads((tmp_path / "moved" / "run.json").read_text())
    assert meta["scenario_file"] == "scenario.toml"


# --- 6. small items -------------------------------------------------------------------


def test_version_and_help(capsys):
    # --version and --help in-process (argparse exits 0); ``run --help`` through the
    # console entry in a fresh process, where the import chatter would show
    with pytest.raises(SystemExit) as done:
        main(["--version"])
    assert done.value.code == 0 and capsys.readouterr().out.strip() == "mjx-radar 0.1.0"
    with pytest.raises(SystemExit) as done:
        main(["--help"])
    out = capsys.readouterr().out
    assert done.value.code == 0 and "SPEC" not in out and "Mobile ground radars" in out
    proc = _cli("run", "--help")
    text = " ".join(proc.stdout.split())
    for opt in ("--trials", "--steps", "--seed", "--out", "--force", "--keep-diverged"):
        assert f"{opt} " in text
    assert "--trials TRIALS Monte Carlo trials" in text  # every option has a help text
    for out in (proc.stdout, proc.stderr):
        assert "Failed to import" not in out


def test_no_warp_chatter_and_osmesa_fallback(tmp_path):
    proc = _cli("validate", SMOKE)
    assert proc.returncode == 0
    assert "Failed to import" not in proc.stdout + proc.stderr
    assert proc.stderr == ""
    if ctypes.util.find_library("OSMesa"):
        pytest.skip("libOSMesa is installed here")
    env = ENV | {"MUJOCO_GL": "osmesa"}
    proc = _cli("validate", SMOKE, env=env)
    assert proc.returncode == 0, proc.stderr  # needs no OpenGL
    proc = _cli("render", str(tmp_path), env=env)
    assert proc.returncode == 2
    assert proc.stderr.strip() == (
        "error: MUJOCO_GL=osmesa: libOSMesa not found; apt-get install libosmesa6 "
        "or set MUJOCO_GL=egl"
    )


def test_video_encoding_does_not_warn_about_fork(tmp_path):
    # The cause: imageio-ffmpeg's preexec_fn runs Python in a fork of the multithreaded
    # JAX process (JAX's at-fork hook warns). The CLI entry turns preexec_fn off.
    code = f"""
import warnings, numpy as np, imageio.v2 as iio
warnings.simplefilter("error")
from mjx_radar.cli.main import main
from mjx_radar.rundir import results
assert main(["validate", {SMOKE!r}]) == 0  # the CLI entry; JAX is running now
with iio.get_writer({str(tmp_path / "v.mp4")!r}, fps=10) as w:
    for _ in range(3):
        w.append_data(np.zeros((64, 64, 3), np.uint8))
"""
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=ENV, cwd=REPO, timeout=120)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert "fork" not in proc.stderr
