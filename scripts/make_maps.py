"""Writes the bundled map data of town_4r4t and yard_3r4t (no downloads; deterministic).

* ``scenarios/maps/town.geojson``: a block of 42 building features, 43 footprints (rectangles,
  rotated rectangles, L shapes, one courtyard block with a hole, one MultiPolygon)
  on a 100 m street grid (streets along x, y = 0, ±100, ±200, ±300 stay free),
  heights 8-45 m, in WGS84 lon/lat about ``ORIGIN`` (the inverse of
  ``scenario.buildings.lonlat_to_local``, rounded to 1e-7 deg, ~1 cm).
* ``scenarios/maps/yard.pgm`` + ``yard.yaml``: a 128 x 128 ROS map_server
  occupancy grid at 2.5 m/cell (320 m square about the origin): container rows,
  an L-shaped warehouse, a round tank, a fence with gates, and a patch of unknown
  (grey) cells.

Usage: ``python scripts/make_maps.py [--out scenarios/maps]``.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np

ORIGIN = (11.5755, 48.1374)  # lon, lat [deg] of the town's local origin


def local_to_lonlat(xy: np.ndarray) -> np.ndarray:
    """Inverse of the first-order ENU map of ``scenario.buildings.lonlat_to_local``."""
    from mjx_radar.scenario.buildings import WGS84_A, WGS84_E2

    lon0, lat0 = ORIGIN
    phi0 = math.radians(lat0)
    w = math.sqrt(1.0 - WGS84_E2 * math.sin(phi0) ** 2)
    n, m = WGS84_A / w, WGS84_A * (1.0 - WGS84_E2) / w**3
    lon = lon0 + np.degrees(xy[:, 0] / (n * math.cos(phi0)))
    lat = lat0 + np.degrees(xy[:, 1] / m)
    return np.round(np.stack([lon, lat], -1), 7)


def _rect(cx, cy, w, h, yaw=0.0):
    c, s = math.cos(yaw), math.sin(yaw)
    pts = np.array([[-w, -h], [w, -h], [w, h], [-w, h]]) / 2
    return pts @ np.array([[c, s], [-s, c]]) + [cx, cy]


def town_features() -> list[dict]:
    """42 features: none, one or two per 100 m block (blocks centred at ±50, ±150, ±250)."""
    rng = np.random.default_rng(24)
    centres = [
        (x, y) for x in (-250, -150, -50, 50, 150, 250) for y in (-250, -150, -50, 50, 150, 250)
    ]
    feats = []

    def add(rings, height, kind):
        geo = [[local_to_lonlat(np.vstack([r, r[:1]])).tolist() for r in rings]]
        feats.append(
            {
                "type": "Feature",
                "properties": {"height": height, "kind": kind},
                "geometry": {"type": "Polygon", "coordinates": geo[0]},
            }
        )

    for k, (cx, cy) in enumerate(centres):
        h = float(np.round(rng.uniform(8.0, 45.0), 1))
        if (cx, cy) in ((50, 50), (-50, -50), (50, -50)):
            continue  # a plaza over the drones' start
        if k % 6 == 0:  # L shape
            ring = np.array([[-30, -30], [30, -30], [30, -5], [-5, -5], [-5, 30], [-30, 30]])
            add([ring + [cx, cy]], h, "L")
        elif (cx, cy) == (-150, 150):  # courtyard block
            outer = np.array([[-35, -35], [35, -35], [35, 35], [-35, 35]]) + [cx, cy]
            inner = np.array([[-15, -15], [-15, 15], [15, 15], [15, -15]]) + [cx, cy]
            add([outer, inner], h, "courtyard")
        elif k % 4 == 1:  # two slabs
            add([_rect(cx - 17, cy, 24, 60)], h, "slab")
            add([_rect(cx + 17, cy, 24, 60)], float(np.round(h * 0.6, 1)), "slab")
        else:
            add([_rect(cx, cy, 50, 40, float(rng.uniform(-0.4, 0.4)))], h, "block")
    # one MultiPolygon: two kiosks on the plaza sharing a feature
    kiosks = [_rect(35, 65, 8, 8), _rect(65, 35, 8, 8)]
    feats.append(
        {
            "type": "Feature",
            "properties": {"height": 4.0, "kind": "kiosks"},
            "geometry": {
                "type": "MultiPolygon",
                "coordinates": [[local_to_lonlat(np.vstack([r, r[:1]])).tolist()] for r in kiosks],
            },
        }
    )
    return feats


def yard_image() -> np.ndarray:
    """``[128, 128]`` uint8 map (0 = occupied, 254 = free, 205 = unknown), row 0 = north."""
    n, res, x0 = 128, 2.5, -160.0
    img = np.full((n, n), 254, np.uint8)
    yy, xx = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    x = x0 + (xx + 0.5) * res  # cell centres (column -> east)
    y = x0 + (n - 1 - yy + 0.5) * res  # row 0 is the top (north) edge

    def fill(mask, value=0):
        img[mask] = value

    for row_y in (-100.0, -75.0, 75.0, 100.0):  # container rows, gaps every 40 m
        fill((np.abs(y - row_y) < 5) & (np.abs(x) < 110) & (np.abs((x + 110) % 40 - 20) > 6))
    fill((x > 40) & (x < 110) & (y > -30) & (y < 10))  # L-shaped warehouse
    fill((x > 40) & (x < 60) & (y >= 10) & (y < 45))
    fill(np.hypot(x + 80, y - 10) < 18)  # round tank
    edge = (np.abs(x) > 150) | (np.abs(y) > 150)  # fence with four gates
    gates = (np.abs(x) < 15) | (np.abs(y) < 15)
    fill(edge & ~gates)
    fill((x > -40) & (x < -20) & (y > -45) & (y < -35), 205)  # unknown patch
    return img


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default=str(Path(__file__).parent.parent / "scenarios" / "maps"))
    out = Path(p.parse_args(argv).out)
    out.mkdir(parents=True, exist_ok=True)
    doc = {"type": "FeatureCollection", "features": town_features()}
    (out / "town.geojson").write_text(json.dumps(doc, indent=None, separators=(",", ":")) + "\n")
    img = yard_image()
    header = (
        f"P5\n# yard occupancy grid, scripts/make_maps.py\n{img.shape[1]} {img.shape[0]}\n255\n"
    )
    (out / "yard.pgm").write_bytes(header.encode() + img.tobytes())
    (out / "yard.yaml").write_text(
        "# ROS map_server map (scripts/make_maps.py): 2.5 m cells, "
        "lower-left corner at (-160, -160)\n"
        "image: yard.pgm\nresolution: 2.5\norigin: [-160.0, -160.0, 0.0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\nmode: trinary\n"
    )
    print(f"wrote {out}/town.geojson ({len(doc['features'])} features), yard.pgm, yard.yaml")


if __name__ == "__main__":
    main()
