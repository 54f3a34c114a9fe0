"""A study gives the same numbers on any number of devices, shards and processes.

One reference study (smoke, stationary + ddr-sfim, analytic rollouts, 4 trials x 8
steps in chunks of 2, seed 3) is run in-process once per module. Every other way of
running the same study must reproduce its ``metrics.parquet`` bit for bit
(``check_exact``): 2 forced host devices, ``--shard 0/2`` + ``--shard 1/2``, two
``--distributed`` processes on localhost (CPU backend), and a ``--shard`` job killed
with SIGKILL and run again. A trial's numbers depend only on the configuration and
the chunk size (every device runs the same per-device program on its own chunk), so
equality is exact, not approximate; any wrong trial order, padding or mixing of
chunks shows as an O(1) difference.
"""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from mjx_radar.cli.main import main as cli_main
from mjx_radar.errors import InputError
from mjx_radar.study import driver

REPO = Path(__file__).resolve().parent.parent
ARGS = ["smoke", "--rollouts", "analytic", "--steps", "8", "--methods", "stationary,ddr-sfim"]
ARGS += ["--trials", "4", "--chunk", "2", "--seed", "3"]
TIMEOUT_S = 600  # a cold compilation on a loaded 2-core machine


def _frame(d: Path) -> pd.DataFrame:
    return pd.read_parquet(d / "metrics.parquet")


def _same(d: Path, ref: Path) -> None:
    pd.testing.assert_frame_equal(_frame(d), _frame(ref), check_exact=True)


def _env(**extra) -> dict:
    env = dict(os.environ, JAX_PLATFORMS="cpu", **extra)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(REPO), env.get("PYTHONPATH")]))
    return env


def _study(args: list[str], **kw) -> subprocess.Popen:
    cmd = [sys.executable, "-m", "mjx_radar", "study", *ARGS, *args]
    return subprocess.Popen(cmd, cwd=REPO, text=True, **kw)


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("scaling") / "ref"
    assert cli_main(["study", *ARGS, "--out", str(out)]) == 0
    assert json.loads((out / "study.json").read_text())["n_devices"] == 1
    return out


@pytest.mark.slow  # 95-115 s on 2 cores: two programs compiled cold for a 2-device mesh in
# a subprocess; the shard and kill-resume tests keep chunk order and consolidation in CI
def test_two_devices_bit_identical(reference, tmp_path):
    """Same per-device chunk on 2 forced host devices: the same executable, the same bits."""
    out = tmp_path / "two"
    env = _env(XLA_FLAGS="--xla_force_host_platform_device_count=2")
    proc = _study(["--out", str(out)], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    _, err = proc.communicate(timeout=TIMEOUT_S)
    assert proc.returncode == 0, err[-2000:]
    assert json.loads((out / "study.json").read_text())["n_devices"] == 2
    _same(out, reference)


def test_shards_consolidate(reference, tmp_path, capsys):
    """``--shard 0/2`` leaves the study incomplete; ``--shard 1/2`` finds every chunk and
    consolidates."""
    out = tmp_path / "shards"
    assert cli_main(["study", *ARGS, "--out", str(out), "--shard", "0/2"]) == 0
    assert "2 of 4 chunks present" in capsys.readouterr().err
    assert not (out / "study.json").exists() and not (out / "metrics.parquet").exists()
    assert cli_main(["study", *ARGS, "--out", str(out), "--shard", "1/2"]) == 0
    assert "study complete" in capsys.readouterr().out
    _same(out, reference)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.slow  # two processes with jax.distributed (suite time; two devices stay in CI)
def test_distributed_two_processes(reference, tmp_path):
    """``jax.distributed`` on localhost (CPU backend): each process runs its chunks,
    process 0 waits for all and consolidates; both exit 0 together."""
    out = tmp_path / "dist"
    common = ["--out", str(out), "--distributed", "--coordinator", f"127.0.0.1:{_free_port()}"]
    common += ["--num-processes", "2"]
    procs = [
        _study(
            [*common, "--process-id", str(i)],
            env=_env(),
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
        )  # fmt: skip
        for i in (0, 1)
    ]
    try:
        results = [p.communicate(timeout=TIMEOUT_S) for p in procs]
    finally:
        for p in procs:
            p.kill()
            p.wait()
    for p, (_, err) in zip(procs, results, strict=True):
        assert p.returncode == 0, err[-3000:]
    assert "worker 1/2" in results[0][1] and "worker 2/2" in results[1][1]
    assert "study complete" in results[0][0] and "study complete" not in results[1][0]
    _same(out, reference)


def test_killed_shard_reruns_losing_at_most_one_chunk(
    reference, tmp_path, capsys, sigkill_once_written
):
    """SIGKILL a ``--shard 1/2`` job after its first chunk file: the rerun keeps that
    file, writes the rest, and with shard 0 the study equals the reference."""
    out = tmp_path / "killed"
    proc = _study(["--out", str(out), "--shard", "1/2"], env=_env(), stderr=subprocess.DEVNULL)
    # shard 1 owns chunks 1 and 3 (stationary 2-3, ddr-sfim 2-3) and runs the costliest first
    first = out / "chunks" / "smoke__ddr-sfim__2-3.parquet"
    sigkill_once_written(proc, first, TIMEOUT_S)
    kept = first.stat().st_mtime_ns
    assert not (out / "study.json").exists()
    assert cli_main(["study", *ARGS, "--out", str(out), "--shard", "1/2"]) == 0
    assert "2 of 4 chunks present" in capsys.readouterr().err
    assert first.stat().st_mtime_ns == kept  # the finished chunk was not run again
    assert cli_main(["study", *ARGS, "--out", str(out), "--shard", "0/2"]) == 0
    assert not list((out / "chunks").glob(".*"))  # no temporaries of the killed write
    _same(out, reference)


def test_resume_with_other_chunk_refused(reference, capsys):
    before = {p: p.stat().st_mtime_ns for p in reference.rglob("*")}
    changed = [a if a != "2" else "4" for a in ARGS]  # --chunk 4
    assert cli_main(["study", *changed, "--out", str(reference), "--resume"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "chunk = 4" in err and "Traceback" not in err
    assert {p: p.stat().st_mtime_ns for p in reference.rglob("*")} == before


def test_joining_worker_accepts_directory_being_created(tmp_path):
    """Workers started together: one may see ``scenarios/`` before ``manifest.json`` exists.

    A joining worker (``--shard`` / ``--distributed``) treats that as a fresh study; a
    single run or ``--resume`` still refuses a directory without a manifest.
    """
    out = tmp_path / "starting"
    (out / "scenarios").mkdir(parents=True)
    (out / "scenarios" / "smoke.toml").write_text("")
    assert driver.check_out(out, {}, resume=True, joining=True) is None
    with pytest.raises(InputError, match="no manifest.json"):
        driver.check_out(out, {}, resume=True)
    (out / "notes.txt").write_text("")  # not a study being created
    with pytest.raises(InputError, match="no manifest.json"):
        driver.check_out(out, {}, resume=True, joining=True)
