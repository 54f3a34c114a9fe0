"""Terrain (docs/terrain.md): the height lookup, terrain line of sight, the MJCF hfield,
radars on slopes in the plant, the slope keep-out, and the [terrain] table's checks."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.interpolate import RegularGridInterpolator

from mjx_radar.io.checks import ScenarioError
from mjx_radar.scenario.reader import load_scenario, scenario_from_dict
from mjx_radar.scenario.schema import RadarLimits, Terrain
from mjx_radar.world import terrain, terrain_los

HILLS = Path(__file__).resolve().parents[1] / "scenarios" / "hills_4r4t.toml"


def _grid(h, ext):
    ny, nx = h.shape
    origin = -0.5 * np.asarray(ext, float)
    sp = np.asarray(ext, float) / [nx - 1, ny - 1]
    g = terrain.TerrainGrid(*(jnp.asarray(a, jnp.float32) for a in (h, origin, sp)))
    xs, ys = origin[0] + sp[0] * np.arange(nx), origin[1] + sp[1] * np.arange(ny)
    interp = RegularGridInterpolator((ys, xs), h)  # independent bilinear reference

    def ref(p):  # float64, clamped to the grid like the lookup
        q = np.clip(p, origin, -origin)
        return interp(q[..., ::-1])

    return g, ref


def _terrain_file(tmp_path, h, name="t.npy", **kw):
    path = tmp_path / name
    np.save(path, h)
    return Terrain(path=str(path), **kw)


def test_height_and_gradient_match_a_reference():
    rng = np.random.default_rng(0)
    h = rng.uniform(0.0, 60.0, (9, 12))
    g, ref = _grid(h, (400.0, 300.0))
    p = rng.uniform(-260.0, 260.0, (500, 2))  # some outside the grid: clamped
    height, gradient = jax.jit(terrain.height), jax.jit(terrain.gradient)  # not op by op
    got = np.asarray(height(g, jnp.asarray(p, jnp.float32)))
    np.testing.assert_allclose(got, ref(p), atol=1e-4)  # float32 of heights <= 60 m
    inside = rng.uniform(-190.0, 190.0, (300, 2))
    eps = 1e-3
    fd = np.stack([(ref(inside + [eps, 0]) - ref(inside - [eps, 0])) / (2 * eps),
                   (ref(inside + [0, eps]) - ref(inside - [0, eps])) / (2 * eps)], -1)  # fmt: skip
    grad = np.asarray(gradient(g, jnp.asarray(inside, jnp.float32)))
    on_line = np.any(np.abs(np.modf((inside + [200, 150]) / [400 / 11, 300 / 8])[0]) < 1e-3, -1)
    np.testing.assert_allclose(grad[~on_line], fd[~on_line], atol=2e-3)
    outside = np.asarray(gradient(g, jnp.array([[250.0, 0.0], [0.0, -200.0]])))
    assert outside[0, 0] == 0.0 and outside[1, 1] == 0.0  # flat across the edge


def test_terrain_los_equals_brute_force_ray_march():
    """Exact min clearance vs a 20001-point march in float64 on random segments.

    The march over-estimates the minimum by at most L·Δt/2 (L the Lipschitz constant of
    the clearance in t), so: exact <= march + float32 slack, and march - exact <= L Δt / 2.
    Where the march's clearance is outside that band, blocked flags must be equal.
    """
    rng = np.random.default_rng(1)
    h = rng.uniform(0.0, 60.0, (9, 12))
    g, ref = _grid(h, (400.0, 300.0))
    n = 600
    a = np.c_[rng.uniform(-260, 260, (n, 2)), rng.uniform(0, 80, n)]
    b = np.c_[rng.uniform(-260, 260, (n, 2)), rng.uniform(0, 80, n)]
    ts = np.linspace(0.0, 1.0, 20001)
    march = np.array([np.min(a[k, 2] + ts * (b[k, 2] - a[k, 2])
                             - ref(a[k, :2] + ts[:, None] * (b[k, :2] - a[k, :2])))
                      for k in range(n)])  # fmt: skip
    # min clearance and blocked flags: one program (not op by op)
    both = jax.jit(lambda g, a, b: (terrain_los.min_clearance(g, a, b),
                                    terrain_los.segment_blocked(g, a, b)))  # fmt: skip
    got, blocked = (np.asarray(x) for x in both(g, jnp.asarray(a, jnp.float32),
                                                jnp.asarray(b, jnp.float32)))  # fmt: skip
    grade = np.max(np.abs(np.diff(h, axis=1))) / (400 / 11) + np.max(np.abs(np.diff(h, axis=0))) / (
        300 / 8
    )
    lip = np.abs(b[:, 2] - a[:, 2]) + grade * np.linalg.norm(b[:, :2] - a[:, :2], axis=-1)
    band = lip * (ts[1] - ts[0]) / 2 + 1e-3
    assert np.all(got <= march + 1e-3)
    assert np.all(march - got <= band)
    clear = np.abs(march) > band
    assert clear.mean() > 0.95 and 0.2 < (march < 0).mean() < 0.9  # a mixed sample
    np.testing.assert_array_equal(blocked[clear], march[clear] < 0)


def test_los_over_a_ridge_closed_form(tmp_path):
    """A ridge of height 50 at x = 0 (triangular across x): a segment from (-100, 0, z0) to
    (100, 0, z1) clears it iff (z0 + z1) / 2 > 50, both in the occlusion module."""
    from mjx_radar.world import occlusion

    xs = np.linspace(-200, 200, 5)  # nodes at -200, -100, 0, 100, 200
    h = np.tile(np.where(xs == 0, 50.0, 0.0), (3, 1))
    t = _terrain_file(tmp_path, h, extent_x=400.0, extent_y=200.0)
    occ = occlusion.with_terrain(None, terrain.terrain_grid(t))
    radar = jnp.array([[-100.0, 0.0, 30.0]])
    tgt = jnp.array([[100.0, 0.0, 69.0], [100.0, 0.0, 71.0], [100.0, 50.0, 71.0]])
    vis = np.asarray(jax.jit(occlusion.line_of_sight)(occ, radar, tgt))
    np.testing.assert_array_equal(vis, [[False, True, True]])


def test_hfield_in_the_scene_matches_the_grid(tmp_path):
    """MuJoCo's hfield (mj_ray straight down) has the grid's heights at the nodes and
    along cell edges (where its triangles and the bilinear surface agree)."""
    import mujoco

    from mjx_radar.physics.scene import build_scene

    rng = np.random.default_rng(2)
    h = rng.uniform(-10.0, 40.0, (6, 7))
    t = _terrain_file(tmp_path, h, extent_x=300.0, extent_y=250.0, height_scale=1.5)
    model, _ = build_scene(1, 1, 0.025, terrain=t)
    assert model.nhfield == 1 and model.geom("terrain").type == mujoco.mjtGeom.mjGEOM_HFIELD
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    gid = model.geom("terrain").id
    pts = [(-150.0 + 50.0 * j + 0.3 * 50.0 * (i % 2), -125.0 + 50.0 * i)
           for i in range(6) for j in range(6)]  # fmt: skip
    got = []
    for x, y in pts:
        geomid = np.zeros(1, np.int32)
        dist = mujoco.mj_ray(model, data, np.array([x, y, 500.0]), np.array([0, 0, -1.0]),
                             None, 1, -1, geomid)  # fmt: skip
        assert geomid[0] == gid
        got.append(500.0 - dist)
    np.testing.assert_allclose(got, terrain.height_np(t, np.asarray(pts)), atol=1e-4)


def _ramp(tmp_path, gx, gy, c, **kw):
    xs = np.linspace(-500, 500, 11)
    x, y = np.meshgrid(xs, xs)
    return _terrain_file(tmp_path, gx * x + gy * y + c, extent_x=1000.0, extent_y=1000.0, **kw)


def test_radar_driving_up_a_known_slope_has_the_analytic_z(tmp_path):
    """Plane h = 0.1 x + 0.15 y + 5 (grade 0.18, 10.2 deg): a radar accelerating at a
    along heading 0.5 rad has, after k Euler steps, s = a (k dt)^2 / 2 along its heading
    (the plant's map, SPEC §3), so z = h(x0 + s cos, y0 + s sin) + antenna height."""
    from mjx_radar.physics import plant as physics

    t = _ramp(tmp_path, 0.1, 0.15, 5.0, antenna_height=2.0)
    dt, a, th = 0.025, 2.0, 0.5
    p = physics.make_plant(1, 1, dt, RadarLimits(), terrain=t)
    assert p.fast  # the contact-free fast step is kept
    data = physics.init_data(p, jnp.array([[-50.0, 20.0, 0.0, th, 0.0, 0.0]]),
                             jnp.array([[0.0, 0.0, 300.0, 0.0, 0.0, 0.0]]))  # fmt: skip

    @jax.jit  # the step and the radar's z: one program (not op by op)
    def step(d):
        d = physics.step(p, d, jnp.array([[a, 0.0]]))
        return d, physics.radar_state(p, d)[0, 2]

    zs, ref = [], []
    for k in range(1, 81):
        data, z = step(data)
        zs.append(float(z))
        s = 0.5 * a * (k * dt) ** 2
        ref.append(0.1 * (-50 + s * np.cos(th)) + 0.15 * (20 + s * np.sin(th)) + 5.0 + 2.0)
    np.testing.assert_allclose(zs, ref, atol=2e-4)
    assert zs[-1] - zs[0] > 0.5  # it did climb


def test_slope_beyond_the_limit_stops_the_plant(tmp_path):
    """Flat for x < 100, grade 1.0 (45 deg) beyond: a radar driving +x stops before the
    steep cell (v = 0, x at most one step into the last flat cell's edge); turned
    around it drives away."""
    from mjx_radar.physics import plant as physics

    xs = np.linspace(-500, 500, 11)
    h = np.tile(np.maximum(xs - 100.0, 0.0), (11, 1))
    t = _terrain_file(tmp_path, h, extent_x=1000.0, extent_y=1000.0, max_slope_deg=25.0)
    p = physics.make_plant(1, 1, 0.025, RadarLimits(), terrain=t)
    data = physics.init_data(p, jnp.array([[60.0, 0.0, 0.0, 0.0, 10.0, 0.0]]),
                             jnp.array([[0.0, 0.0, 300.0, 0.0, 0.0, 0.0]]))  # fmt: skip
    step = jax.jit(lambda d, u: physics.step(p, d, u))
    for _ in range(200):  # 5 s from 10 m/s at 1 m/s^2 would end at x = 122.5
        data = step(data, jnp.array([[1.0, 0.0]]))
    r = np.asarray(physics.radar_state(p, data))[0]
    assert r[0] <= 100.0 and r[0] > 99.0 and r[4] == 0.0
    for _ in range(40):  # drive backwards (downhill direction is -x): allowed
        data = step(data, jnp.array([[-5.0, 0.0]]))
    assert float(physics.radar_state(p, data)[0, 0]) < 99.0


def test_ground_component_answers_the_plant(tmp_path):
    """``Ground.too_steep`` against the closed form of a flat-then-45-degree surface
    (grade 0 for x < 100, 1 beyond; the limit tan 25 deg = 0.47): a step onto the flank
    is stopped, a step along it (not steeper) or off it is not; flat ground stops
    nothing and has no antenna offset; on terrain ``on_ground`` is h + antenna."""
    from mjx_radar.world.components import Ground

    xs = np.linspace(-500, 500, 11)
    h = np.tile(np.maximum(xs - 100.0, 0.0), (11, 1))
    t = _terrain_file(tmp_path, h, extent_x=1000.0, extent_y=1000.0, max_slope_deg=25.0)
    g, flat = Ground(t), Ground()
    xy = jnp.array([[50.0, 0.0], [95.0, 0.0], [150.0, 0.0], [105.0, 0.0]])
    nxt = jnp.array([[60.0, 0.0], [105.0, 0.0], [160.0, 0.0], [95.0, 0.0]])
    np.testing.assert_array_equal(np.asarray(g.too_steep(xy, nxt)), [False, True, False, False])
    np.testing.assert_array_equal(np.asarray(flat.too_steep(xy, nxt)), [False] * 4)
    assert flat.antenna_height == 0.0 and g.antenna_height == t.antenna_height
    radar = jnp.array([[150.0, 30.0, 0.0, 0.0, 0.0, 0.0]])
    assert float(g.on_ground(radar)[0, 2]) == pytest.approx(50.0 + t.antenna_height, abs=1e-4)
    assert flat.on_ground(radar) is radar


def test_slope_cost_closed_form(tmp_path):
    """terrain_slope = alpha_slope * sum_n relu(grade - tan(max_slope))."""
    from mjx_radar.task import costs
    from mjx_radar.world.components import Ground, World

    t = _ramp(tmp_path, 0.6, 0.8, 0.0, max_slope_deg=30.0, alpha_slope=7.0)  # grade 1.0
    task = type("T", (), {"world": World(ground=Ground(t))})()  # the term reads the ground
    radar = jnp.zeros((4, 3, 6)).at[..., 0].set(jnp.arange(3.0) * 10)
    hz = costs.Horizon(jnp.zeros((4, 3, 2)), radar, None, None)
    got = np.asarray(jax.jit(lambda hz: costs.terrain_slope(hz, task, None))(hz))
    np.testing.assert_allclose(got, 7.0 * 3 * (1.0 - np.tan(np.radians(30.0))), rtol=1e-5)


def _raw(tmp_path, **terrain_kw):
    return {"name": "t", "n_radars": 2, "targets": [[0, 0, 155, 20, 10, 0]],
            "radars": [[300, 0, 0], [-300, 0, 0]], "terrain": terrain_kw}  # fmt: skip


@pytest.mark.parametrize(
    "array, kw, expect",
    [
        (np.ones((4, 4), bool), {}, "dtype bool is not allowed"),
        (np.ones((4, 4), complex), {}, "dtype complex128 is not allowed"),
        (np.where(np.eye(4) > 0, np.nan, 1.0), {}, "non-finite height at row 0, column 0"),
        (np.ones(5), {}, "shape (5,) is not allowed"),
        (np.ones((4, 4)), {"extent_x": 0.0}, "terrain.extent_x = 0.0: must be a number in (0.0"),
        (np.ones((4, 4)), {"height_scale": -1.0}, "terrain.height_scale = -1.0"),
    ],
)
def test_bad_terrain_files_give_one_line(tmp_path, array, kw, expect):
    np.save(tmp_path / "t.npy", array)
    with pytest.raises(ScenarioError) as err:
        scenario_from_dict(_raw(tmp_path, path="t.npy", **kw), tmp_path)
    msg = str(err.value)
    assert expect in msg and "\n" not in msg


def test_png_terrain_and_colour_image(tmp_path):
    from PIL import Image

    codes = np.arange(12, dtype=np.uint16).reshape(3, 4) * 5000
    Image.fromarray(codes).save(tmp_path / "g.png")
    t = Terrain(path=str(tmp_path / "g.png"), height_scale=65.535)
    np.testing.assert_allclose(terrain.node_heights(t), codes[::-1] / 1000.0)  # north row first
    Image.fromarray(np.zeros((4, 4, 3), np.uint8)).save(tmp_path / "rgb.png")
    with pytest.raises(ScenarioError, match="PNG mode RGB is not grayscale"):
        scenario_from_dict(_raw(tmp_path, path="rgb.png"), tmp_path)
    with pytest.raises(ScenarioError, match="outside the scenario file's folder"):
        scenario_from_dict(_raw(tmp_path, path="../g.png"), tmp_path / "sub")


def test_targets_below_ground_refused_or_lifted(tmp_path):
    np.save(tmp_path / "t.npy", np.full((3, 3), 200.0))
    with pytest.raises(ScenarioError, match=r"targets\[0\]\[2\] \(z\) = 155.*below the terrain"):
        scenario_from_dict(_raw(tmp_path, path="t.npy"), tmp_path)
    s = scenario_from_dict(_raw(tmp_path, path="t.npy", targets_agl=True), tmp_path)
    from mjx_radar.task.method import METHODS
    from mjx_radar.task.params import task_params

    p = task_params(s, METHODS["stationary"])
    assert float(p.target_init[0, 2]) == pytest.approx(355.0)


def test_python_api_round_trip_and_bundle(tmp_path):
    from mjx_radar.scenario.bundle import bundle_scenario

    s = load_scenario(HILLS)
    assert s.terrain is not None and s.terrain.path.endswith("hills.png")
    s2 = s.replace(terrain={"max_slope_deg": 20.0})
    assert s2.terrain.max_slope_deg == 20.0 and s2.terrain.path == s.terrain.path
    s2.to_toml(tmp_path / "x.toml")
    assert load_scenario(tmp_path / "x.toml") == s2
    flat = load_scenario("smoke")
    assert flat.terrain is None
    with pytest.raises(ScenarioError, match="terrain.path"):
        flat.replace(terrain={"extent_x": 10.0})
    out = tmp_path / "run"
    out.mkdir()
    bundle_scenario(HILLS, out)
    assert (out / "terrain" / "hills.png").is_file()
    assert load_scenario(out / "scenario.toml") == dataclasses.replace(
        s, terrain=dataclasses.replace(s.terrain, path=str((out / "terrain/hills.png").resolve()))
    )


def test_bundled_tile_is_what_the_script_makes():
    import importlib.util

    path = Path(__file__).resolve().parents[1] / "scripts" / "make_terrain_tile.py"
    spec = importlib.util.spec_from_file_location("make_terrain_tile", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    s = load_scenario(HILLS)
    np.testing.assert_allclose(terrain.node_heights(s.terrain), mod.heights(), atol=2e-3)


def test_planner_rollouts_and_terms_know_the_terrain():
    """Rollouts put z on the ground (analytic lookup, no contacts), the slope term is in
    the objective, and the planner masks with the terrain only with mpc.los."""
    from mjx_radar.task.task import build

    s = load_scenario(HILLS).replace(mpc={"rollout": "analytic", "los": True})
    task, _ = build(s)
    assert "terrain_slope" in [t.name for t in task.terms]
    assert task.world.plan_occluders is not None and task.world.plan_occluders.terrain is not None
    state = jnp.array([[0.0, 0.0, 0.0, 0.0, 10.0, 0.0], [150.0, -200.0, 0.0, 1.0, 5.0, 0.1],
                       [-300.0, 280.0, 0.0, 2.0, 0.0, 0.0],
                       [220.0, 0.0, 0.0, -1.0, 3.0, 0.0]])  # fmt: skip
    traj = np.asarray(jax.jit(task.rollout)(state, jnp.ones((5, 4, 2))))
    z = terrain.height_np(s.terrain, traj[..., :2].astype(float)) + s.terrain.antenna_height
    np.testing.assert_allclose(traj[..., 2], z, atol=1e-3)
    off, _ = build(s.replace(mpc={"los": False}))
    assert off.world.plan_occluders is None and off.world.occluders.terrain is not None
    from mjx_radar.physics import rollout_radars  # the public entry point (MJX)

    traj = np.asarray(rollout_radars(s, state, jnp.ones((3, 4, 2))))
    z = terrain.height_np(s.terrain, traj[..., :2].astype(float)) + s.terrain.antenna_height
    np.testing.assert_allclose(traj[..., 2], z, atol=1e-3)


def test_placement_stands_on_gentle_ground():
    """Random placement on hills_4r4t: z = ground + antenna, no start on a steep flank."""
    from mjx_radar.env.placement import place_radars, shape_layout
    from mjx_radar.env.streams import trial_streams
    from mjx_radar.task.method import METHODS
    from mjx_radar.task.params import shape_key, task_params

    s = load_scenario(HILLS)
    layout, params = shape_layout(shape_key(s)), task_params(s, METHODS["stationary"])
    place = jax.jit(
        jax.vmap(lambda t: place_radars(layout, params, trial_streams(params.seed, t).placement))
    )
    states, ok = (np.asarray(a) for a in place(jnp.arange(32)))
    assert ok.all()
    xy = states[..., :2].astype(float)
    np.testing.assert_allclose(states[..., 2], terrain.height_np(s.terrain, xy) + 2.0, atol=1e-3)
    grid = terrain.terrain_grid(s.terrain)
    grade = np.asarray(jax.jit(terrain.slope)(grid, jnp.asarray(states[..., :2])))
    assert grade.max() <= terrain.max_grade(s.terrain)
