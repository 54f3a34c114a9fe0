"""Geometry and per-frame traces of the offline HTML viewer (:mod:`mjx_radar.viz.view.viewer`).

Everything here is numpy on the host: polylines are ``[P, 3]`` float32 arrays with a
NaN row between pieces (plotly draws a gap there), so one trace holds all radars'
rings, all samples or all lines of sight of a step, and a frame is a handful of
array slices, not a Python loop over points.

:func:`static_traces` gives the layers that never move (ground extent, terrain surface,
obstacles, waypoint routes: :mod:`mjx_radar.viz.view.viewer_world`); :func:`frame_traces` the
layers of one filter step, in the order of :data:`LAYERS`. Fixed radar sites
(``[[radar_override]] mobile = false``) are their own layer (cross markers); drones absent
at a step (``[[target_motion]]`` appear / leave) are NaN there (not drawn), with their
estimates, axes and lines of sight (:func:`mjx_radar.viz.overlays.world_state`). Over
terrain, rings, MPPI samples and plans are draped on the ground.
"""

from __future__ import annotations

import numpy as np

from mjx_radar.viz.overlays import RADAR_RGB, TARGET_RGB, world_state
from mjx_radar.viz.view import viewer_los
from mjx_radar.viz.view.viewer_world import (
    ground_z,
    polylines,
    route_trace,
    segments,
    terrain_surface,
)

RING_POINTS = 40  # segments of an R2T ring
ROUND_POINTS = 24  # segments of a cylinder's outline
#: animated layers: (legend name, legendgroup), one trace each, in frame order
LAYERS = (
    ("radars", "radars"),
    ("radar trails", "radars"),
    ("R2T rings", "rings"),
    ("drones (truth)", "drones"),
    ("estimates", "estimates"),
    ("2-sigma axes", "estimates"),
    ("MPPI samples", "samples"),
    ("plan", "plan"),
    ("lines of sight", "los"),
    ("fixed sites", "radars"),
    ("blocked lines of sight", "los"),
    ("vehicles", "world"),
)
FIXED_SYMBOL = "cross"  # fixed radar sites (mobile radars: "square")
SAMPLE_SCALE = "Plasma"
VISIBLE_RGB = "rgb(20,20,20)"  # lines of sight: opaque and 3 px, legible over terrain
BLOCKED_RGB = "rgb(215,0,0)"  # blocked ones: dashed


def _rgb(c) -> str:
    r, g, b = (int(round(255 * v)) for v in c)
    return f"rgb({r},{g},{b})"


def rings(centers: np.ndarray, radius: float, z: float = 0.5) -> np.ndarray:
    """Horizontal circles of ``radius`` around ``centers[:, :2]`` at height ``z``."""
    t = np.linspace(0.0, 2.0 * np.pi, RING_POINTS + 1)
    c = np.asarray(centers, np.float32)[:, None, :2]
    xy = c + radius * np.stack([np.cos(t), np.sin(t)], -1)[None]
    return polylines(np.concatenate([xy, np.full((*xy.shape[:2], 1), z)], -1))


def _xyz(points: np.ndarray) -> dict:
    return {"x": points[:, 0], "y": points[:, 1], "z": points[:, 2]}


def obstacle_outline(obstacles) -> np.ndarray:
    """Wireframe prisms of the obstacles: footprint polygon at bottom and top, vertical edges.

    Boxes and meshes use :func:`mjx_radar.world.obstacles.footprint_polygon` (a mesh:
    the convex hull of its projected vertices, what the planner avoids), cylinders a
    circle; heights from the box / cylinder size or the mesh's vertex z range.
    """
    from mjx_radar.world.obstacles import footprint_polygon, mesh_vertices

    pieces = []
    for obs in obstacles:
        pos = np.asarray(obs.pos, float)
        if obs.kind == "cylinder":
            t = np.linspace(0.0, 2.0 * np.pi, ROUND_POINTS, endpoint=False)
            poly = pos[:2] + obs.size[0] * np.stack([np.cos(t), np.sin(t)], -1)
            z0, z1 = pos[2] - obs.size[1], pos[2] + obs.size[1]
        else:
            poly = footprint_polygon(obs)
            if obs.kind == "box":
                z0, z1 = pos[2] - obs.size[2], pos[2] + obs.size[2]
            else:
                z = mesh_vertices(obs)[:, 2]
                z0, z1 = float(z.min()), float(z.max())
        ring = np.concatenate([poly, poly[:1]])
        lo = np.column_stack([ring, np.full(len(ring), max(z0, 0.0))])
        hi = np.column_stack([ring, np.full(len(ring), z1)])
        pieces += [polylines(np.stack([lo, hi])), segments(lo[:-1], hi[:-1])]
    return np.concatenate(pieces) if pieces else np.zeros((0, 3), np.float32)


def static_traces(scene, lo, hi) -> list[dict]:
    """The ground extent (rectangle at z = 0), the terrain surface, the obstacle wireframes
    and the waypoint routes (the last three only where the
    :class:`~mjx_radar.viz.scene.Scene` has them)."""
    corners = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])
    ground = np.column_stack([np.concatenate([corners, corners[:1]]), np.zeros(5)])
    out = [
        dict(
            type="scatter3d",
            mode="lines",
            name="ground extent",
            legendgroup="world",
            line={"color": "rgb(120,120,120)", "width": 2},
            hoverinfo="skip",
            **_xyz(ground.astype(np.float32)),
        )
    ]
    if scene.ground.present:
        out.append(terrain_surface(scene.ground.config, lo, hi))
    if scene.obstacles.present:
        out.append(
            dict(
                type="scatter3d",
                mode="lines",
                name="obstacles",
                legendgroup="world",
                line={"color": "rgb(90,90,90)", "width": 3},
                hoverinfo="skip",
                **_xyz(obstacle_outline(scene.obstacles.shapes)),
            )
        )
    routes = route_trace(scene.target_init, scene.target_motion)
    return out if routes is None else [*out, routes]


def layer_styles(n: int, m: int, fixed=None, vehicles: bool = False) -> list[dict]:
    """The constant attributes of the :data:`LAYERS` traces (names, colours, widths);
    ``fixed [N]`` bool: the fixed sites (the "fixed sites" legend entry only if any);
    ``vehicles``: the scenario has moving obstacles (their legend entry)."""
    radar_c = [_rgb(RADAR_RGB[i % len(RADAR_RGB)]) for i in range(n)]
    target_c = [_rgb(TARGET_RGB[i % len(TARGET_RGB)]) for i in range(m)]
    styles = [
        dict(
            mode="markers+text",
            marker={"size": 6, "symbol": "square", "color": radar_c},
            text=[f"R{i}" for i in range(n)],
            textposition="top center",
        ),
        dict(mode="lines", line={"color": "rgb(0,115,255)", "width": 3}, opacity=0.6),
        dict(mode="lines", line={"color": "rgb(230,25,25)", "width": 2, "dash": "dash"}),
        dict(
            mode="markers+text",
            marker={"size": 5, "symbol": "diamond", "color": target_c},
            text=[f"D{j}" for j in range(m)],
            textposition="top center",
        ),
        dict(mode="markers", marker={"size": 4, "symbol": "circle-open", "color": target_c}),
        dict(mode="lines", line={"color": "rgb(200,160,0)", "width": 4}),
        dict(
            mode="lines",
            showlegend=False,  # its entry is sample_legend(): see there
            line={
                "color": [],
                "colorscale": SAMPLE_SCALE,
                "cmin": 0.0,
                "cmax": 1.0,
                "width": 2,
                "showscale": True,
                "colorbar": {
                    "title": {"text": "MPPI weight"},
                    "len": 0.4,
                    "x": 0.64,
                    "y": 0.8,
                    "thickness": 12,
                },
            },
        ),
        dict(mode="lines", line={"color": "rgb(0,160,60)", "width": 5}),
        dict(mode="lines", line={"color": VISIBLE_RGB, "width": 3}),
        dict(
            mode="markers+text",
            marker={"size": 12, "symbol": FIXED_SYMBOL, "color": radar_c},
            text=[f"R{i}" for i in range(n)],
            textposition="top center",
            showlegend=fixed is not None and bool(np.any(fixed)),
        ),
        dict(mode="lines", line={"color": BLOCKED_RGB, "width": 3, "dash": "dash"}),
        dict(mode="lines", line={"color": "rgb(170,60,20)", "width": 5}, showlegend=vehicles),
    ]
    return [
        dict(type="scatter3d", name=name, legendgroup=group, hoverinfo="skip", **style)
        for (name, group), style in zip(LAYERS, styles, strict=True)
    ]


def frame_traces(tr, k: int, samples: int, plan_xy: np.ndarray | None, visible=None) -> list[dict]:
    """The data of the :data:`LAYERS` traces at filter step ``k`` of a trial.

    Args:
        tr: a :class:`~mjx_radar.viz.run_dir.Trial`.
        k: filter step (0-based).
        samples: at most this many MPPI samples, the highest weights.
        plan_xy: ``[C, H, N, 2]`` planned radar paths of the trial, or ``None``.
        visible: ``[N, M]`` bool line of sight at the step, or ``None``: computed here
            (:func:`mjx_radar.viz.view.viewer_los.visibility`; pass it for many frames at once).
    """
    radar = tr.radar[k, :, :3].astype(np.float32)
    n, m = radar.shape[0], tr.target.shape[1]
    _, _, present = world_state(tr.scene, (k + 1) * tr.dt, m)
    gone = np.where(present, 0.0, np.nan).astype(np.float32)[:, None]  # NaN: absent
    target, mean = tr.target[k, :, :3] + gone, tr.mean[k] + gone
    sc = tr.scene
    c = tr.control_index(k)
    w = tr.sample_weight[c] / max(float(tr.sample_weight[c].max()), 1e-12)
    keep = np.argsort(w, kind="stable")[max(len(w) - samples, 0) :]  # the best drawn last
    paths = np.moveaxis(tr.sample_xy[c][keep], 2, 1)  # [S, N, H, 2]
    z = np.broadcast_to(radar[None, :, None, 2:3], (*paths.shape[:-1], 1))
    if sc.ground.present:
        z = ground_z(sc.ground, paths, 0.0)[..., None]
    sample_pts = polylines(np.concatenate([paths, z], -1).reshape(-1, paths.shape[2], 3))
    sample_w = np.repeat(w[keep], n * (paths.shape[2] + 1)).astype(np.float32)
    two_sigma = 2.0 * tr.sigma[k][:, None, :] * np.eye(3)[None]  # [M, 3 axes, 3]
    axes = segments(
        (mean[:, None] - two_sigma).reshape(-1, 3), (mean[:, None] + two_sigma).reshape(-1, 3)
    )
    if plan_xy is not None:
        plan = np.moveaxis(plan_xy[min(c, len(plan_xy) - 1)], 1, 0)  # [N, H, 2]
        plan_z = radar[:, None, 2:3].repeat(plan.shape[1], 1)
        if sc.ground.present:
            plan_z = ground_z(sc.ground, plan, 0.0)[..., None]
        plan_pts = polylines(np.concatenate([plan, plan_z], -1))
    else:
        plan_pts = np.zeros((0, 3), np.float32)
    t = (k + 1) * tr.dt
    if visible is None:
        world = (sc.ground, sc.obstacles, sc.moving)
        visible = viewer_los.visibility(*world, radar[None], target[None], [t])[0]
    los, blocked = viewer_los.los_segments(radar, target, visible)
    ring = rings(radar, tr.meta["r2t"])
    if sc.ground.present:
        ring[:, 2] = ground_z(sc.ground, ring[:, :2], 0.5)
    fixed = np.asarray(sc.fixed, bool)[:, None]
    points = [
        np.where(fixed, np.nan, radar),
        polylines(np.moveaxis(tr.trail(k), 1, 0)),
        ring,
        target.astype(np.float32),
        mean.astype(np.float32),
        axes,
        sample_pts,
        plan_pts,
        los,
        np.where(fixed, radar, np.nan),
        blocked,
        viewer_los.vehicle_lines(sc.moving.vehicles, t),
    ]
    out = [dict(type="scatter3d", **_xyz(p)) for p in points]
    out[6]["line"] = {"color": sample_w}
    return out
