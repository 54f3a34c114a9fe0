"""Result files (mjx_radar.rundir.results, mjx_radar.io.atomic): schema, round trips, atomicity."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from mjx_radar.errors import InputError
from mjx_radar.io import atomic
from mjx_radar.rundir import results

T, K = 3, 4
KEYS = ("scenario", "method", "trial", "step", "time_s")


def _metrics(rng) -> dict:
    return {name: rng.normal(size=(T, K)) for name in results.METRIC_COLUMNS}


@pytest.fixture
def frame():
    metrics = _metrics(np.random.default_rng(0))
    time_s = 0.025 * np.arange(1, K + 1)
    return results.metrics_frame("smoke", "ddr-sfim", np.array([5, 6, 7]), time_s, metrics), metrics


def test_metrics_frame_schema(frame):
    df, metrics = frame
    assert df.shape == (T * K, len(KEYS) + len(results.METRIC_COLUMNS))
    assert tuple(df.columns) == KEYS + results.METRIC_COLUMNS
    assert isinstance(df["scenario"].dtype, pd.CategoricalDtype)
    assert isinstance(df["method"].dtype, pd.CategoricalDtype)
    assert df["trial"].dtype == np.int32 and df["step"].dtype == np.int32
    for name in ("time_s", *results.METRIC_COLUMNS):
        assert df[name].dtype == np.float64, name
    assert list(df["scenario"].unique()) == ["smoke"] and list(df["method"].unique()) == [
        "ddr-sfim"
    ]


def test_metrics_frame_long_format_order(frame):
    """Row ``t * K + k`` is trial ``t``, 1-based step ``k + 1``, and holds ``metrics[:, t, k]``."""
    df, metrics = frame
    np.testing.assert_array_equal(df["trial"], np.repeat([5, 6, 7], K))
    np.testing.assert_array_equal(df["step"], np.tile(np.arange(1, K + 1), T))
    np.testing.assert_array_equal(df["time_s"], np.tile(0.025 * np.arange(1, K + 1), T))
    for name in results.METRIC_COLUMNS:
        for t, k in ((0, 0), (1, 2), (2, 3)):
            assert df[name].iloc[t * K + k] == metrics[name][t, k]


def test_metrics_frame_missing_metric_raises():
    metrics = _metrics(np.random.default_rng(1))
    del metrics["nees"]
    with pytest.raises(KeyError):
        results.metrics_frame("s", "m", np.arange(T), np.arange(K), metrics)


def test_parquet_round_trip(tmp_path, frame):
    df, _ = frame
    path = tmp_path / "sub" / "metrics.parquet"
    results.write_parquet(path, df)
    back = pd.read_parquet(path)
    pd.testing.assert_frame_equal(back, df)  # values, dtypes (categories too) and order
    assert not list(path.parent.glob(".*part*"))


def test_npz_and_json_round_trip_through_read_run(tmp_path):
    rng = np.random.default_rng(2)
    arrays = {
        "radar": rng.normal(size=(2, 4, 3, 6)).astype(np.float32),
        "time_s": np.arange(4, dtype=np.float64),
        "sample_weight": rng.random((2, 1, 5)),
    }
    meta = {"scenario": "smoke", "steps": 4, "r2t": 50.0, "nested": {"a": [1, 2]}}
    results.write_npz(tmp_path / "trajectories.npz", arrays)
    results.write_json(tmp_path / "run.json", meta)
    assert json.loads((tmp_path / "run.json").read_text()) == meta
    meta_back, arrays_back = results.read_run(tmp_path)
    assert meta_back == meta and set(arrays_back) == set(arrays)
    for k, a in arrays.items():
        assert arrays_back[k].dtype == a.dtype
        np.testing.assert_array_equal(arrays_back[k], a)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.json", "trajectories.npz"]


@pytest.mark.parametrize("exc", [RuntimeError, KeyboardInterrupt])
def test_atomic_write_failure_keeps_old_file_and_no_part(tmp_path, exc):
    path = tmp_path / "run.json"
    path.write_text("old")
    seen = []

    def write(tmp):
        seen.append(tmp)
        Path(tmp).write_text("half-")
        raise exc("boom")

    with pytest.raises(exc):
        results.atomic_write(path, write)
    assert path.read_text() == "old"
    assert seen and not Path(seen[0]).exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.json"]


def test_atomic_write_replaces_and_names_temporaries(tmp_path):
    path = tmp_path / "new" / "clip.mp4"
    names = []

    def write(tmp):
        names.append(Path(tmp).name)
        Path(tmp).write_bytes(b"abc")

    atomic.atomic_write(path, write, keep_suffix=True)
    assert path.read_bytes() == b"abc" and (path.stat().st_mode & 0o777) == 0o644
    assert names[0].startswith(".clip.mp4.") and names[0].endswith(".part.mp4")
    atomic.atomic_write_text(path, "x")
    assert path.read_text() == "x"
    atomic.atomic_write_bytes(path, b"\x00\x01")
    assert path.read_bytes() == b"\x00\x01"
    assert sorted(p.name for p in path.parent.iterdir()) == ["clip.mp4"]
    assert results.atomic_write is atomic.atomic_write  # one implementation


def test_check_writable(tmp_path):
    ok = tmp_path / "a" / "b" / "fig.png"
    assert atomic.check_writable(ok) == ok
    assert ok.parent.is_dir() and not list(ok.parent.iterdir())  # probe removed
    (tmp_path / "file").write_text("")
    with pytest.raises(InputError, match=r"--out = .*cannot write there"):
        atomic.check_writable(tmp_path / "file" / "fig.png")
    with pytest.raises(InputError, match="is a directory"):
        atomic.check_writable(tmp_path / "a", "--out")
    with pytest.raises(InputError, match="--video"):
        atomic.check_writable(Path("/proc/mjx_radar_test/fig.png"), "--video")
