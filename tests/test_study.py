"""``mjx-radar study`` / ``report``: kill -9 and resume, statistics, bad input, figures.

One small study (smoke, stationary + ddr-sfim with analytic rollouts, 4 trials x
8 steps in chunks of 2) is run in-process once per module and reused.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import jax
import numpy as np
import pandas as pd
import pytest

import mjx_radar.cli.main as cli
from mjx_radar.engine import determinism
from mjx_radar.engine.run_spec import run_spec
from mjx_radar.study import metrics as study_metrics

REPO = Path(__file__).resolve().parent.parent
ARGS = ["smoke", "--methods", "stationary,ddr-sfim", "--rollouts", "analytic"]
ARGS += ["--steps", "8", "--trials", "4", "--chunk", "2", "--seed", "3"]


def _frame(d: Path) -> pd.DataFrame:
    f = pd.read_parquet(d / "metrics.parquet")
    return f.sort_values(["scenario", "method", "trial", "step"]).reset_index(drop=True)


def _subprocess(args: list[str], **kw) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "mjx_radar", *args], cwd=REPO, text=True, **kw)


@pytest.fixture(scope="module")
def study_dir(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("study") / "full"
    assert cli.main(["study", *ARGS, "--out", str(out)]) == 0
    return out


def test_study_files_and_finite(study_dir):
    meta = json.loads((study_dir / "study.json").read_text())
    assert meta["methods"] == ["stationary", "ddr-sfim"] and meta["trials"] == 4
    assert meta["non_finite"] == 0 and meta["devices"].startswith("[")
    # the default (None): on where it can be set; a CPU's kernels are deterministic anyway
    on_cpu = jax.default_backend() == "cpu"
    assert meta["deterministic"] is (on_cpu or determinism.flag_in_env() is True)
    # this study's program only (stationary rides along in the SFIM one)
    assert {(p["n_radars"], p["batch"], p["kind"]) for p in meta["programs"]} <= {
        (2, 2, "sfim+none")
    }
    assert all(p["trace_lower_s"] >= 0 and p["xla_compile_s"] >= 0 for p in meta["programs"])
    frame = _frame(study_dir)
    assert len(frame) == 2 * 4 * 8
    cols = ["rmse_pos", "rmse_state", "nees", "crlb_pos"]
    assert np.isfinite(frame[cols].to_numpy()).all()
    assert sorted(p.name for p in (study_dir / "chunks").iterdir()) == [
        f"smoke__{m}__{a}-{b}.parquet"
        for m in ("ddr-sfim", "stationary")
        for a, b in ((0, 1), (2, 3))
    ]


def test_trial_independent_of_batch_mates(study_dir):
    """Trial i's numbers do not depend on the other trials of its (same-size) batch, nor
    on the program that runs its method."""
    import dataclasses

    from mjx_radar.engine import runner
    from mjx_radar.scenario.reader import load_scenario

    s = load_scenario("smoke")
    s = dataclasses.replace(s, mpc=dataclasses.replace(s.mpc, rollout="analytic"))
    frame = _frame(study_dir)
    # run alone, each method in its own program: the study's shared program (stationary
    # rides along in the SFIM one) gives the same numbers bit for bit
    for method in ("ddr-sfim", "stationary"):
        res = runner.run_trials(run_spec(s), method, 3, [3, 1], 8, full=False)
        rows = frame[frame["method"] == method]
        for row, trial in enumerate((3, 1)):
            for col in ("rmse_pos", "nees", "crlb_pos", "gospa"):
                np.testing.assert_array_equal(
                    res[col][row], rows[rows["trial"] == trial][col].to_numpy(), err_msg=col
                )


def test_kill9_then_resume_is_identical(study_dir, tmp_path, sigkill_once_written):
    out = tmp_path / "killed"
    proc = _subprocess(["study", *ARGS, "--out", str(out)], stderr=subprocess.DEVNULL)
    # the first chunk a lane runs: the costliest ready one (study.lanes)
    sigkill_once_written(proc, out / "chunks" / "smoke__ddr-sfim__0-1.parquet", 300)
    assert not (out / "study.json").exists()
    assert 1 <= len(list((out / "chunks").glob("*.parquet"))) < 4  # killed mid-way
    assert cli.main(["study", *ARGS, "--out", str(out), "--resume"]) == 0
    pd.testing.assert_frame_equal(_frame(out), _frame(study_dir))
    # resuming a complete study changes nothing
    assert cli.main(["study", *ARGS, "--out", str(out), "--resume"]) == 0
    pd.testing.assert_frame_equal(_frame(out), _frame(study_dir))


def test_hdi_by_hand():
    # n = 10, the 90% window spans floor(0.9 * 10) = 9 gaps: only [x0, x9] = [1, 10].
    np.testing.assert_array_equal(study_metrics.hdi(np.arange(1.0, 11.0)), [1.0, 10.0])
    # n = 11, 9 gaps: [x0, x9] = [0, 9] (width 9) beats [x1, x10] = [1, 100] (width 99).
    outlier = np.array([0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 100.0])
    np.testing.assert_array_equal(study_metrics.hdi(outlier), [0.0, 9.0])
    # 50% of 6 values, 3 gaps: [1, 8] (7) < [2, 16] (14) < [4, 32] (28).
    np.testing.assert_array_equal(study_metrics.hdi([1.0, 2, 4, 8, 16, 32], 0.5), [1.0, 8.0])
    # per column of [T, K]: column 1 sorted [-50, 5 x 10] -> [x1, x10] = [5, 5] (width 0).
    two = np.stack([outlier, np.array([5.0] * 10 + [-50.0])], axis=1)
    np.testing.assert_array_equal(study_metrics.hdi(two), [[0.0, 9.0], [5.0, 5.0]])


def test_ecdf_by_hand():
    x, f = study_metrics.ecdf(np.array([[3.0, 1.0], [2.0, np.nan], [2.0, 4.0]]))
    np.testing.assert_array_equal(x, [1.0, 2.0, 3.0, 4.0])
    np.testing.assert_allclose(f, [0.2, 0.6, 0.8, 1.0])


def test_summary_reductions_by_hand():
    trials = np.arange(10)
    values = {
        "stationary": 10.0 + 0 * trials,
        "ddr-sfim": trials + 1.0,
        "ccr-sfim": 2.0 * (trials + 1),
    }
    rows = []
    for method, v in values.items():
        for step in (1, 2):
            rows.append(pd.DataFrame({"scenario": "x", "method": method, "trial": trials,
                                      "step": step, "time_s": 0.025 * step, "rmse_pos": v,
                                      "rmse_state": 2 * v, "crlb_pos": 1.0}))  # fmt: skip
    steps = study_metrics.per_step(pd.concat(rows, ignore_index=True))
    t = study_metrics.summary(steps).set_index("method")
    # means 10, 5.5, 11; HDI over 10 trials spans all of them: upper ends 10, 10, 20
    np.testing.assert_allclose(t["mean_rmse_pos"], [10.0, 5.5, 11.0])
    np.testing.assert_allclose(t["hdi_hi_pos"], [10.0, 10.0, 20.0])
    ddr = t.loc["ddr-sfim"]
    assert ddr.red_mean_vs_stationary == pytest.approx(45.0)  # 1 - 5.5 / 10
    assert ddr.red_hdi_vs_stationary == pytest.approx(0.0)  # 1 - 10 / 10
    assert ddr.red_mean_vs_ccr == pytest.approx(50.0) and ddr.red_hdi_vs_ccr == pytest.approx(50.0)
    assert np.isnan(t.loc["stationary", "red_mean_vs_stationary"])


@pytest.mark.parametrize(
    "argv",
    [
        ["study", "smoke", "--methods", "stationary,bogus"],
        ["study", "smoke", "--trials", "0"],
        ["study", "smoke", "--steps", "6"],
        ["study", "/nonexistent/missing.toml"],
    ],
)
def test_bad_input_exit_2_no_files(argv, tmp_path, capsys):
    out = tmp_path / "out"
    assert cli.main([*argv, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error:") and "\n" not in err and "Traceback" not in err
    assert not out.exists()


def test_existing_dir_needs_resume_and_same_config(study_dir, capsys):
    before = {p: p.stat().st_mtime_ns for p in study_dir.rglob("*")}
    assert cli.main(["study", *ARGS, "--out", str(study_dir)]) == 2
    assert "--resume" in capsys.readouterr().err
    changed = [a if a != "4" else "5" for a in ARGS]  # --trials 5
    assert cli.main(["study", *changed, "--out", str(study_dir), "--resume"]) == 2
    assert "trials" in capsys.readouterr().err
    assert {p: p.stat().st_mtime_ns for p in study_dir.rglob("*")} == before


def test_cli_subprocess_one_line_error(tmp_path):
    proc = _subprocess(["study", "smoke", "--methods", "nope", "--out", str(tmp_path / "o")],
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE)  # fmt: skip
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 2 and len(err.strip().splitlines()) == 1 and "nope" in err


def test_report(study_dir, tmp_path, capsys):
    assert cli.main(["report", str(tmp_path)]) == 2  # not a study
    assert cli.main(["report", str(study_dir)]) == 0
    md = (study_dir / "report.md").read_text()
    for name in ("smoke_rmse.png", "smoke_rmse_mppi.png", "smoke_ecdf.png"):
        png = study_dir / "figures" / name
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert f"(figures/{name})" in md
    assert "38–74%" in md and "33–79%" in md and "| ddr-sfim |" in md


@pytest.mark.slow
def test_two_devices_match_one(study_dir, tmp_path):
    """The trial axis sharded over 2 (forced host) devices, with padding, matches 1 device.

    Not bit for bit: the partitioned program rounds differently (float32, ~1e-5 relative);
    a wrong trial order or padding would show as O(1) differences.
    """
    out = tmp_path / "two"
    env = dict(os.environ, XLA_FLAGS="--xla_force_host_platform_device_count=2")
    args = ["study", "smoke", "--methods", "stationary", "--rollouts", "analytic", "--steps", "8"]
    proc = _subprocess(
        [*args, "--trials", "3", "--chunk", "3", "--seed", "3", "--out", str(out)], env=env
    )
    assert proc.wait(timeout=600) == 0
    assert json.loads((out / "study.json").read_text())["n_devices"] == 2
    two, one = _frame(out), _frame(study_dir)
    one = one[(one["method"] == "stationary") & (one["trial"] < 3)].reset_index(drop=True)
    for col in ("rmse_pos", "rmse_state", "nees", "crlb_pos"):
        np.testing.assert_allclose(two[col].to_numpy(), one[col].to_numpy(), rtol=1e-3)


@pytest.mark.slow
def test_two_devices_match_one_with_the_settled_mht(tmp_path):
    """The settled MHT sharded over 2 (forced host) devices, 3 trials padded to 4, matches
    1 device: its hypothesis tables split over the trial axis, its scan counter (a
    batch-shared leaf, ``HypState.BATCH_SHARED``) handed to every trial unbatched."""
    from mjx_radar.scenario.reader import load_scenario

    mht = {"association": "mht", "hypotheses": 16, "branch_scans": 1, "settle_scans": 8}
    mht |= {"settled_hypotheses": 4, "estimate": "consensus"}
    load_scenario("clutter_3r4t").replace(tracker=mht).to_toml(tmp_path / "mht.toml")
    args = ["study", str(tmp_path / "mht.toml"), "--methods", "stationary", "--rollouts"]
    args += ["analytic", "--steps", "16", "--trials", "3", "--chunk", "3", "--seed", "3"]
    frames = []
    for n in (1, 2):
        env = dict(os.environ, XLA_FLAGS=f"--xla_force_host_platform_device_count={n}")
        out = tmp_path / f"d{n}"
        assert _subprocess([*args, "--out", str(out)], env=env).wait(timeout=900) == 0
        assert json.loads((out / "study.json").read_text())["n_devices"] == n
        frames.append(_frame(out))
    for col in ("rmse_pos", "nees"):
        np.testing.assert_allclose(frames[1][col].to_numpy(), frames[0][col].to_numpy(), rtol=1e-3)
