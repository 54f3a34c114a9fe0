"""The world layers of the viewer that do not move: terrain surface and waypoint routes.

Shared by the offline HTML (:mod:`mjx_radar.viz.view.viewer`) and the live view
(:mod:`mjx_radar.viz.live_view.live_page`) through
:func:`mjx_radar.viz.view.viewer_traces.static_traces`.

- :func:`polylines` and :func:`segments`: the NaN-separated ``[P, 3]`` float32 polylines
  every layer is drawn with (one trace holds many pieces).
- :func:`terrain_surface`: the ``[terrain]`` height field (:mod:`mjx_radar.world.terrain`)
  as a plotly ``surface``. Its nodes are the file's own grid nodes ``H[i, j]`` at
  ``(x0 + j dx, y0 + i dy)``, cropped to the scene box (plus one node) and subsampled to
  at most :data:`TERRAIN_NODES` nodes per side by a stride ``s`` (every s-th row and
  column, the last one kept): the drawn surface equals the height grid at those nodes
  (plotly interpolates linearly between them; the simulator's bilinear interpolant agrees
  at the nodes). Size: ``<= 160 x 160`` float32 heights, at most about 180 kB in the file, once.
- :func:`ground_z`: the bilinear height (numpy, :func:`mjx_radar.world.terrain.height_np`)
  under xy points, to drape rings, MPPI samples and plans on the ground.
- :func:`route_lines`: each ``waypoints`` target's route, start -> waypoints (-> the
  first again when it loops), as a dotted polyline coloured per drone.
"""

from __future__ import annotations

import numpy as np

from mjx_radar.viz.overlays import TARGET_RGB

TERRAIN_NODES = 160  # nodes per side of the drawn surface at most
LIFT = 0.5  # [m] rings, samples and plans drawn this far above the ground
#: low green to high brown (no white: the scene's background)
TERRAIN_SCALE = [[0.0, "rgb(70,130,70)"], [0.5, "rgb(175,160,105)"], [1.0, "rgb(120,85,55)"]]


def polylines(paths: np.ndarray) -> np.ndarray:
    """``[P, L, 3]`` paths -> ``[P * (L + 1), 3]`` float32 points, NaN row after each path."""
    paths = np.asarray(paths, np.float32)
    gap = np.full((*paths.shape[:-2], 1, 3), np.nan, np.float32)
    return np.concatenate([paths, gap], axis=-2).reshape(-1, 3)


def segments(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Segments ``a[i] -> b[i]`` (``[P, 3]`` each) as one NaN-separated polyline ``[3P, 3]``."""
    return polylines(np.stack([a, b], axis=-2))


def _rgb(c) -> str:
    r, g, b = (int(round(255 * v)) for v in c)
    return f"rgb({r},{g},{b})"


def aspect(xy_span, scale: float = 1.2, z: float = 0.5) -> dict:
    """The scene's ``aspectratio`` and ``camera``: x and y true to scale, the longer side
    ``scale`` (plotly's cube is 1: the box fills the scene's domain), z ``z``."""
    sx, sy = (max(float(v), 1.0) for v in xy_span)
    k = scale / max(sx, sy)
    return {
        "aspectmode": "manual",
        "aspectratio": {"x": sx * k, "y": sy * k, "z": z},
        "camera": {"eye": {"x": 0.95, "y": -1.3, "z": 0.8}},
    }


def terrain_nodes(terrain, lo, hi, max_nodes: int = TERRAIN_NODES):
    """``(xs [nx], ys [ny], heights [ny, nx], stride)``: the grid nodes drawn.

    The nodes of the height grid within ``[lo, hi]`` (xy, plus one node either side),
    every ``stride``-th row and column (the last one kept), ``stride`` the smallest that
    leaves at most ``max_nodes`` per side.
    """
    from mjx_radar.world.terrain import grid_geometry, node_heights

    h = node_heights(terrain)
    origin, spacing = grid_geometry(terrain, h.shape)
    lo_ij = np.floor((np.asarray(lo, float) - origin) / spacing).astype(int) - 1
    hi_ij = np.ceil((np.asarray(hi, float) - origin) / spacing).astype(int) + 1
    shape = np.array([h.shape[1], h.shape[0]])
    lo_ij, hi_ij = np.clip(lo_ij, 0, shape - 1), np.clip(hi_ij, 0, shape - 1)
    stride = max(int(np.ceil((hi_ij - lo_ij).max() / max(max_nodes - 1, 1))), 1)
    cols, rows = (
        np.unique(np.r_[np.arange(a, b + 1, stride), b]) for a, b in zip(lo_ij, hi_ij, strict=True)
    )
    xs, ys = origin[0] + cols * spacing[0], origin[1] + rows * spacing[1]
    return xs, ys, h[np.ix_(rows, cols)], stride


def terrain_surface(terrain, lo, hi, max_nodes: int = TERRAIN_NODES) -> dict:
    """The terrain as a plotly ``surface`` trace (legend entry "terrain"; :func:`terrain_nodes`)."""
    xs, ys, h, stride = terrain_nodes(terrain, lo, hi, max_nodes)
    return dict(
        type="surface",
        name=f"terrain (every {stride} node)" if stride > 1 else "terrain",
        legendgroup="world",
        showlegend=True,
        showscale=False,
        colorscale=TERRAIN_SCALE,
        opacity=0.85,
        hoverinfo="skip",
        x=xs.astype(np.float32),
        y=ys.astype(np.float32),
        z=h.astype(np.float32),
        lighting={"ambient": 0.7, "diffuse": 0.6},
        contours={"z": {"show": False}},
    )


def ground_z(ground, xy: np.ndarray, default: float) -> np.ndarray:
    """``[...]`` height of the :class:`~mjx_radar.world.components.Ground` + :data:`LIFT`
    under ``xy [..., 2]``; ``default`` on flat ground (no terrain)."""
    xy = np.asarray(xy, np.float64)
    if not ground.present:
        return np.full(xy.shape[:-1], default, np.float32)
    from mjx_radar.world.terrain import height_np

    flat = np.where(np.isfinite(xy), xy, 0.0).reshape(-1, 2)
    z = height_np(ground.config, flat).reshape(xy.shape[:-1]) + LIFT
    return np.where(np.isnan(xy[..., 0]), np.nan, z).astype(np.float32)


def route_lines(target_init, target_motion):
    """``(points [P, 3], colours [P])`` of the waypoint routes (NaN row between routes), or
    ``None`` when no target flies ``waypoints`` (``target_init [M][6]``: the drones'
    starts; ``target_motion``: the ``[[target_motion]]`` tables)."""
    pieces, colours = [], []
    for tm in target_motion:
        if tm.model != "waypoints":
            continue
        wps = np.asarray(tm.waypoints, np.float32)
        start = np.asarray(target_init[tm.target][:3], np.float32)
        path = np.concatenate([start[None], wps, wps[:1] if tm.loop else wps[:0]])
        pieces.append(np.concatenate([path, np.full((1, 3), np.nan, np.float32)]))
        colours += [_rgb(TARGET_RGB[tm.target % len(TARGET_RGB)])] * (len(path) + 1)
    if not pieces:
        return None
    return np.concatenate(pieces), colours


def route_trace(target_init, target_motion) -> dict | None:
    """The routes as one dotted ``scatter3d`` (legend entry "waypoint routes"), or ``None``."""
    routes = route_lines(target_init, target_motion)
    if routes is None:
        return None
    pts, colours = routes
    return dict(
        type="scatter3d",
        mode="lines+markers",
        name="waypoint routes",
        legendgroup="world",
        hoverinfo="skip",
        line={"color": colours, "width": 3, "dash": "dot"},
        marker={"size": 3, "symbol": "diamond-open", "color": colours},
        x=pts[:, 0],
        y=pts[:, 1],
        z=pts[:, 2],
    )
