"""Per-pair line-of-sight and detection masks of a run (``simulate(masks=True)``, ``--masks``),
and a mixed fleet with clutter end to end (issue 36).

The ``visible`` mask is checked against an independent line-of-sight reference (the
recorded radar and drone positions, the segment sampled finely against a box) and the
presence times; ``detected`` against the per-step counts of the metrics table. A run
without masks gives exactly the same numbers (the masks are outputs only). The mixed
fleet (``mixed_6r4t``: per-radar radar equations, fixed sites) with ``clutter_3r4t``'s
detection and clutter settings once failed in the PDA update (a broadcasting error); it
runs here with stationary radars (the filter path: per-radar noise in the PDA bank; the
planner's per-radar detection weights are unit-tested in test_fleet), and its masks are
checked against its counts.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import mjx_radar
from mjx_radar.scenario.schema import DetectionConfig, Obstacle, TargetMotion

BOX = Obstacle("box", (150.0, 0.0, 15.0), (10.0, 30.0, 15.0))  # 30 m high, across radar 0


@pytest.fixture(scope="module")
def scenario():
    """smoke with one box hiding drone 0 (not drone 1, higher) from radar 0, drone 1
    appearing at 0.1 s (step 4), and Swerling I detections (Pd ~ 0.5 near 300 m)."""
    s = mjx_radar.load_scenario("smoke")
    return dataclasses.replace(
        s,
        radar_init=((300.0, 0.0, 3.14159), (-300.0, 0.0, 0.0)),
        obstacles=(BOX,),
        target_motion=(TargetMotion(1, appear=0.1),),
        detection=DetectionConfig(model="swerling1", pfa=1e-6, gain_db=30.0),
    )


def _box_blocks(a, b, n=4001):
    """``[...]`` bool: segment a -> b passes through :data:`BOX` (sampled; reference)."""
    t = np.linspace(0.0, 1.0, n).reshape((n,) + (1,) * a.ndim)
    p = a[None] + t * (b - a)[None]  # [n, ..., 3]
    inside = np.all(np.abs(p - np.asarray(BOX.pos)) <= np.asarray(BOX.size), axis=-1)
    return inside.any(0)


def test_mixed_fleet_with_clutter_runs_and_records_masks():
    """A few steps: finite, sane metrics, false alarms, masks that add up."""
    mixed, clutter = (mjx_radar.load_scenario(n) for n in ("mixed_6r4t", "clutter_3r4t"))
    s = mixed.replace(
        filter={"structure": clutter.filter.structure},
        detection=dataclasses.asdict(clutter.detection),
    )
    run = mjx_radar.simulate(s, "stationary", trials=2, steps=8, masks=True, progress=False)
    m = run.metrics
    assert len(m) == 2 * 8 and np.isfinite(m[["rmse_pos", "nees", "crlb_pos"]]).all().all()
    assert (m.diverged == 0).all() and (m.lost == 0).all()
    # the tracks start N(truth, p0 I) (p0 = 50 m^2): RMSE ~ sqrt(3 p0) = 12.2 m, and the
    # bound starts below it and shrinks with the detections
    prior = np.sqrt(3 * s.p0)
    assert m.rmse_pos.max() < 3 * prior and (m.crlb_pos > 0).all()
    assert m.crlb_pos.max() < prior and m.crlb_pos.iloc[7] < m.crlb_pos.iloc[0]
    assert m.false_alarms.min() > 0  # ~ 0.005 / m x 1000 m x 6 radars = 30 per scan
    ds = run.trajectories
    assert len(run.meta["noise_constants"]) == 6  # the fleet's own radar equations
    vis, det = ds.visible.values, ds.detected.values  # [T, K, 6, 4]
    assert vis.all()  # no obstacles, every drone present
    assert not (det & ~vis).any() and 0 < det.sum() < vis.sum()
    np.testing.assert_array_equal(det.sum((2, 3)), ds.detections.values)
    assert det[:, :, :2].mean() > det[:, :, 2:].mean()  # the long-range sites see more


@pytest.mark.slow
def test_masks_match_geometry_presence_and_counts(scenario, tmp_path):
    run = mjx_radar.simulate(scenario, "stationary", trials=2, steps=8, masks=True, progress=False)
    ds = run.trajectories
    assert ds.visible.dims == ("trial", "step", "radar", "target")
    vis, det = ds.visible.values, ds.detected.values  # [T, K, N, M]
    radar = ds.radar_states.sel(radar_state=["x", "y", "z"]).values  # [T, K, N, 3]
    drone = ds.truth.sel(state=["x", "y", "z"]).values  # [T, K, M, 3]
    a = np.broadcast_to(radar[:, :, :, None], vis.shape + (3,))
    b = np.broadcast_to(drone[:, :, None], vis.shape + (3,))
    present = ds.present.values[None, :, None, :]  # [1, K, 1, M]
    np.testing.assert_array_equal(vis, ~_box_blocks(a, b) & present)
    assert not vis[:, :, 0, 0].any() and vis[:, 3:, 0, 1].all()  # hidden / visible
    assert not vis[:, :3, :, 1].any() and vis[:, :, 1].sum() == 2 * (8 + 5)
    assert not (det & ~vis).any() and 0 < det.sum() < vis.sum()  # misses happen
    np.testing.assert_array_equal(vis.sum((2, 3)), ds.visible_pairs.values)
    np.testing.assert_array_equal(det.sum((2, 3)), ds.detections.values)
    loaded = mjx_radar.Run.load(run.save(tmp_path / "run"))
    np.testing.assert_array_equal(loaded.trajectories.detected.values, det)
    plain = mjx_radar.simulate(scenario, "stationary", trials=2, steps=8, progress=False)
    assert "visible" not in plain.arrays and "visible" not in plain.trajectories
    for k in ("target", "mean", "cov_diag", "radar"):
        np.testing.assert_array_equal(plain.arrays[k], run.arrays[k], err_msg=k)


def test_masks_option_is_checked_and_on_the_command_line():
    with pytest.raises(mjx_radar.ScenarioError, match=r"^masks = 1: must be True or False"):
        mjx_radar.simulate("smoke", masks=1, progress=False)
    from mjx_radar.cli.main import build_parser

    args = build_parser().parse_args(["run", "smoke", "--masks"])
    assert args.masks is True
