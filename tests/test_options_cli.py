"""Options beyond the paper run end to end through ``mjx-radar run``: the range + azimuth
measurement model with the per-target filter bank, and ``--precision float64``."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd

import mjx_radar.cli.main as cli

REPO = Path(__file__).resolve().parent.parent
SMOKE = (REPO / "scenarios" / "smoke.toml").read_text()
RUN = ["--steps", "8", "--rollouts", "analytic", "--trials", "2"]


def _frame(out: Path) -> pd.DataFrame:
    return pd.read_parquet(out / "metrics.parquet")


def test_range_azimuth_with_per_target_filter_runs(tmp_path):
    path = tmp_path / "smoke_az.toml"
    text = SMOKE.replace('name = "smoke"', 'name = "smoke_az"')
    path.write_text(text + '\n[measurement]\nmodel = "range-azimuth"\n\n[filter]\n'
                    'structure = "per-target"\n')  # fmt: skip
    out = tmp_path / "az"
    assert cli.main(["run", str(path), *RUN, "--out", str(out)]) == 0
    f = _frame(out)
    assert len(f) == 2 * 8 and np.isfinite(f[["rmse_pos", "nees", "crlb_pos"]]).all().all()
    # the azimuth adds information: the bound is below the range-only one of the same run
    ref = tmp_path / "ref"
    assert cli.main(["run", str(REPO / "scenarios" / "smoke.toml"), *RUN, "--out", str(ref)]) == 0
    assert (f["crlb_pos"].to_numpy() < _frame(ref)["crlb_pos"].to_numpy()).all()
    copied = (out / "scenario.toml").read_text()
    assert "range-azimuth" in copied and "per-target" in copied


def test_precision_float64_api_equals_cli(tmp_path):
    """``simulate(precision="float64")`` puts x64 mode on for this call only, yet the
    programs are traced in worker threads (JAX's mode is per thread: they traced float32
    and refused the float64 arguments): the API's numbers are the CLI's, which sets the
    mode for its whole process. The CLI run loads the API's program from the cache."""
    import jax

    from mjx_radar import simulate

    res = simulate(
        "smoke", "ddr-sfim", trials=2, steps=8, rollouts="analytic", precision="float64",
        progress=False,
    )  # fmt: skip
    assert not jax.config.jax_enable_x64  # the mode was the call's only
    assert res.meta["precision"] == "float64" and res.metrics["nees"].dtype == np.float64
    out = tmp_path / "f64"
    cmd = [sys.executable, "-m", "mjx_radar", "run", "scenarios/smoke.toml", *RUN]
    cmd += ["--out", str(out), "--precision", "float64"]
    proc = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-2000:]
    meta = json.loads((out / "run.json").read_text())
    assert meta["precision"] == "float64"
    # the default: deterministic where a GPU backend may start; a CPU's kernels always are
    assert meta["deterministic"] is True
    cli_frame = _frame(out)
    assert np.isfinite(cli_frame[["rmse_pos", "crlb_pos"]]).all().all()
    for col in ("rmse_pos", "nees", "crlb_pos"):
        np.testing.assert_array_equal(cli_frame[col].to_numpy(), res.metrics[col].to_numpy())
