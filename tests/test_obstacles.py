"""Obstacles: contacts in the plant, SDF, line of sight, masked updates, scenario files."""

import dataclasses
import functools
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_radar.estimation.filters import ckf
from mjx_radar.estimation.information import fisher
from mjx_radar.estimation.sensor.sensing import ddr_noise_cov, range_model
from mjx_radar.physics import plant as physics
from mjx_radar.scenario.reader import ScenarioError, load_scenario, scenario_from_dict
from mjx_radar.scenario.schema import MPCConfig, Obstacle, RadarLimits, Scenario
from mjx_radar.task import objective
from mjx_radar.task.task import build
from mjx_radar.world import obstacles, occlusion

MESHES = Path(__file__).resolve().parent.parent / "scenarios" / "meshes"
TOWER = Obstacle("mesh", (0.0, -60.0, 0.0), path=str(MESHES / "tower.obj"))  # 30 x 30 x 60 m
WALL = Obstacle("box", (50.0, 0.0, 10.0), (1.0, 30.0, 10.0))  # face at x = 49
TREE = Obstacle("cylinder", (0.0, 60.0, 10.0), (3.0, 10.0))  # surface at y = 57


def test_radar_stops_at_wall_tree_and_building():
    # Three radars at full speed straight at a wall, a tree and a building (dt = 25 ms).
    dt, lim = 0.025, RadarLimits()
    plant = physics.make_plant(3, 1, dt, lim, (WALL, TREE, TOWER))
    s0 = jnp.array(
        [[0.0, 0, 0, 0, 50, 0], [0.0, 0, 0, np.pi / 2, 50, 0], [0, 0, 0, -np.pi / 2, 50, 0]]
    )
    u = jnp.tile(jnp.array([[35.0, 0.0]]), (160, 3, 1))  # 4 s of full throttle

    def run(s0, u):
        d = physics.init_data(plant, s0, jnp.array([[0.0, 0, 50, 0, 0, 0]]))

        def body(d, uk):
            d = physics.step(plant, d, uk, jnp.zeros((1, 3)))
            return d, (physics.radar_state(plant, d), physics.obstacle_contacts(plant, d))

        return jax.lax.scan(body, d, u)[1]

    traj, contacts = jax.jit(run)(s0, u)
    traj = np.asarray(traj)
    # Signed progress towards each obstacle face: x, y, -y; faces at 49, 57, 45 m.
    progress = np.stack([traj[:, 0, 0], traj[:, 1, 1], -traj[:, 2, 1]], -1)
    faces = np.array([49.0, 57.0, 45.0])
    env = physics.contact_envelope(lim, dt)
    r = obstacles.HULL_RADIUS
    # No tunnelling: the physical hull never passes the face by more than 3 cm ...
    assert np.all(progress.max(0) <= faces - r + 0.03), progress.max(0) - (faces - r)
    # ... and every radar ends at rest against it: the grown sphere touches it (soft
    # contact: a few mm for boxes and meshes, ~0.12 m for MJX's sphere-cylinder).
    assert np.all(progress[-1] >= faces - r - env - 0.01), progress[-1] - (faces - r - env)
    assert np.all(progress[-1] <= faces - r - env + 0.2), progress[-1] - (faces - r - env)
    assert np.all(np.abs(np.diff(progress[-20:], axis=0)) < 1e-3)
    assert np.all(np.abs(traj[-1, :, 4]) < lim.accel * dt)  # speed state reset when blocked
    assert int(contacts[-1]) == 3 and int(contacts[0]) == 0


def test_planner_plant_is_contact_free():
    s = Scenario("t", 2, ((0, 0, 50, 0, 0, 0),), obstacles=(WALL,), radar_init=((0, 0, 0),) * 2)
    assert physics.planner_plant(s.timing.dt_control, s.limits).fast
    world = (s.obstacles, s.terrain, s.moving_obstacles)
    assert not physics.truth_plant(2, 1, s.timing.dt_filter, s.limits, *world).fast


def _box_distance_sampled(obs, xy, n=4000):
    """Distance to a rotated rectangle's boundary by dense sampling (outside points)."""
    t = np.linspace(0, 1, n, endpoint=False)
    sx, sy = obs.size[:2]
    edges = [(-sx + 2 * sx * t, sy + 0 * t), (sx + 0 * t, -sy + 2 * sy * t)]
    pts = np.concatenate([np.stack(e, -1) * sgn for e in edges for sgn in (1, -1)])
    c, s = np.cos(obs.yaw), np.sin(obs.yaw)
    pts = pts @ np.array([[c, s], [-s, c]]) + np.asarray(obs.pos[:2])
    d2 = [
        ((q[:, None, 0] - pts[:, 0]) ** 2 + (q[:, None, 1] - pts[:, 1]) ** 2).min(-1)
        for q in np.array_split(xy, max(1, len(xy) // 256))
    ]  # chunks of [256, 4n]: |q - p|² per coordinate, then the root of the minimum
    return np.sqrt(np.concatenate(d2))


def test_sdf_lookup_matches_analytic_distance():
    box = Obstacle("box", (30.0, -20.0, 5.0), (12.0, 4.0, 5.0), yaw=0.4)
    cyl = Obstacle("cylinder", (-40.0, 25.0, 5.0), (6.0, 5.0))
    grid = obstacles.sdf_grid((box, cyl, TOWER), 100.0)
    xy = np.random.default_rng(0).uniform(-120, 120, (4000, 2))
    sdf = jax.jit(obstacles.sdf)  # one program per query shape (not op by op)
    look = np.asarray(sdf(grid, jnp.asarray(xy, jnp.float32)))
    d_cyl = np.linalg.norm(xy - [-40.0, 25.0], axis=-1) - 6.0
    tower = np.max(np.abs(xy - [0.0, -60.0]) - 15.0, axis=-1)  # inside: -depth
    tower = np.where(
        tower > 0, np.linalg.norm(np.maximum(np.abs(xy - [0, -60]) - 15, 0), axis=-1), tower
    )
    out_box = obstacles.footprint_sdf(box, xy) > 0
    d_box = np.where(out_box, 0.0, obstacles.footprint_sdf(box, xy))
    d_box[out_box] = _box_distance_sampled(box, xy[out_box])
    exact = np.minimum(np.minimum(d_cyl, tower), d_box)
    res = float(grid.resolution)
    near = (exact > -1.0) & (exact < 10.0)  # the band the obstacle cost looks at
    assert np.abs(look - exact)[near].max() < 0.05 * res + 0.02
    assert np.abs(look - exact).max() < 0.5 * res  # medial axes inside smooth a little
    far = np.asarray([[500.0, 0.0]])  # outside the grid: clamped value + distance
    exact_far = obstacles.union_sdf((box, cyl, TOWER), far)[0]
    assert abs(float(sdf(grid, jnp.asarray(far))[0]) - exact_far) < 2.0


def _inside(obs, p):
    """Direct point-in-obstacle test ``p[..., 3] -> (inside, depth)`` (depth < 0 outside)."""
    if obs.kind == "cylinder":
        rad = obs.size[0] - np.linalg.norm(p[..., :2] - np.asarray(obs.pos[:2]), axis=-1)
        zed = obs.size[1] - np.abs(p[..., 2] - obs.pos[2])
        depth = np.minimum(rad, zed)
    elif obs.kind == "box":
        c, s = np.cos(obs.yaw), np.sin(obs.yaw)
        d = p - np.asarray(obs.pos)
        q = np.stack([c * d[..., 0] + s * d[..., 1], -s * d[..., 0] + c * d[..., 1], d[..., 2]], -1)
        depth = np.min(np.asarray(obs.size) - np.abs(q), axis=-1)
    else:  # convex mesh: inside every face plane (normals from the triangles)
        v = obstacles.mesh_vertices(obs)
        tri = v[obstacles.mesh_local(obs.path, obs.scale)[1]]
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        n /= np.linalg.norm(n, axis=-1, keepdims=True)
        depth = np.min(np.einsum("fi,fi->f", n, tri[:, 0]) - p @ n.T, axis=-1)
    return depth >= 0, depth


@pytest.mark.parametrize(
    "obs",
    [
        Obstacle("box", (10.0, 5.0, 8.0), (15.0, 5.0, 8.0), yaw=0.7),
        Obstacle("cylinder", (-5.0, 10.0, 12.0), (8.0, 12.0)),
        Obstacle("mesh", (5.0, -5.0, 0.0), yaw=0.5, path=str(MESHES / "hex_tower.obj"), scale=0.8),
        Obstacle("mesh", (0.0, 0.0, 0.0), yaw=-0.3, path=str(MESHES / "hall.obj")),
    ],
    ids=["box", "cylinder", "hex_tower", "hall"],
)
def test_line_of_sight_matches_direct_geometry(obs):
    rng = np.random.default_rng(1)
    n = 1500
    a = np.concatenate([rng.uniform(-60, 60, (n, 2)), rng.uniform(0, 5, (n, 1))], -1)
    b = np.concatenate([rng.uniform(-60, 60, (n, 2)), rng.uniform(0, 60, (n, 1))], -1)
    blocked = np.asarray(jax.jit(occlusion.segment_blocked)(occlusion.occluders((obs,)), a, b))
    t = np.linspace(0, 1, 4001)[:, None, None]
    deepest = np.concatenate(  # depth [T, n] maxed over T, 15 segments at a time (memory)
        [
            _inside(obs, a[None, k] + t * (b - a)[None, k])[1].max(0)
            for k in np.split(np.arange(n), 100)
        ]
    )
    clear_cut = np.abs(deepest) > 0.05  # skip grazing segments (sampling resolution)
    assert clear_cut.mean() > 0.95
    np.testing.assert_array_equal(blocked[clear_cut], deepest[clear_cut] > 0)
    assert 0.1 < blocked.mean() < 0.9  # both outcomes are exercised


def _hand_geometry():
    # Radar 0 behind the wall (x = 49) from target 0, radar 1 with a clear view.
    radars = jnp.array([[100.0, 0.0, 0.0], [0.0, -100.0, 0.0], [-80.0, 30.0, 0.0]])
    targets = jnp.array([[0.0, 0.0, 10.0], [60.0, 80.0, 60.0]])
    return radars, targets


def test_blocked_pair_has_zero_fisher_information():
    radars, targets = _hand_geometry()
    vis = np.asarray(jax.jit(lambda r, t: occlusion.visibility((WALL,), r, t))(radars, targets))
    np.testing.assert_array_equal(vis, [[False, True], [True, True], [True, True]])
    c = 7.285e-10

    @jax.jit  # each side one program (not op by op)
    def masked_side(radars, targets, vis):
        packed = fisher.sfim_packed(radars, targets, fisher.ddr_weight(c), mask=vis)
        return fisher.sfim(radars, targets, c, mask=vis), fisher.unpack_sym3(packed)

    @jax.jit
    def by_hand_side(radars, targets):
        by_hand = fisher.sfim(radars[1:], targets, c)  # radar 0 sees only target 1
        return by_hand.at[1].add(fisher.sfim(radars[:1], targets[1:], c)[0])

    masked, unpacked = masked_side(radars, targets, vis)
    by_hand = by_hand_side(radars, targets)
    np.testing.assert_allclose(masked, by_hand, rtol=1e-6)
    np.testing.assert_allclose(unpacked, by_hand, rtol=1e-5)


@functools.cache
def _update_inputs():
    """``(radars, mean, cov, z, visibility)`` of :func:`_hand_geometry` in float64: one
    program, shared by both noise models."""
    with jax.enable_x64(True):
        radars, targets = _hand_geometry()

        @jax.jit
        def inputs(radars, targets):
            truth = jnp.concatenate([targets, jnp.array([[3.0, -2, 0], [1, 1, 0.5]])], -1)
            truth = truth.reshape(-1)
            key = jax.random.PRNGKey(4)
            a = jax.random.normal(key, (12, 12))
            cov = 20.0 * jnp.eye(12) + a @ a.T
            mean = truth + jnp.linalg.cholesky(cov) @ jax.random.normal(key, (12,))
            z = range_model(radars)(truth) + 0.3 * jax.random.normal(jax.random.PRNGKey(5), (6,))
            return mean, cov, z, occlusion.visibility((WALL,), radars, targets)

        return radars, *inputs(radars, targets)


@pytest.mark.parametrize("noise", ["ddr", "array"])
def test_masked_update_equals_update_without_the_measurement(noise):
    with jax.enable_x64(True):
        radars, mean, cov, z, vis = _update_inputs()
        h = range_model(radars)
        keep = np.asarray(vis).reshape(-1)
        idx = np.flatnonzero(keep)

        def r_full(zh):
            return ddr_noise_cov(zh, 1e-6) if noise == "ddr" else jnp.diag(jnp.arange(1.0, 7.0))

        def r_kept(zh):
            return (
                ddr_noise_cov(zh, 1e-6) if noise == "ddr" else jnp.diag(jnp.arange(1.0, 7.0)[idx])
            )

        @jax.jit  # the three updates: one program (not op by op)
        def updates(mean, cov, z):
            return (
                ckf.update(mean, cov, z, h, r_full, mask=jnp.asarray(keep)),
                ckf.update(mean, cov, z[idx], lambda x: h(x)[idx], r_kept),
                ckf.update(mean, cov, z, h, r_full),
            )

        (m1, p1), (m2, p2), (m3, _) = updates(mean, cov, z)
        np.testing.assert_allclose(m1, m2, rtol=0, atol=1e-10)
        np.testing.assert_allclose(p1, p2, rtol=0, atol=1e-10)
        assert np.abs(np.asarray(m3 - m1)).max() > 1e-3  # the mask did change something


def test_obstacle_cost_term():
    # A still radar 4 m from a cylinder's surface, margin 6 m: + a_obs * 2 m per step.
    base = Scenario(
        "t",
        1,
        ((0.0, 0.0, 60.0, 0.0, 0.0, 0.0),),
        sigma_w2=0.0,
        radar_init=((200.0, 0.0, 0.0),),
        mpc=MPCConfig(horizon=5, rollout="analytic"),
        placement_half_width=100.0,  # a fine SDF grid (bilinear error ~ res^2 / radius)
    )
    obs = dataclasses.replace(base, obstacles=(Obstacle("cylinder", (210, 0, 5), (6, 5)),))
    state = jnp.array([[200.0, 0, 0, 0, 0, 0]])
    u = jnp.zeros((5, 2))
    scenarios = (base, obs)
    tasks, params = zip(*(build(s, "ddr-sfim") for s in scenarios), strict=True)

    @jax.jit  # both scenarios' costs: one program (not op by op)
    def both(u, state, means, params):
        out = []
        for task, mean, p in zip(tasks, means, params, strict=True):
            ctx = objective.plan_context(task, state, mean, jnp.eye(6))
            out.append(objective.make_objective(task)(u, ctx, p))
        return out

    means = [jnp.asarray(s.target_init[0]) for s in scenarios]
    costs = both(u, state, means, params)
    (c0, p0), (c1, p1) = costs
    assert "obstacle" not in p0.terms
    np.testing.assert_allclose(float(c1 - c0), float(p1.terms["obstacle"]), rtol=1e-5)
    expect = base.mpc.alpha_obs * 2.0 * float(np.sum(base.mpc.gamma ** np.arange(5)))
    assert abs(float(c1 - c0) - expect) < 5e-3 * expect


GOOD = {
    "name": "t",
    "n_radars": 1,
    "targets": [[0.0, 0.0, 50.0, 1.0, 0.0, 0.0]],
    "radars": [[200.0, 0.0, 0.0]],
}
FOREST = {"count": 5, "region": [-100.0, -100.0, 100.0, 100.0]}
BAD = {
    "forest_count_zero": ({"forest": FOREST | {"count": 0}}, "forest.count"),
    "forest_region_inverted": ({"forest": FOREST | {"region": [1, 0, -1, 5]}}, "forest.region"),
    "forest_region_short": ({"forest": FOREST | {"region": [1, 0, 5]}}, "forest.region"),
    "forest_radius_order": ({"forest": FOREST | {"radius": [3.0, 1.0]}}, "forest.radius"),
    "forest_unknown": ({"forest": FOREST | {"trees": 3}}, "forest.trees"),
    "forest_missing_count": ({"forest": {"region": [0, 0, 1, 1]}}, "forest.count"),
    "forest_too_dense": ({"forest": FOREST | {"count": 2000, "spacing": 20.0}}, "forest.count"),
    "los_not_bool": ({"mpc": {"los": 1}}, "mpc.los"),
    "obs_margin_negative": ({"mpc": {"obs_margin": -1.0}}, "mpc.obs_margin"),
    "alpha_obs_nan": ({"mpc": {"alpha_obs": float("nan")}}, "mpc.alpha_obs"),
    "mesh_missing": ({"obstacles": [{"kind": "mesh", "path": "nope.obj"}]}, "obstacles[0].path"),
    "box_size": ({"obstacles": [{"kind": "box", "size": [1.0, 2.0]}]}, "obstacles[0].size"),
    "cyl_negative": (
        {"obstacles": [{"kind": "cylinder", "size": [-1.0, 2.0]}]},
        "obstacles[0].size",
    ),
    "radar_inside": (
        {"obstacles": [{"kind": "cylinder", "pos": [201.0, 0, 5], "size": [2.0, 5.0]}]},
        "radars[0]",
    ),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_obstacle_fields_raise_one_line(case):
    extra, needle = BAD[case]
    with pytest.raises(ScenarioError) as err:
        scenario_from_dict(GOOD | extra)
    assert needle in str(err.value) and "\n" not in str(err.value), str(err.value)


def test_bad_mesh_file_and_missing_radars(tmp_path):
    (tmp_path / "bad.obj").write_text("this is not a mesh\n")
    raw = GOOD | {"obstacles": [{"kind": "mesh", "path": "bad.obj"}]}
    with pytest.raises(ScenarioError, match=r"obstacles\[0\].path"):
        scenario_from_dict(raw, tmp_path)
    no_radars = {k: v for k, v in GOOD.items() if k != "radars"} | {"forest": FOREST}
    with pytest.raises(ScenarioError, match="radars: required"):
        scenario_from_dict(no_radars)


def test_forest_is_deterministic_and_spaced():
    f = FOREST | {"count": 40, "spacing": 5.0, "clearance": 20.0, "seed": 3}
    s1, s2 = scenario_from_dict(GOOD | {"forest": f}), scenario_from_dict(GOOD | {"forest": f})
    assert s1.obstacles == s2.obstacles and len(s1.obstacles) == 40
    xy = np.array([o.pos[:2] for o in s1.obstacles])
    r = np.array([o.size[0] for o in s1.obstacles])
    gap = np.linalg.norm(xy[:, None] - xy[None], axis=-1) - r[:, None] - r[None] + 1e9 * np.eye(40)
    assert gap.min() >= 5.0 - 0.02
    assert np.all(np.abs(xy) <= 100.0)
    assert all(o.kind == "cylinder" and o.pos[2] == o.size[1] for o in s1.obstacles)


@pytest.mark.parametrize("name", ["forest_4r4t", "city_4r4t"])
def test_bundled_obstacle_scenarios_load(name):
    s = load_scenario(name)
    assert s.n_radars == 4 and s.n_targets == 4 and s.obstacles
    assert s.target_init == load_scenario("paper_4r4t").target_init
