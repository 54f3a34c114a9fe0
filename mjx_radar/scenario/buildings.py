"""Building footprints from GeoJSON, extruded into convex mesh obstacles (host only).

A GeoJSON ``FeatureCollection`` (RFC 7946) of ``Polygon`` / ``MultiPolygon``
features, each with a numeric height property [m], becomes buildings standing on
z = 0 (docs/maps.md):

1. coordinates → the scenario's local metric frame (x east, y north) [m]: either
   already metric (``crs = "local"``), or WGS84 lon/lat (``crs = "lonlat"``, the
   RFC 7946 default) projected onto the local tangent plane (ENU) at ``origin =
   (lon0, lat0)`` by the first-order equirectangular map
   ``x = N(φ0) cos φ0 · Δλ``, ``y = M(φ0) · Δφ`` with the WGS84 radii of curvature
   ``N = a / √(1 − e² sin² φ0)`` (prime vertical) and
   ``M = a (1 − e²) / (1 − e² sin² φ0)^{3/2}`` (meridian); Δλ, Δφ in radians. The
   relative error is ≈ |Δφ| tan φ0 in x (2 × 10⁻⁴ at 1 km north of a 50° origin);
2. polygons are checked with shapely (``is_valid_reason``: a self-intersecting
   ring is refused);
3. each polygon is split into convex parts (shapely's constrained Delaunay
   triangles, then adjacent pieces merged while their union stays convex) because
   MJX collides with, and ``world.obstacles`` takes the footprint of, a mesh's
   convex hull;
4. each part is extruded by trimesh (``extrude_triangulation``) into a watertight
   prism of the building's height, written once as a content-addressed OBJ file
   (:func:`maps_dir`) and returned as a ``kind = "mesh"`` :class:`Obstacle` with
   ``pos`` = the part's footprint centroid at z = 0.

The parts of one building tile its footprint, so the union SDF (min over parts)
is exact outside every building; inside a non-convex building it is negative but
its magnitude can be smaller than the depth (it is the depth inside one part).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import re
import warnings
from pathlib import Path
from typing import NamedTuple

import numpy as np

from mjx_radar.scenario.schema import Obstacle

WGS84_A = 6378137.0  # semi-major axis [m]
WGS84_E2 = 6.69437999014e-3  # first eccentricity squared
LONLAT_NAMES = (
    "urn:ogc:def:crs:OGC:1.3:CRS84",
    "urn:ogc:def:crs:OGC::CRS84",
    "EPSG:4326",
    "urn:ogc:def:crs:EPSG::4326",
    "CRS84",
)
MAX_BUILDINGS = 2000
MAX_JSON_DEPTH = 64  # nesting levels of a GeoJSON file (a MultiPolygon in a feature: ~8)
MAX_VERTICES = 256  # per polygon: the convex split grows as n^3 (256: ~10 s, 800: ~100 s)


class MapError(ValueError):
    """A map file is invalid: ``str(err)`` is one line (the field is added by the caller)."""


class Building(NamedTuple):
    """One footprint polygon of a feature (a MultiPolygon gives several).

    Attributes:
        polygon: shapely ``Polygon`` in the local metric frame [m].
        height: extrusion height [m] (> 0).
        feature: index of the GeoJSON feature it came from.
    """

    polygon: object
    height: float
    feature: int


def lonlat_to_local(lonlat: np.ndarray, origin: tuple[float, float]) -> np.ndarray:
    """Local tangent-plane (east, north) coordinates of WGS84 lon/lat points.

    Args:
        lonlat: ``[..., 2]`` (longitude, latitude) [deg].
        origin: (lon0, lat0) of the local frame's origin [deg].

    Returns:
        ``[..., 2]`` (x east, y north) [m], first-order ENU (module docstring).
    """
    lon0, lat0 = origin
    phi0 = math.radians(lat0)
    w = math.sqrt(1.0 - WGS84_E2 * math.sin(phi0) ** 2)
    n, m = WGS84_A / w, WGS84_A * (1.0 - WGS84_E2) / w**3
    d = np.radians(np.asarray(lonlat, np.float64) - np.array([lon0, lat0]))
    d[..., 0] = (d[..., 0] + math.pi) % (2 * math.pi) - math.pi  # across the antimeridian
    return np.stack([n * math.cos(phi0) * d[..., 0], m * d[..., 1]], -1)


def read_geojson(path: str | Path, crs: str, origin=None, height_key: str = "height"):
    """The buildings of a GeoJSON file in the local metric frame.

    Args:
        path: the ``.geojson`` / ``.json`` file.
        crs: ``"local"`` (coordinates in metres) or ``"lonlat"`` (WGS84 degrees).
        origin: (lon0, lat0) [deg], required for ``"lonlat"``.
        height_key: the feature property holding the height [m].

    Returns:
        list of :class:`Building`.

    Raises:
        MapError: one line naming the feature and the problem.
    """
    if crs not in ("local", "lonlat"):
        raise MapError(f"unknown CRS {crs!r}; must be 'local' or 'lonlat'")
    if crs == "lonlat" and origin is None:
        raise MapError("crs = 'lonlat' needs the origin (lon0, lat0) [deg]")
    features = _features(path, crs)
    out: list[Building] = []
    for i, feat in enumerate(features):
        out += _feature_buildings(i, feat, crs, origin, height_key)
    if len(out) > MAX_BUILDINGS:
        raise MapError(f"{len(out)} polygons; at most {MAX_BUILDINGS}")
    return out


def _json_depth(text: str) -> int:
    """The deepest nesting of ``[`` (91) and ``{`` (123) in JSON ``text``, strings skipped."""
    bare = re.sub(r'"(?:\\.|[^"\\])*"', "", text).encode()
    c = np.frombuffer(bare, np.uint8).astype(np.int32)
    return int(np.cumsum(np.isin(c, (91, 123)) * 1 - np.isin(c, (93, 125))).max(initial=0))


def _features(path, crs: str) -> list:
    """The features of a GeoJSON FeatureCollection file, its declared CRS checked."""
    try:
        text = Path(path).read_text()
        if _json_depth(text) > MAX_JSON_DEPTH:  # whatever the interpreter's recursion limit
            raise RecursionError
        doc = json.loads(text)
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
        raise MapError(f"not a readable JSON file ({str(err).splitlines()[0]})") from None
    except RecursionError:
        raise MapError("not a readable JSON file (nested too deeply)") from None
    if not isinstance(doc, dict) or doc.get("type") != "FeatureCollection":
        raise MapError("must be a GeoJSON FeatureCollection")
    declared = doc.get("crs")
    if declared is not None:  # the 2008 GeoJSON "crs" member (RFC 7946 dropped it)
        props = declared.get("properties") if isinstance(declared, dict) else None
        name = props.get("name") if isinstance(props, dict) else None
        if name not in LONLAT_NAMES:
            raise MapError(
                f"unknown CRS {name!r}; only WGS84 lon/lat (RFC 7946) or a "
                "local metric frame (no crs member, buildings.crs = 'local')"
            )
        if crs != "lonlat":
            raise MapError(
                f"the file declares CRS {name!r} (lon/lat); set buildings.crs = "
                "'lonlat' and buildings.origin"
            )
    features = doc.get("features")
    if not isinstance(features, list) or not features:
        raise MapError("features: must be a non-empty array")
    return features


def _height(where: str, feat, height_key: str) -> float:
    """A feature's height property [m], in (0, 1000]; its geometry a (Multi)Polygon."""
    if not isinstance(feat, dict) or not isinstance(feat.get("geometry"), dict):
        raise MapError(f"{where}: must be a Feature with a geometry")
    props = feat.get("properties") or {}
    h = props.get(height_key) if isinstance(props, dict) else None
    if isinstance(h, bool) or not isinstance(h, int | float):
        raise MapError(f"{where}: missing or non-numeric height property {height_key!r}")
    if not (math.isfinite(h) and 0.0 < h <= 1000.0):
        raise MapError(f"{where}: height {h!r} must be in (0, 1000] m")
    if feat["geometry"].get("type") not in ("Polygon", "MultiPolygon"):
        raise MapError(
            f"{where}: geometry must be a Polygon or MultiPolygon, "
            f"not {feat['geometry'].get('type')!r}"
        )
    return h


def _feature_buildings(i: int, feat, crs: str, origin, height_key: str) -> list[Building]:
    """Feature ``i``'s polygons as buildings in the local frame (``MapError`` naming it)."""
    import shapely
    from shapely.geometry import shape

    where = f"feature {i}"
    h = _height(where, feat, height_key)
    try:
        with warnings.catch_warnings():  # NaN coordinates: refused below, in one line
            warnings.simplefilter("ignore", RuntimeWarning)
            geom = shape(feat["geometry"])
    except Exception as err:  # shapely raises several types for malformed rings
        raise MapError(f"{where}: malformed coordinates ({str(err).splitlines()[0]})") from None
    if geom.is_empty or not np.all(np.isfinite(shapely.get_coordinates(geom))):
        raise MapError(f"{where}: empty or non-finite coordinates")
    if crs == "lonlat":
        ll = shapely.get_coordinates(geom)
        if np.any(np.abs(ll[:, 1]) > 90.0) or np.any(np.abs(ll[:, 0]) > 180.0):
            raise MapError(f"{where}: lon/lat out of range (|lon| <= 180, |lat| <= 90)")
        geom = shapely.transform(geom, lambda c: lonlat_to_local(c, origin))
    if not geom.is_valid:
        raise MapError(f"{where}: invalid polygon ({shapely.is_valid_reason(geom)})")
    out = []
    for poly in getattr(geom, "geoms", [geom]):
        n_vert = len(shapely.get_coordinates(poly)) - 1 - len(poly.interiors)
        if n_vert > MAX_VERTICES:
            raise MapError(
                f"{where}: polygon has {n_vert} vertices; at most {MAX_VERTICES} "
                "(simplify it, e.g. shapely's simplify(0.5))"
            )
        if poly.area < 1e-6:
            raise MapError(f"{where}: polygon has zero area")
        out.append(Building(shapely.orient_polygons(poly), float(h), i))
    return out


def convex_parts(polygon) -> list:
    """Convex polygons tiling ``polygon`` (holes allowed); one part if it is convex.

    Constrained Delaunay triangles (shapely), merged greedily: two pieces sharing
    an edge become one while their union's area equals its convex hull's.
    """
    import shapely

    if abs(polygon.convex_hull.area - polygon.area) <= 1e-9 * polygon.area:
        return [polygon]
    pieces = list(shapely.constrained_delaunay_triangles(polygon).geoms)
    merged = True
    while merged:
        merged = False
        for a in range(len(pieces)):
            for b in range(a + 1, len(pieces)):
                if pieces[a].intersection(pieces[b]).length <= 1e-9:
                    continue  # no shared edge
                union = shapely.union(pieces[a], pieces[b]).simplify(0.0)
                if union.geom_type == "Polygon" and (
                    abs(union.convex_hull.area - union.area) <= 1e-9 * union.area
                ):
                    pieces[a] = union
                    del pieces[b]
                    merged = True
                    break
            if merged:
                break
    return [shapely.orient_polygons(p) for p in pieces]


def extrude(polygon, height: float):
    """Watertight trimesh prism of a convex polygon from z = 0 to ``height`` [m]."""
    import trimesh

    ring = np.asarray(polygon.exterior.coords, np.float64)[:-1]
    fan = np.array([[0, k, k + 1] for k in range(1, len(ring) - 1)], np.int64)
    return trimesh.creation.extrude_triangulation(ring, fan, height)


def maps_dir() -> Path:
    """Folder of the generated building meshes (content-addressed OBJ files).

    ``$MJX_RADAR_MAPS_DIR``, else ``maps/`` beside the compile cache folder
    (``~/.cache/mjx_radar/maps``), else the temporary folder when the cache is off.
    """
    if os.environ.get("MJX_RADAR_MAPS_DIR"):
        return Path(os.environ["MJX_RADAR_MAPS_DIR"]).expanduser()
    from mjx_radar.io.cache_dirs import default_dir

    cache = default_dir()
    if cache is None:
        import tempfile

        return Path(tempfile.gettempdir()) / "mjx_radar_maps"
    return cache.parent / "maps"


def _write_obj(vertices: np.ndarray, faces: np.ndarray) -> str:
    """Writes an OBJ once under :func:`maps_dir` (name = hash of its text); its path."""
    from mjx_radar.io.atomic import atomic_write

    text = "".join(f"v {x!r} {y!r} {z!r}\n" for x, y, z in vertices.tolist())
    text += "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in faces.tolist())
    path = maps_dir() / f"{hashlib.sha256(text.encode()).hexdigest()[:24]}.obj"
    if not path.is_file() or path.read_text() != text:
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write(path, lambda tmp: Path(tmp).write_text(text))
    return str(path)


def building_obstacles(buildings) -> tuple[Obstacle, ...]:
    """Convex extruded parts of ``buildings`` as mesh obstacles (OBJ files written)."""
    out = []
    for b in buildings:
        for part in convex_parts(b.polygon):
            c = np.asarray(part.centroid.coords[0])
            mesh = extrude(part, b.height)
            verts = np.asarray(mesh.vertices) - np.array([c[0], c[1], 0.0])
            path = _write_obj(verts, np.asarray(mesh.faces))
            out.append(Obstacle(kind="mesh", pos=(float(c[0]), float(c[1]), 0.0), path=path))
    return tuple(out)
