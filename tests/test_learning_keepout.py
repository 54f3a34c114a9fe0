"""The keep-out and ground set features (``features="v2"``) and the keep-out hinge of the
cloning loss (docs/learning.md, "Distillation"): each against an independent reference
(finite differences, closed forms, a brute-force line-of-sight march), and the set
network's permutation equivariance on them."""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

pytest.importorskip("flax")
pytest.importorskip("optax")

from mjx_radar.learning.set_features import SIZES, SetObs, set_features  # noqa: E402
from mjx_radar.learning.set_net import SetNet, init_params  # noqa: E402


def _obs(env, radar, mean, weight=None):
    """What :func:`set_features` reads of an observation: the given radar states and
    target estimates (covariance I, no detections)."""
    from types import SimpleNamespace

    n, m = radar.shape[0], mean.shape[0]
    weight = np.ones(m) if weight is None else weight
    return SimpleNamespace(
        radar_state=jnp.asarray(radar, jnp.float32),
        mean=jnp.asarray(mean.reshape(-1), jnp.float32),
        cov=jnp.eye(6 * m, dtype=jnp.float32),
        target_weight=jnp.asarray(weight, jnp.float32),
        detections=jnp.zeros((n, m), jnp.float32),
    )


def _features(env, obs, version):
    """:func:`set_features` of ``obs`` as one jitted program (eagerly, each of its small
    ops compiles on its own: hundreds of compilations)."""
    return jax.jit(lambda: set_features(env, obs, version))()


@pytest.fixture(scope="module")
def paper():
    from mjx_radar.env import make

    return make("paper_3r4t")


def _radars_and_drones(rng):
    """3 radar states ``[x, y, 0, θ, v, 0]`` and 4 drone estimates ``[x, y, z, vx, vy, vz]``."""
    radar = np.column_stack(
        [
            rng.uniform(-300, 300, (3, 2)),
            np.zeros(3),
            rng.uniform(-3, 3, 3),
            rng.uniform(-40, 40, 3),
            np.zeros(3),
        ]
    )
    mean = np.column_stack(
        [rng.uniform(-200, 200, (4, 2)), rng.uniform(40, 80, 4), rng.uniform(-20, 20, (4, 3))]
    )
    return radar, mean


def test_v2_pair_features_against_finite_differences(paper):
    """The closing rate is the time derivative of d₃ (central difference of the moved
    positions, 1e-3 s), the margin ahead is d₃ after the horizon at constant velocity
    over R2T minus 1 (numpy), the nearest flag marks each radar's closest present drone
    (an absent one, weight 0, never), line of sight is clear without obstacles; v1's
    six features are v2's first six."""
    env = paper
    rng = np.random.default_rng(0)
    radar, mean = _radars_and_drones(rng)
    weight = np.array([1.0, 1.0, 0.0, 1.0])
    x = _features(env, _obs(env, radar, mean, weight), "v2")
    x1 = _features(env, _obs(env, radar, mean, weight), "v1")
    assert x.pair.shape == (3, 4, SIZES["v2"][2]) and x.radar.shape == (3, SIZES["v2"][0])
    np.testing.assert_array_equal(np.asarray(x.pair[..., :6]), np.asarray(x1.pair))

    def d3(t):
        vr = radar[:, 4:5] * np.column_stack(
            [np.cos(radar[:, 3]), np.sin(radar[:, 3]), np.zeros(3)]
        )
        p = radar[:, :3] + t * vr
        q = mean[:, :3] + t * mean[:, 3:]
        return np.linalg.norm(q[None] - p[:, None], axis=-1)

    h, task = 1e-3, env.task
    rate = (d3(h) - d3(-h)) / (2 * h) / task.fleet.limits.speed
    np.testing.assert_allclose(np.asarray(x.pair[..., 6]), rate, rtol=1e-4, atol=1e-5)
    tau = task.mpc.horizon * task.timing.dt_control
    ahead = d3(tau) / float(env.params.r2t) - 1
    np.testing.assert_allclose(np.asarray(x.pair[..., 7]), ahead, rtol=1e-5, atol=1e-5)
    d = np.where(weight[None] > 0, d3(0.0), np.inf)
    want = (d == d.min(1, keepdims=True)).astype(float)
    np.testing.assert_array_equal(np.asarray(x.pair[..., 8]), want)
    np.testing.assert_array_equal(np.asarray(x.pair[..., 9]), np.ones((3, 4)))
    np.testing.assert_array_equal(np.asarray(x.radar[:, 7:]), np.zeros((3, 3)))  # flat ground


def test_v2_ground_features_against_a_line_of_sight_march():
    """On hills_4r4t: line of sight from each radar to each estimate matches a march of
    4001 points along the segment against the map's bilinear heights (numpy, the file's
    reader), on pairs both blocked and clear; the gradient matches central differences
    of those heights (5 cm, inside one cell of the grid)."""
    from mjx_radar.env import make
    from mjx_radar.io.terrain_file import height_np

    env = make("hills_4r4t")
    t = env.task.world.ground.config
    xy = np.array([[151.3, 3.7], [-347.1, 117.9], [253.3, -61.1], [-97.7, -296.3]])
    z = height_np(t, xy) + t.antenna_height
    radar = np.column_stack([xy, z, np.zeros((4, 3))])
    mean = np.array(
        [[400.0, 0.0, 115.0], [420.0, 150.0, 120.0], [380.0, -120.0, 60.0], [100.0, -200.0, 300.0]]
    )
    mean = np.column_stack([mean, np.zeros((4, 3))])
    x = _features(env, _obs(env, radar, mean), "v2")
    s = np.linspace(0.0, 1.0, 4001)[1:-1]
    pts = radar[:, None, None, :3] + s[:, None] * (
        mean[None, :, None, :3] - radar[:, None, None, :3]
    )
    clear = np.all(
        pts[..., 2] >= height_np(t, pts[..., :2].reshape(-1, 2)).reshape(pts.shape[:-1]), -1
    )
    los = np.asarray(x.pair[..., 9])
    assert 0 < los.sum() < los.size, "the case must hold both clear and blocked pairs"
    np.testing.assert_array_equal(los, clear.astype(float))
    e = 0.05
    gx = (height_np(t, xy + [e, 0]) - height_np(t, xy - [e, 0])) / (2 * e)
    gy = (height_np(t, xy + [0, e]) - height_np(t, xy - [0, e])) / (2 * e)
    np.testing.assert_allclose(np.asarray(x.radar[:, 7:9]), np.column_stack([gx, gy]), atol=2e-3)
    grade = np.hypot(gx, gy) / np.tan(np.deg2rad(t.max_slope_deg))
    np.testing.assert_allclose(np.asarray(x.radar[:, 9]), grade, atol=5e-3)


def test_v2_features_and_network_are_permutation_equivariant(paper):
    """Permuting the radars of an observation permutes v2's radar and pair rows (and
    the network's actions) alike; permuting the targets permutes their columns and
    leaves the actions unchanged (float32 round-off)."""
    env = paper
    rng = np.random.default_rng(1)
    radar, mean = _radars_and_drones(rng)
    pr, pt = np.array([2, 0, 1]), np.array([3, 1, 0, 2])
    x = _features(env, _obs(env, radar, mean), "v2")
    xp = _features(env, _obs(env, radar[pr], mean[pt]), "v2")
    np.testing.assert_allclose(np.asarray(xp.radar), np.asarray(x.radar)[pr], atol=1e-5)
    np.testing.assert_allclose(np.asarray(xp.pair), np.asarray(x.pair)[pr][:, pt], atol=1e-5)
    params = init_params(16, jax.random.PRNGKey(1), False, "v2")
    apply = jax.jit(SetNet(16).apply)
    out, outp = apply(params, x), apply(params, xp)
    np.testing.assert_allclose(np.asarray(outp), np.asarray(out)[pr], rtol=1e-4, atol=1e-5)


def test_keepout_hinge_closed_form():
    """One radar at rest at the origin heading +x, one still drone at (R2T, 0, 0), K = 3
    periods of T = 0.1 s: full acceleration moves the radar ā t²/2 = 1.575 m towards the
    drone (t = 0.3 s), so the hinge is (1.575 / R2T)²; braking (a = -1) moves it away: 0;
    a drone moving away at 10 m/s too: (1.575 - 3)₊ = 0; absent drones and padded radars
    count nothing; the gradient in the action is positive."""
    from mjx_radar.learning.distill import HINGE_PERIODS, Scales, keepout_hinge

    assert HINGE_PERIODS == 3
    hinge = jax.jit(keepout_hinge)  # eagerly, each small op compiles on its own
    s = Scales(400.0, 50.0, jnp.array([35.0]), 0.1, 125.0)
    radar = jnp.array([[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]])
    target = jnp.zeros((1, 28)).at[0, 0].set(125.0 / 400.0).at[0, 27].set(1.0)
    x = SetObs(radar, target, jnp.zeros((1, 1, 6)), jnp.ones(1), jnp.ones(1))
    a = lambda acc: jnp.array([[acc, 0.0]])  # noqa: E731
    move = 0.5 * 35.0 * 0.3**2
    want = (move / 125.0) ** 2
    np.testing.assert_allclose(float(hinge(a(1.0), x, s)), want, rtol=1e-3)
    assert float(hinge(a(-1.0), x, s)) == 0.0
    away = x._replace(target=target.at[0, 3].set(10.0 / 50.0))
    assert float(hinge(a(1.0), away, s)) == 0.0
    gone = x._replace(target=target.at[0, 27].set(0.0))
    assert float(hinge(a(1.0), gone, s)) == 0.0
    grad = jax.grad(lambda u: hinge(a(u), x, s))(0.5)
    assert float(grad) > 0  # accelerating towards the drone costs more
    two = SetObs(
        jnp.concatenate([radar, radar]),
        target,
        jnp.zeros((2, 1, 6)),
        jnp.array([1.0, 0.0]),
        jnp.ones(1),
    )
    s2 = s._replace(accel=jnp.array([35.0, 35.0]))
    both = hinge(jnp.array([[1.0, 0.0], [1.0, 0.0]]), two, s2)
    np.testing.assert_allclose(float(both), want, rtol=1e-3)


def test_keepout_hinge_gradient_passes_the_speed_limit():
    """A radar at full speed (v̄) towards a drone 130 m ahead: it covers v̄ t = 15 m in
    t = 0.3 s whatever its acceleration (the speed is clipped), hinge (10 / R2T)², yet
    the hinge's gradient in the action is positive (straight through the clip), so the
    clone learns to brake; full braking covers (v̄ + v̄ - ā t) t / 2 = 13.425 m."""
    from mjx_radar.learning.distill import Scales, keepout_hinge

    s = Scales(400.0, 50.0, jnp.array([35.0]), 0.1, 125.0)
    radar = jnp.array([[0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0]])  # v = v̄ along +x
    target = jnp.zeros((1, 28)).at[0, 0].set(130.0 / 400.0).at[0, 27].set(1.0)
    x = SetObs(radar, target, jnp.zeros((1, 1, 6)), jnp.ones(1), jnp.ones(1))
    h = lambda u: keepout_hinge(jnp.array([[u, 0.0]]), x, s)  # noqa: E731
    assert float(h(0.5)) == float(h(1.0))
    np.testing.assert_allclose(float(h(1.0)), (10.0 / 125.0) ** 2, rtol=1e-3)
    assert float(jax.grad(h)(0.5)) > 0
    np.testing.assert_allclose(float(h(-1.0)), ((13.425 - 5.0) / 125.0) ** 2, rtol=1e-3)


@pytest.mark.slow  # ~20 s: brax's PPO networks compiled (CI keeps the v2 features' references)
def test_v2_flattening_and_ppo_networks():
    """v2 sets flatten and unflatten back bit for bit at their own size, and brax's set
    networks of version v2 (PPO fine-tuning of a v2 clone) give the clone's action means
    on the flattened observation."""
    pytest.importorskip("brax")
    from mjx_radar.learning.set_features import flat_size, flatten, unflatten
    from mjx_radar.learning.set_ppo import make_set_ppo_networks

    n, m = 3, 2
    rs, ts, ps = SIZES["v2"]
    k = jax.random.split(jax.random.PRNGKey(4), 3)
    x = SetObs(
        jax.random.normal(k[0], (n, rs)),
        jax.random.normal(k[1], (m, ts)),
        jax.random.normal(k[2], (n, m, ps)),
        jnp.ones(n),
        jnp.ones(m),
    )
    flat = flatten(x)
    assert flat.shape == (flat_size(n, m, "v2"),) and flat_size(n, m, "v2") > flat_size(n, m)
    for a, b in zip(unflatten(flat, n, m, "v2"), x, strict=True):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    nets = make_set_ppo_networks(
        flat.shape[0], 2 * n, n_radars=n, n_targets=m, hidden=8, features="v2"
    )
    params = nets.policy_network.init(jax.random.PRNGKey(5))
    out = nets.policy_network.apply(None, params, flat[None])
    want = SetNet(8).apply(params["net"], x).reshape(-1)
    np.testing.assert_allclose(np.asarray(out[0, : 2 * n]), np.asarray(want), atol=1e-6)


@pytest.mark.slow  # compiles a distillation and a closed loop: ~1-2 min on 2 cores
def test_v2_distillation_with_the_hinge_runs_as_a_planner(tiny, tmp_path):
    """bc with features v2 and the keep-out hinge on tiny (5 periods): policy.json keeps
    both settings, its checkpoint holds v2-sized weights, and policy:DIR runs it with
    the v2 features on 2 radars and on 3 (never seen)."""
    import json

    import mjx_radar
    from mjx_radar.learning.distill_config import DistillConfig
    from mjx_radar.learning.distill_train import distill_policy

    short = dataclasses.replace(tiny, timing=dataclasses.replace(tiny.timing, steps=20))
    cfg = DistillConfig(
        num_envs=2,
        buffer_size=100,
        batch_size=16,
        updates=5,
        hidden=8,
        features="v2",
        keepout_weight=1000.0,
    )
    out = tmp_path / "v2"
    state = distill_policy(short, 10, out, config=cfg, log=lambda _: None)
    saved = json.loads((out / "policy.json").read_text())["config"]
    assert (saved["features"], saved["keepout_weight"]) == ("v2", 1000.0)
    z = np.load(out / state["checkpoint"] / "params.npz")
    assert {z[k].shape for k in z.files} >= {(SIZES["v2"][0], 8), (SIZES["v2"][2] + 16, 8)}
    for sc in (short, dataclasses.replace(short, n_radars=3)):
        run = mjx_radar.simulate(sc, planner=f"policy:{out}", trials=1)
        assert np.isfinite(run.summary()["rmse_pos"])
