"""hills_4r4t in the closed loop (docs/terrain.md): radar z follows the terrain along the
run, the ridge masks radar-target pairs (``visible_pairs``), and the occlusion-aware
planner (``mpc.los``) compiles with the terrain in its line-of-sight test.

Slow (one closed-loop compile with the planner, 60-160 s on 2 CPU cores); the pieces are
tested fast in tests/test_terrain.py (lookup, LOS, plant z on a known slope).
"""

from __future__ import annotations

import numpy as np
import pytest

from mjx_radar.scenario.reader import load_scenario
from mjx_radar.world import terrain

pytestmark = pytest.mark.slow

Z_TOL = 1e-3  # m: float32 bilinear lookup of heights <= 100 m (docs/terrain.md)


@pytest.fixture(scope="module")
def hills_run():
    import mjx_radar

    s = load_scenario("hills_4r4t").replace(
        # radar 0 stands 170 m west of the ridge crest: the crest hides the drones from it
        radars=[[50.0, 0.0, 3.0], [-300.0, 200.0, 1.0], [-250.0, -300.0, 0.5], [0.0, 350.0, 0.0]],
        mpc={"horizon": 3, "rollout": "analytic", "los": True},
        mppi={"samples": 32, "iterations": 1},
        timing={"steps": 80},
    )
    return s, mjx_radar.simulate(s, "ddr-sfim", trials=2, progress=False)


def test_radars_stay_on_the_terrain_and_z_varies(hills_run):
    s, run = hills_run
    radar = np.asarray(run.arrays["radar"])  # [T, K, N, 6]
    ground = terrain.height_np(s.terrain, radar[..., :2].astype(float))
    np.testing.assert_allclose(radar[..., 2], ground + s.terrain.antenna_height, atol=Z_TOL)
    assert np.ptp(radar[..., 2], axis=1).max() > 0.1  # z changes along the run
    assert np.ptp(radar[:, -1, :, 2], axis=-1).min() > 1.0  # the radars are not coplanar


def test_ridge_masks_some_pairs(hills_run):
    s, run = hills_run
    vis = run.metrics["visible_pairs"].to_numpy()
    n_pairs = s.n_radars * s.n_targets
    assert vis.min() < n_pairs and vis.max() > 0
    assert np.isfinite(run.metrics["rmse_pos"]).all()


def test_saved_run_renders_the_terrain(hills_run, tmp_path):
    """The run directory carries the height field; the render scene has the hfield and
    puts each radar's body on the ground; the snapshot shades terrain and masked regions."""
    import matplotlib.pyplot as plt
    import mujoco

    from mjx_radar.viz import render, snapshot
    from mjx_radar.viz.run_dir import load_trial

    s, run = hills_run
    out = run.save(tmp_path / "run")
    assert (out / "terrain" / "hills.png").is_file()
    tr = load_trial(out, 0)
    model, index = render.scene_model(tr)
    assert model.nhfield == 1
    data = mujoco.MjData(model)
    render.set_state(model, data, index, tr, 10)
    body = [model.body(f"radar{i}/radar").id for i in range(s.n_radars)]
    np.testing.assert_allclose(data.xpos[body, 2], tr.radar[10, :, 2] - 2.0, atol=1e-5)
    fig = snapshot.snapshot_figure(tr, 10, grid=40)
    gids = {a.get_gid() for ax in fig.axes for a in ax.get_children()}
    plt.close(fig)
    assert {"terrain", "masked"} <= gids
