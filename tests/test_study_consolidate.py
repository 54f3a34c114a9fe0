"""metrics.parquet streamed while a study's chunks are written equals the chunk files read
back (study.consolidate)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from mjx_radar.rundir import results
from mjx_radar.study import consolidate
from mjx_radar.study.lost import lost_counts

SCENARIOS = ["b_world", "a_world"]  # study order, not alphabetical
METHODS = ["stationary", "ddr-sfim+grad", "ccr-sfim"]  # a planner name, canonical order differs
TRIALS, CHUNK, STEPS = 5, 2, 6


def _chunks(tmp_path, rng):
    """Chunk files of a small study (random metrics, a few NaN, lost flags) in study order."""
    time_s = 0.025 * np.arange(1, STEPS + 1)
    out = []
    for sc in SCENARIOS:
        for m in METHODS:
            for first in range(0, TRIALS, CHUNK):
                ids = np.arange(first, min(first + CHUNK, TRIALS))
                metrics = {k: rng.normal(size=(len(ids), STEPS)) for k in results.METRIC_COLUMNS}
                metrics["lost"] = rng.random((len(ids), STEPS)) < 0.2
                metrics["rmse_pos"][0, rng.integers(STEPS)] = np.nan
                frame = results.metrics_frame(sc, m, ids, time_s, metrics)
                path = tmp_path / "chunks" / f"{sc}__{m}__{ids[0]}-{ids[-1]}.parquet"
                results.write_parquet(path, frame)
                out.append((path, frame))
    return out


def test_the_streamed_table_is_the_table_read_back(tmp_path):
    chunks = _chunks(tmp_path, np.random.default_rng(0))
    paths = [p for p, _ in chunks]
    stream = consolidate.Stream(tmp_path / "metrics.parquet", paths, SCENARIOS, METHODS)
    for path, frame in chunks:
        stream.add(path, frame)
    summary = stream.finish()
    streamed = pd.read_parquet(tmp_path / "metrics.parquet")
    back = consolidate.read_chunks(paths, SCENARIOS)
    pd.testing.assert_frame_equal(streamed, back, check_exact=True)
    assert list(streamed["method"].cat.categories) == ["stationary", "ccr-sfim", "ddr-sfim+grad"]
    assert summary == consolidate.summarise(back)
    assert summary.rows == len(SCENARIOS) * len(METHODS) * TRIALS * STEPS
    assert summary.non_finite == len(chunks)  # one NaN per chunk
    # the lost counts of one cell from its [T, K] table
    cell = back[(back.scenario == "a_world") & (back.method == "stationary")]
    lost = cell.pivot(index="trial", columns="step", values="lost").to_numpy()
    assert summary.lost["a_world/stationary"] == lost_counts(lost)
    assert not list(tmp_path.glob(".*.part"))


@pytest.mark.parametrize("how", ["given twice", "incomplete"])
def test_a_stream_that_missed_a_chunk_writes_nothing(tmp_path, how):
    """The study then reads its chunk files back (driver.finish)."""
    chunks = _chunks(tmp_path, np.random.default_rng(1))
    paths = [p for p, _ in chunks]
    stream = consolidate.Stream(tmp_path / "metrics.parquet", paths, SCENARIOS, METHODS)
    given = chunks + chunks[-1:] if how == "given twice" else chunks[:-1]
    for path, frame in given:
        stream.add(path, frame)
    assert stream.finish() is None
    assert not (tmp_path / "metrics.parquet").exists()
    assert not list(tmp_path.glob(".*.part"))


def test_chunks_added_out_of_order_from_threads_are_written_in_study_order(tmp_path):
    """A study's host threads finish chunks in any order (study.host_work)."""
    from concurrent.futures import ThreadPoolExecutor

    chunks = _chunks(tmp_path, np.random.default_rng(2))
    paths = [p for p, _ in chunks]
    stream = consolidate.Stream(tmp_path / "metrics.parquet", paths, SCENARIOS, METHODS)
    order = np.random.default_rng(3).permutation(len(chunks))
    with ThreadPoolExecutor(3) as pool:
        list(pool.map(lambda i: stream.add(*chunks[i]), order))
    summary = stream.finish()
    back = consolidate.read_chunks(paths, SCENARIOS)
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "metrics.parquet"), back)
    assert summary == consolidate.summarise(back)
