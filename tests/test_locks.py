"""One writer per output directory (``io/lock.py``, issue 26).

Two ``run`` (or ``study``, or ``study --resume``) processes given the same ``--out``
used to both exit 0 and claim the results. Now the second one gets one line and exit
2 while the first holds ``DIR/.lock``; ``--shard I/N`` workers share the directory
(shared lock) but one shard cannot run twice. ``flock`` locks belong to an open file
description, so a second :func:`lock_dir` in this very process conflicts too.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from mjx_radar.cli.main import main
from mjx_radar.errors import InputError
from mjx_radar.io.lock import lock_dir
from mjx_radar.study.driver import Worker
from mjx_radar.study.execute import lock_out

REPO = Path(__file__).resolve().parent.parent
SMOKE = str(REPO / "scenarios" / "smoke.toml")
FAST = ["--steps", "8", "--rollouts", "analytic"]
STUDY = ["smoke", "--methods", "stationary", "--rollouts", "analytic", "--steps", "8"]
STUDY += ["--trials", "2", "--chunk", "2"]
ENV = {**os.environ, "JAX_PLATFORMS": "cpu", "PYTHONPATH": str(REPO)}
BUSY = "another mjx-radar process (pid {}) is writing there"


def _one_line_exit2(capsys, argv, needle):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and needle in err and "Traceback" not in err, err
    return err


def test_lock_semantics(tmp_path):
    with lock_dir(tmp_path) as held:
        assert held.held and (tmp_path / ".lock").read_text().split() == [str(os.getpid())]
        with pytest.raises(InputError, match=re.escape(BUSY.format(os.getpid()))):
            lock_dir(tmp_path)
        with pytest.raises(InputError):
            lock_dir(tmp_path, shared=True)
    assert list(tmp_path.iterdir()) == []  # released and removed
    a, b = lock_dir(tmp_path, shared=True), lock_dir(tmp_path, shared=True)
    with pytest.raises(InputError):
        lock_dir(tmp_path)
    a.release()
    assert (tmp_path / ".lock").exists()  # b still holds it
    with pytest.raises(InputError):
        lock_dir(tmp_path)
    b.release()
    assert list(tmp_path.iterdir()) == []
    lock_dir(tmp_path).release()


def test_run_refused_while_another_writes(tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    with lock_dir(out):
        err = _one_line_exit2(capsys, ["run", SMOKE, "--out", str(out), *FAST], "writing there")
        assert f"--out = {str(out)!r}" in err and f"pid {os.getpid()}" in err
        # --force does not override a live writer
        _one_line_exit2(capsys, ["run", SMOKE, "--out", str(out), "--force", *FAST], "pid")
    assert list(out.iterdir()) == []


def test_run_refused_by_a_holder_process_until_it_is_killed(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    hold = "import sys, time; from mjx_radar.io.lock import lock_dir; l = lock_dir(sys.argv[1]); "
    hold += "print('locked', flush=True); time.sleep(600)"
    holder = subprocess.Popen([sys.executable, "-c", hold, str(out)], env=ENV, cwd=REPO,
                              stdout=subprocess.PIPE, text=True)  # fmt: skip
    try:
        assert holder.stdout.readline().strip() == "locked"
        cmd = [sys.executable, "-m", "mjx_radar", "run", SMOKE, "--out", str(out), *FAST]
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120, env=ENV, cwd=REPO)
        err = proc.stderr.strip()
        assert proc.returncode == 2 and len(err.splitlines()) == 1, err
        assert BUSY.format(holder.pid) in err, err
    finally:
        holder.kill()  # SIGKILL: the kernel drops the lock with the process
        holder.wait()
    with lock_dir(out):  # free again, though the killed holder's .lock file is left
        pass


def test_study_and_resume_refused_while_another_writes(tmp_path, capsys):
    out = tmp_path / "study"
    out.mkdir()
    with lock_dir(out):
        for extra in ([], ["--resume"], ["--shard", "0/2"]):
            _one_line_exit2(capsys, ["study", *STUDY, "--out", str(out), *extra], "writing there")
    assert list(out.iterdir()) == []


def test_study_refused_while_a_shard_runs(tmp_path, capsys):
    out = tmp_path / "study"
    _, locks = lock_out(out, Worker(1, 2, "shard"))
    try:
        _one_line_exit2(capsys, ["study", *STUDY, "--out", str(out), "--resume"], "writing there")
        argv = ["study", *STUDY, "--out", str(out), "--shard", "1/2"]
        err = _one_line_exit2(capsys, argv, "is running shard 1/2 there")
        assert f"pid {os.getpid()}" in err
    finally:
        for lock in locks:
            lock.release()


def test_shards_share_a_directory(tmp_path):
    out = tmp_path / "study"
    held = []
    for i in range(3):  # every shard of a study at once
        held += lock_out(out, Worker(i, 3, "shard"))[1]
    held += lock_out(out, Worker(1, 2, "distributed"))[1]
    with pytest.raises(InputError, match="running shard 2/3"):
        lock_out(out, Worker(2, 3, "shard"))
    with pytest.raises(InputError, match="writing there"):
        lock_out(out, Worker())
    for lock in held:
        lock.release()
    assert list(out.iterdir()) == []
    lock_out(out, Worker())[1][0].release()


@pytest.mark.slow
def test_two_runs_at_once_one_refused(tmp_path):
    """The report of issue 26: two ``run`` processes on one ``--out`` both exited 0."""
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "mjx_radar", "run", SMOKE, "--out", str(out), *FAST]
    cmd += ["--cache-dir", str(tmp_path / "cache")]
    procs = [subprocess.Popen(cmd, env=ENV, cwd=REPO, stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True) for _ in range(2)]  # fmt: skip
    results = [p.communicate(timeout=900) for p in procs]
    codes = sorted(p.returncode for p in procs)
    assert codes == [0, 2], results
    refused = next(err for p, (_, err) in zip(procs, results, strict=True) if p.returncode == 2)
    assert "writing there" in refused and len(refused.strip().splitlines()) == 1, refused
    assert (out / "run.json").exists() and not (out / ".lock").exists()
