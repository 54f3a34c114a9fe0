"""Targets that appear and leave: metrics over present targets, planner weights, the loop."""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from mjx_radar.env import presence
from mjx_radar.scenario.schema import TargetMotion
from mjx_radar.task import costs
from mjx_radar.task.costs import Horizon
from mjx_radar.task.task import build


def test_error_metrics_are_the_present_targets_marginal():
    rng = np.random.default_rng(0)
    m = 3
    a = rng.normal(size=(6 * m, 6 * m))
    cov = a @ a.T + 6 * m * np.eye(6 * m)
    truth = rng.normal(size=(m, 6)) * 10
    mean = truth.reshape(-1) + rng.normal(size=6 * m)
    here = np.array([True, False, True])
    # jitted: eagerly, each of their small ops compiles on its own
    error_metrics, crlb_pos = jax.jit(presence.error_metrics), jax.jit(presence.crlb_pos)
    got = error_metrics(jnp.asarray(truth), jnp.asarray(mean), jnp.asarray(cov),
                        jnp.asarray(here))  # fmt: skip
    idx = np.concatenate([np.arange(6 * j, 6 * j + 6) for j in (0, 2)])
    e = (mean - truth.reshape(-1))[idx]
    nees = e @ np.linalg.solve(cov[np.ix_(idx, idx)], e)
    pos = e.reshape(2, 6)[:, :3]
    ref = (np.sqrt((pos**2).sum() / 2), np.sqrt((e**2).sum() / 2), nees)
    np.testing.assert_allclose(np.asarray(got, np.float64), ref, rtol=1e-5)
    none = error_metrics(jnp.asarray(truth), jnp.asarray(mean), jnp.asarray(cov),
                         jnp.zeros(m, bool))  # fmt: skip
    assert [float(x) for x in none] == [0.0, 0.0, 0.0]
    np.testing.assert_allclose(
        float(crlb_pos(jnp.array([4.0, 100.0, 16.0]), jnp.asarray(here))),
        np.sqrt(10.0), rtol=1e-6,
    )  # fmt: skip


def test_start_tracks_resets_blocks_and_cross_covariance():
    m = 2
    # float32 inputs made on the host and one jitted call: eagerly, every op compiles alone
    cov = np.full((12, 12), 0.5, np.float32) + np.eye(12, dtype=np.float32)
    truth = np.arange(12.0, dtype=np.float32).reshape(m, 6)
    start = jax.jit(lambda *a: presence.start_tracks(*a, 50.0))
    mean, cov2 = (np.asarray(x) for x in start(np.zeros(12, np.float32), cov,
                                               np.array([False, True]), truth,
                                               jax.random.PRNGKey(0)))  # fmt: skip
    np.testing.assert_array_equal(mean[:6], 0.0)
    assert np.all(np.abs(np.asarray(mean[6:]) - np.arange(6, 12)) < 5 * np.sqrt(50))
    np.testing.assert_array_equal(cov2[6:, 6:], 50.0 * np.eye(6))
    np.testing.assert_array_equal(cov2[:6, 6:], 0.0)
    np.testing.assert_array_equal(cov2[:6, :6], cov[:6, :6])


def test_absent_target_costs_nothing_in_the_planner(tiny):
    # SFIM and R2T terms with weights [1, 0] equal those of a one-target task on target 0
    # alone (whose 12 cubature points are the two-target task's 24 points of target 0
    # taken twice: the same mean over points)
    task, params = build(tiny, "ddr-sfim")
    one = tiny.replace(targets=[list(tiny.target_init[0])])
    task1, params1 = build(one, "ddr-sfim")
    rng = np.random.default_rng(1)
    h = tiny.mpc.horizon
    radar = jnp.asarray(np.concatenate([rng.uniform(-300, 300, (h, 2, 2)), np.zeros((h, 2, 4))],
                                       -1), jnp.float32)  # fmt: skip
    pts1 = rng.normal(size=(h, 12, 1, 6)) * 20 + np.array([0, 0, 60, 0, 0, 0])
    other = rng.normal(size=(h, 24, 1, 6)) * 20 + np.array([100, 50, 70, 0, 0, 0])
    pts2 = np.concatenate([np.concatenate([pts1, pts1], 1), other], 2)  # [H, 24, 2, 6]
    ctl, info = jnp.zeros((h, 2, 2)), jnp.broadcast_to(jnp.eye(6), (2, 6, 6))
    h2 = Horizon(ctl, radar, jnp.asarray(pts2, jnp.float32), info)
    h1 = Horizon(ctl, radar, jnp.asarray(pts1, jnp.float32), info[:1])
    p2 = params._replace(target_weight=jnp.array([1.0, 0.0]), r2t=jnp.float32(150.0))
    p1 = params1._replace(r2t=jnp.float32(150.0), noise=params.noise)  # C carries M: same C
    terms = (costs.information, costs.radar_target)
    two = {f: jax.jit(lambda h, p, f=f: f(h, task, p)) for f in terms}  # one compilation each
    for term in terms:
        one = jax.jit(lambda h, p, f=term: f(h, task1, p))
        np.testing.assert_allclose(two[term](h2, p2), one(h1, p1), rtol=2e-6, atol=1e-4)
    # weights [1, 1] are the unweighted term (the compiled information term above)
    full = params._replace(target_weight=jnp.array([1.0, 1.0]))
    info = two[costs.information]
    np.testing.assert_allclose(info(h2, full), info(h2, params), rtol=1e-6)


def test_closed_loop_masks_absent_targets(tiny, tmp_path):
    import mjx_radar

    # target 1 appears at 0.5 s and leaves at 1.5 s (steps 20..59 of 80)
    s = tiny.replace(target_motion=(TargetMotion(target=1, appear=0.5, leave=1.5),))
    run = mjx_radar.simulate(s, "stationary", trials=2, steps=80, progress=False, masks=True)
    met = run.metrics.sort_values(["trial", "step"])
    step = met["step"].to_numpy()
    expect = np.where((step >= 20) & (step < 60), 2, 1)
    np.testing.assert_array_equal(met["targets_present"], expect)
    np.testing.assert_array_equal(met["visible_pairs"], 2 * expect)  # N = 2 radars
    err = run.arrays["mean"].reshape(2, 80, 2, 6) - run.arrays["target"]  # [T, K, M, 6]
    e2 = (err[..., :3] ** 2).sum(-1)
    here = np.stack([np.ones(80, bool), (np.arange(1, 81) >= 20) & (np.arange(1, 81) < 60)], -1)
    ref = np.sqrt((e2 * here).sum(-1) / here.sum(-1)).reshape(-1)
    np.testing.assert_allclose(met["rmse_pos"], ref, rtol=1e-4, atol=1e-5)
    # the track of target 1 starts at its appearance: its error is then p0-sized
    assert np.all(np.sqrt(e2[:, 19, 1]) < 5 * np.sqrt(3 * s.p0))
    assert np.all(np.isfinite(met["nees"])) and not met["lost"].any()
    assert dataclasses.asdict(s)["target_motion"][0]["appear"] == 0.5
    # the per-pair masks (masks=True): every radar sees exactly the present targets
    ds = run.trajectories
    pairs = np.broadcast_to(here[None, :, None, :], (2, 80, 2, 2))  # [T, K, N, M]
    np.testing.assert_array_equal(ds.visible.values, pairs)
    np.testing.assert_array_equal(ds.detected.values, pairs)  # perfect detection
    saved = mjx_radar.Run.load(run.save(tmp_path / "run")).trajectories  # trajectories.npz
    np.testing.assert_array_equal(saved.visible.values, pairs)
