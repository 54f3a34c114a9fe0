"""Real maps: GeoJSON buildings (projection, extrusion, SDF) and ROS occupancy grids."""

import json
import math
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import shapely
from PIL import Image

from mjx_radar.physics import plant as physics
from mjx_radar.scenario import buildings, occupancy
from mjx_radar.scenario.buildings import MapError
from mjx_radar.scenario.reader import ScenarioError, load_scenario
from mjx_radar.scenario.schema import RadarLimits
from mjx_radar.world import obstacles

HEAD = """name = "t"
n_radars = 2
targets = [[0, 0, 55, 20, 10, 0]]
radars = [[300, 0, 0], [-300, 0, 0]]
"""


def _geojson(tmp_path, features, crs=None, name="b.geojson"):
    doc = {"type": "FeatureCollection", "features": features}
    if crs:
        doc["crs"] = {"type": "name", "properties": {"name": crs}}
    (tmp_path / name).write_text(json.dumps(doc))
    return tmp_path / name


def _feature(rings, height=10.0, key="height"):
    props = {key: height} if key else {}
    return {
        "type": "Feature",
        "properties": props,
        "geometry": {"type": "Polygon", "coordinates": [np.asarray(r).tolist() for r in rings]},
    }


def _load(tmp_path, table):
    (tmp_path / "s.toml").write_text(HEAD + table)
    return load_scenario(tmp_path / "s.toml")


def test_lonlat_projection_matches_wgs84_degree_lengths():
    # Tabulated WGS84 lengths of one degree: 110.574 / 111.320 km (lat / lon) at the
    # equator, 111.132 / 78.847 km at 45 deg; the first-order map is exact in its slope.
    for lat0, dlat, dlon in ((0.0, 110574.0, 111320.0), (45.0, 111132.0, 78847.0)):
        xy = buildings.lonlat_to_local(np.array([[1e-3, lat0], [0.0, lat0 + 1e-3]]), (0.0, lat0))
        np.testing.assert_allclose(xy[0], [dlon * 1e-3, 0.0], atol=6e-3)
        np.testing.assert_allclose(xy[1], [0.0, dlat * 1e-3], atol=6e-3)
    # across the antimeridian: 179.999 E to 179.999 W is 0.002 deg east
    xy = buildings.lonlat_to_local(np.array([[-179.999, 0.0]]), (179.999, 0.0))
    np.testing.assert_allclose(xy[0, 0], 2 * 111.320, atol=6e-3)


def test_extruded_rectangle_volume_and_footprint_sdf(tmp_path):
    rect = [[10, -5], [40, -5], [40, 15], [10, 15], [10, -5]]  # 30 x 20 m
    path = _geojson(tmp_path, [_feature([rect], 12.5)])
    (found,) = buildings.read_geojson(path, "local")
    (obs,) = buildings.building_obstacles([found])
    mesh = buildings.extrude(buildings.convex_parts(found.polygon)[0], 12.5)
    assert mesh.is_watertight and math.isclose(mesh.volume, 30 * 20 * 12.5, rel_tol=1e-12)
    assert obs.kind == "mesh" and obs.pos == (25.0, 5.0, 0.0)
    verts = obstacles.mesh_vertices(obs)  # the OBJ file as the plant and occlusion read it
    np.testing.assert_allclose(verts.min(0), [10, -5, 0], atol=1e-12)
    np.testing.assert_allclose(verts.max(0), [40, 15, 12.5], atol=1e-12)
    xy = np.random.default_rng(0).uniform(-20, 70, (2000, 2))
    q = np.abs(xy - [25.0, 5.0]) - [15.0, 10.0]  # closed-form rectangle SDF
    exact = np.linalg.norm(np.maximum(q, 0), axis=-1) + np.minimum(q.max(-1), 0)
    np.testing.assert_allclose(obstacles.union_sdf((obs,), xy), exact, atol=1e-9)


def test_nonconvex_building_parts_tile_it(tmp_path):
    outer = [[0, 0], [60, 0], [60, 25], [25, 25], [25, 60], [0, 60], [0, 0]]  # L shape
    hole = [[5, 5], [5, 15], [15, 15], [15, 5], [5, 5]]  # a courtyard
    path = _geojson(tmp_path, [_feature([outer, hole], 20.0)])
    (found,) = buildings.read_geojson(path, "local")
    poly = found.polygon
    parts = buildings.convex_parts(poly)
    assert 2 <= len(parts) <= 8
    union = shapely.union_all(parts)
    assert union.symmetric_difference(poly).area < 1e-9 * poly.area
    assert math.isclose(sum(p.area for p in parts), poly.area, rel_tol=1e-12)  # no overlap
    vol = sum(buildings.extrude(p, 20.0).volume for p in parts)
    assert math.isclose(vol, poly.area * 20.0, rel_tol=1e-12)
    obs = buildings.building_obstacles([found])
    xy = np.random.default_rng(1).uniform(-30, 90, (3000, 2))
    phi = obstacles.union_sdf(obs, xy)
    inside = shapely.contains_xy(poly, xy[:, 0], xy[:, 1])
    dist = shapely.distance(shapely.points(xy), poly)  # 0 inside
    np.testing.assert_allclose(phi[~inside], dist[~inside], atol=1e-9)
    depth = shapely.distance(shapely.points(xy), poly.boundary)
    assert np.all(phi[inside] < 0) and np.all(-phi[inside] <= depth[inside] + 1e-9)


def test_bundled_map_data_is_made_by_the_script(tmp_path):
    import importlib.util

    script = Path(__file__).parent.parent / "scripts" / "make_maps.py"
    spec = importlib.util.spec_from_file_location("make_maps", script)
    make_maps = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(make_maps)
    make_maps.main(["--out", str(tmp_path)])
    bundled = Path(__file__).parent.parent / "scenarios" / "maps"
    for name in ("town.geojson", "yard.pgm", "yard.yaml"):
        assert (tmp_path / name).read_bytes() == (bundled / name).read_bytes(), name
    # lon/lat written at 1e-7 deg: the projection round trip is within 1.5 cm
    xy = np.random.default_rng(2).uniform(-300, 300, (500, 2))
    back = buildings.lonlat_to_local(make_maps.local_to_lonlat(xy), make_maps.ORIGIN)
    assert np.abs(back - xy).max() < 0.015
    s = load_scenario("town_4r4t")
    assert s.n_radars == 4 and len(s.obstacles) == 52
    assert all(o.kind == "mesh" for o in s.obstacles)


@pytest.mark.parametrize(
    "table, files, needle",
    [
        (
            '[buildings]\npath = "b.geojson"\ncrs = "local"\n',
            [_feature([[[0, 0], [10, 10], [10, 0], [0, 10], [0, 0]]])],
            "Self-intersection",
        ),
        (
            '[buildings]\npath = "b.geojson"\ncrs = "local"\n',
            [_feature([[[0, 0], [10, 0], [10, 10], [0, 0]]], key=None)],
            "missing or non-numeric",
        ),
        (
            '[buildings]\npath = "b.geojson"\ncrs = "local"\n',
            [_feature([[[0, 0], [10, 0], [10, 10], [0, 0]]], height=-3.0)],
            "height -3.0",
        ),
        ('[buildings]\npath = "b.geojson"\ncrs = "EPSG:3857"\n', [], "buildings.crs"),
        ('[buildings]\npath = "b.geojson"\ncrs = "lonlat"\n', [], "buildings.origin"),
        ('[buildings]\npath = "b.geojson"\ncrs = "local"\nextra = 1\n', [], "unknown field"),
        ('[buildings]\npath = "../b.geojson"\ncrs = "local"\n', [], "outside"),
    ],
)
def test_bad_buildings_raise_one_line(tmp_path, table, files, needle):
    _geojson(tmp_path, files or [_feature([[[100, 100], [110, 100], [110, 110], [100, 100]]])])
    with pytest.raises(ScenarioError) as err:
        _load(tmp_path, table)
    assert needle in str(err.value) and "\n" not in str(err.value), str(err.value)


def test_unknown_crs_member_in_file(tmp_path):
    feat = [_feature([[[0, 0], [1e-4, 0], [1e-4, 1e-4], [0, 0]]])]
    _geojson(tmp_path, feat, crs="urn:ogc:def:crs:EPSG::3857")
    with pytest.raises(MapError, match="unknown CRS"):
        buildings.read_geojson(tmp_path / "b.geojson", "lonlat", (0.0, 0.0))
    _geojson(tmp_path, feat, crs="urn:ogc:def:crs:OGC:1.3:CRS84")
    with pytest.raises(MapError, match="set buildings.crs = 'lonlat'"):
        buildings.read_geojson(tmp_path / "b.geojson", "local")
    (b,) = buildings.read_geojson(tmp_path / "b.geojson", "lonlat", (0.0, 0.0))
    assert math.isclose(b.polygon.area, 0.5 * 11.1320 * 11.0574, rel_tol=1e-4)


def _write_map(tmp_path, pixels, negate=0, mode="trinary", yaw=0.0, name="m.png"):
    Image.fromarray(np.asarray(pixels, np.uint8)).save(tmp_path / name)
    (tmp_path / "m.yaml").write_text(
        f"image: {name}\nresolution: 0.5\norigin: [-1.0, 2.0, {yaw}]\nnegate: {negate}\n"
        f"occupied_thresh: 0.65\nfree_thresh: 0.196\nmode: {mode}\n"
    )
    return tmp_path / "m.yaml"


def test_occupancy_follows_map_server_conventions(tmp_path):
    # map_server: p = (255 - x) / 255 (negate 0) or x / 255 (negate 1); occupied if
    # p > 0.65, free if p < 0.196, else unknown; image row 0 is the top of the map.
    x = np.array([[0, 89, 90, 100], [204, 205, 206, 255]], np.uint8)
    p0 = (255.0 - x) / 255.0
    for negate, p in ((0, p0), (1, x / 255.0)):
        for unknown in ("occupied", "free"):
            g = occupancy.read_map(_write_map(tmp_path, x, negate), unknown)
            occ = (p > 0.65) | ((p >= 0.196) & (p <= 0.65) if unknown == "occupied" else False)
            np.testing.assert_array_equal(g.occupied, occ[::-1])
    assert g.resolution == 0.5 and g.origin == (-1.0, 2.0, 0.0)
    # RGB: the mean of the channels (not luminance) is the value
    rgb = np.array([[[0, 0, 255], [255, 255, 0]]], np.uint8)  # means 85 and 170
    g = occupancy.read_map(_write_map(tmp_path, rgb, name="c.png"), "free")
    np.testing.assert_array_equal(g.occupied, [[True, False]])
    # RGBA in scale mode: alpha is excluded from the mean and never changes an
    # occupied or free pixel; an in-between pixel is unknown (occupied by default)
    rgba = np.array([[[0, 0, 0, 0], [255, 255, 255, 0], [128, 128, 128, 255]]], np.uint8)
    g = occupancy.read_map(_write_map(tmp_path, rgba, mode="scale", name="a.png"), "free")
    np.testing.assert_array_equal(g.occupied, [[True, False, False]])
    g = occupancy.read_map(tmp_path / "m.yaml", "occupied")
    np.testing.assert_array_equal(g.occupied, [[True, False, True]])
    # cell (i, j) centre = origin + (i + 1/2, j + 1/2) * resolution, rotated by yaw
    g = occupancy.read_map(_write_map(tmp_path, x, yaw=math.pi / 2))
    np.testing.assert_allclose(occupancy.cell_centres(g)[1, 2], [-1.0 - 0.75, 2.0 + 1.25])
    phi = obstacles.union_sdf(occupancy.box_obstacles(g, 3.0), occupancy.cell_centres(g))
    np.testing.assert_array_equal(phi < 0, g.occupied)  # rotated boxes cover the cells
    assert np.abs(phi).min() >= 0.25 - 1e-9


def test_merged_boxes_tile_the_occupied_cells_exactly():
    rng = np.random.default_rng(3)
    for _ in range(20):
        occ = rng.random((rng.integers(1, 30), rng.integers(1, 30))) < rng.uniform(0.1, 0.9)
        cover = np.zeros(occ.shape, int)
        for i0, i1, j0, j1 in occupancy.merge_runs(occ):
            cover[j0:j1, i0:i1] += 1
        np.testing.assert_array_equal(cover, occ.astype(int))  # disjoint, exact union
    full = np.ones((7, 5), bool)
    assert occupancy.merge_runs(full) == [(0, 5, 0, 7)]


def test_occupied_cells_equal_the_planner_keep_out_region():
    s = load_scenario("yard_3r4t")
    g = occupancy.read_map(Path(__file__).parent.parent / "scenarios" / "maps" / "yard.yaml")
    assert len(s.obstacles) == len(occupancy.merge_runs(g.occupied)) < g.occupied.sum() / 50
    centres = occupancy.cell_centres(g)
    exact = obstacles.union_sdf(s.obstacles, centres)
    np.testing.assert_array_equal(exact < 0, g.occupied)  # boxes = cells, on the host
    assert np.abs(exact).min() >= 0.5 * g.resolution - 1e-9
    grid = obstacles.sdf_grid(s.obstacles, s.placement_half_width)  # the planner's lookup
    phi = np.asarray(jax.jit(obstacles.sdf)(grid, jnp.asarray(centres, jnp.float32)))
    np.testing.assert_array_equal(phi < 0, g.occupied)


def test_radar_never_enters_occupied_cells_at_full_speed(tmp_path):
    # A wall of merged boxes (a gap-free 3-cell-thick row), hit head-on and along a seam.
    occ = np.zeros((12, 40), bool)
    occ[6:9, 5:35] = True
    occ[9:11, 10:12] = True
    g = occupancy.OccupancyGrid(occ, 2.0, (-40.0, -10.0, 0.0))
    boxes = occupancy.box_obstacles(g, 4.0)
    assert len(boxes) == 2
    dt, lim = 0.025, RadarLimits()
    plant = physics.make_plant(3, 1, dt, lim, boxes)
    s0 = jnp.array(
        [
            [-20.0, -20.0, 0, 1.2, 50, 0],
            [0.0, -20, 0, np.pi / 2, 50, 0],
            [-19.0, 30, 0, -np.pi / 2, 50, 0],
        ]
    )
    u = jnp.tile(jnp.array([[35.0, 0.0]]), (120, 3, 1))

    def run(s0, u):
        d = physics.init_data(plant, s0, jnp.array([[0.0, 0, 50, 0, 0, 0]]))

        def body(d, uk):
            d = physics.step(plant, d, uk, jnp.zeros((1, 3)))
            return d, physics.radar_state(plant, d)

        return jax.lax.scan(body, d, u)[1]

    traj = np.asarray(jax.jit(run)(s0, u))
    gap = obstacles.union_sdf(boxes, traj[..., :2])
    assert gap.min() >= obstacles.HULL_RADIUS - 0.03, gap.min()
    assert np.all(gap[-1] < obstacles.HULL_RADIUS + 2.0)  # all three were stopped by it


@pytest.mark.parametrize("name", ["town_4r4t", "yard_3r4t"])
def test_map_scenarios_load_and_round_trip(name, tmp_path):
    import tomllib

    import mjx_radar

    s = load_scenario(name)
    assert s.obstacles and s.radar_init
    assert s.replace(name="x").obstacles == s.obstacles  # Python round trip (to_toml)
    s.to_toml(tmp_path / "s.toml")
    assert load_scenario(tmp_path / "s.toml") == s and mjx_radar.validate(s) == s
    assert name in mjx_radar.bundled_scenarios()
    root = Path(__file__).parent.parent
    data = tomllib.loads((root / "pyproject.toml").read_text())["tool"]["setuptools"]
    shipped = data["package-data"]["mjx_radar.scenarios"]
    assert {"maps/*.geojson", "maps/*.yaml", "maps/*.pgm"} <= set(shipped)


def test_yaml_exponent_without_dot_reads_as_ros_does(tmp_path):
    # PyYAML (YAML 1.1) reads `5e-1` as a string; yaml-cpp (map_server) reads 0.5
    path = _write_map(tmp_path, np.zeros((4, 4)))
    text = path.read_text().replace("resolution: 0.5", "resolution: 5e-1")
    path.write_text(text.replace("origin: [-1.0, 2.0,", "origin: [-1e0, 2E0,"))
    g = occupancy.read_map(path)
    assert g.resolution == 0.5 and tuple(g.origin[:2]) == (-1.0, 2.0)
    path.write_text(text.replace("resolution: 5e-1", "resolution: half"))
    with pytest.raises(MapError, match="resolution = 'half'"):
        occupancy.read_map(path)


def test_bad_occupancy_maps(tmp_path):
    _write_map(tmp_path, np.zeros((4, 4)))
    text = (tmp_path / "m.yaml").read_text()
    cases = [
        (text.replace("resolution: 0.5\n", ""), "resolution: missing"),
        (text.replace("mode: trinary", "mode: raw"), "raw is not supported"),
        (text.replace("free_thresh: 0.196", "free_thresh: 0.9"), "free_thresh = 0.9 >"),
        (text.replace("m.png", "../m.png"), "inside the YAML"),
        (text.replace("m.png", "nothere.png"), "cannot read"),
        (text.replace("origin: [-1.0, 2.0, 0.0]", "origin: [1, 2]"), "origin ="),
    ]
    for body, needle in cases:
        (tmp_path / "m.yaml").write_text(body)
        with pytest.raises(ScenarioError) as err:
            _load(tmp_path, '[occupancy]\npath = "m.yaml"\n')
        assert needle in str(err.value) and "\n" not in str(err.value), (needle, str(err.value))
    Image.fromarray(np.zeros((4, 4), np.uint16)).save(tmp_path / "i.png")  # 16-bit gray
    (tmp_path / "m.yaml").write_text(text.replace("m.png", "i.png"))
    with pytest.raises(ScenarioError, match="need 8-bit gray"):
        _load(tmp_path, '[occupancy]\npath = "m.yaml"\n')


def test_bundle_copies_map_files(tmp_path):
    from mjx_radar.scenario.bundle import bundle_scenario

    root = Path(__file__).parent.parent / "scenarios"
    for name in ("town_4r4t", "yard_3r4t"):
        out = tmp_path / name
        written = bundle_scenario(root / f"{name}.toml", out)
        copy = load_scenario(out / "scenario.toml")  # loads from the run directory alone
        assert copy.obstacles == load_scenario(name).obstacles
        assert all(p.is_relative_to(out) for p in written)
    assert (tmp_path / "town_4r4t" / "maps" / "town.geojson").is_file()
    assert (tmp_path / "yard_3r4t" / "maps" / "yard" / "yard.pgm").is_file()


@pytest.mark.slow
def test_yard_closed_loop_never_enters_occupied_cells():
    import mjx_radar

    s = load_scenario("yard_3r4t")
    s = s.replace(mpc={"rollout": "analytic"})
    run = mjx_radar.simulate(s, trials=2, steps=120, progress=False)
    assert run.metrics["obstacle_contacts"].sum() == 0
    radar_xy = np.asarray(run.arrays["radar"])[..., :2]  # [T, K, N, 2]
    moved = np.linalg.norm(radar_xy[:, -1] - radar_xy[:, 0], axis=-1)
    assert moved.max() > 5.0  # the radars did drive
    gap = obstacles.union_sdf(s.obstacles, radar_xy)
    assert gap.min() >= obstacles.HULL_RADIUS, gap.min()


def test_degenerate_and_huge_footprints():
    maps = Path(__file__).parent / "bad_inputs" / "maps"
    (b,) = buildings.read_geojson(maps / "zero_edge.geojson", "local")  # a repeated vertex
    assert b.polygon.area == pytest.approx(100.0)
    assert len(buildings.convex_parts(b.polygon)) == 1
    with pytest.raises(MapError, match="1200 vertices; at most 256"):
        buildings.read_geojson(maps / "many_vertices.geojson", "local")
