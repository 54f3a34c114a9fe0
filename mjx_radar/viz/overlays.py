"""The overlays of one step of a trial, drawn by ``render`` (MuJoCo) and ``snapshot`` (matplotlib).

:func:`step_overlay` gathers what both draw at filter step ``k`` — radar markers
with their trails and R2T / R2R rings, true drones, CKF estimates with 2-sigma
extents, and the MPPI samples of the acting plan ordered by weight; fixed radar sites
(``mobile = false``) as tall boxes / triangles, waypoint missions as dotted routes with
diamond markers, absent drones (appear / leave) left out — in one place;
:func:`draw_mujoco` appends it to an ``MjvScene`` as user geoms and
:func:`draw_matplotlib` to a top-down axes. Colours: :data:`RADAR_RGB` per radar,
:data:`TARGET_RGB` per drone, samples by relative weight ``w / max w``.
"""

from __future__ import annotations

import dataclasses

import numpy as np

RADAR_RGB = np.array([[0.0, 0.45, 1.0], [1.0, 0.5, 0.0], [0.0, 0.7, 0.25], [0.8, 0.0, 0.8]])
TARGET_RGB = np.array([[0.85, 0.05, 0.05], [0.55, 0.0, 0.35], [0.35, 0.2, 0.0], [0.1, 0.1, 0.1]])


@dataclasses.dataclass(frozen=True)
class StepOverlay:
    """What is overlaid at one filter step (N radars, M drones, S samples, H horizon)."""

    radar: np.ndarray  # [N, 6] radar states
    radar_rgb: np.ndarray  # [N, 3]
    target: np.ndarray  # [M, 3] true drone positions
    target_rgb: np.ndarray  # [M, 3]
    mean: np.ndarray  # [M, 3] CKF position estimates
    sigma: np.ndarray  # [M, 3] CKF position standard deviations
    r2t: float  # radar-to-target ring radius [m]
    r2r: float  # radar-to-radar ring radius [m]
    trail: np.ndarray  # [L, N, 3] past radar positions, newest first
    samples: np.ndarray  # [S, H, N, 2] MPPI sampled paths, lowest weight first
    weight: np.ndarray  # [S] relative weights in [0, 1], ascending
    fixed: np.ndarray | None = None  # [N] bool: fixed sites ([[radar_override]] mobile = false)
    waypoints: tuple = ()  # ((rgb [3], [W, 3] waypoints), ...) of waypoint missions
    present: np.ndarray | None = None  # [M] bool: drones present at this step


def world_state(scene, t: float, m: int):
    """Fixed sites [N], waypoint routes and presence [M] of a
    :class:`~mjx_radar.viz.scene.Scene` at time ``t`` [s] (filter step k: ``(k + 1) dt``);
    shared with the viewer (:mod:`mjx_radar.viz.view.viewer_traces`)."""
    fixed = np.array(scene.fixed, bool)
    present, routes = np.ones(m, bool), []
    for tm in scene.target_motion:
        present[tm.target] = tm.appear <= t < tm.leave
        if tm.model == "waypoints":
            rgb = TARGET_RGB[tm.target % len(TARGET_RGB)]
            routes.append((rgb, np.asarray(tm.waypoints, float)))
    return fixed, tuple(routes), present


def step_overlay(tr, k: int) -> StepOverlay:
    """The overlay of filter step ``k`` (0-based) of a :class:`~mjx_radar.viz.run_dir.Trial`."""
    n, m = tr.radar.shape[1], tr.target.shape[1]
    c = tr.control_index(k)
    w = tr.sample_weight[c] / max(float(tr.sample_weight[c].max()), 1e-12)
    order = np.argsort(w, kind="stable")  # the best drawn last, on top
    fixed, routes, present = world_state(tr.scene, (k + 1) * tr.dt, m)
    return StepOverlay(
        radar=tr.radar[k],
        radar_rgb=RADAR_RGB[np.arange(n) % len(RADAR_RGB)],
        target=tr.target[k, :, :3],
        target_rgb=TARGET_RGB[np.arange(m) % len(TARGET_RGB)],
        mean=tr.mean[k],
        sigma=tr.sigma[k],
        r2t=float(tr.meta["r2t"]),
        r2r=float(tr.meta["r2r"]),
        trail=tr.trail(k),
        samples=tr.sample_xy[c][order],
        weight=w[order],
        fixed=fixed,
        waypoints=routes,
        present=present,
    )


class _Geoms:
    """Appends user geoms to an ``MjvScene`` until ``scene.maxgeom`` is reached."""

    def __init__(self, scene):
        import mujoco

        self.mj, self.scene = mujoco, scene
        self.eye = np.eye(3).reshape(-1)

    def add(self, gtype, size, pos, rgba, emission=0.3) -> bool:
        s = self.scene
        if s.ngeom >= s.maxgeom:
            return False
        g = s.geoms[s.ngeom]
        size, pos = np.asarray(size, np.float64), np.asarray(pos, np.float64)
        self.mj.mjv_initGeom(g, gtype, size, pos, self.eye, np.asarray(rgba, np.float32))
        g.emission = emission
        s.ngeom += 1
        return True

    def line(self, a, b, rgba, width=2.0) -> bool:
        line = self.mj.mjtGeom.mjGEOM_LINE
        if not self.add(line, np.zeros(3), np.zeros(3), rgba):
            return False
        a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
        self.mj.mjv_connector(self.scene.geoms[self.scene.ngeom - 1], line, width, a, b)
        return True

    def polyline(self, pts, rgba, width=2.0) -> bool:
        return all(self.line(p, q, rgba, width) for p, q in zip(pts[:-1], pts[1:], strict=True))

    def ring(self, center, radius, rgba, n=40) -> bool:
        t = np.linspace(0, 2 * np.pi, n + 1)
        pts = np.stack([center[0] + radius * np.cos(t), center[1] + radius * np.sin(t)], -1)
        return self.polyline(np.column_stack([pts, np.full(n + 1, 0.5)]), rgba, 1.5)


def _lifted(xy: np.ndarray, z: float) -> np.ndarray:
    return np.column_stack([xy, np.full(len(xy), z)])


def draw_mujoco(scene, ov: StepOverlay, scale: float) -> None:
    """Appends ``ov`` to an ``MjvScene`` as user geoms, most important first.

    Args:
        scene: the renderer's ``MjvScene`` after ``update_scene``.
        ov: the step's overlay.
        scale: marker size unit [m] (about 1.2 % of the scene's extent).
    """
    import mujoco

    gt, g, s = mujoco.mjtGeom, _Geoms(scene), scale
    fixed = np.zeros(len(ov.radar), bool) if ov.fixed is None else ov.fixed
    here = np.ones(len(ov.target), bool) if ov.present is None else ov.present
    for (x, y, *_rest), rgb, site in zip(ov.radar, ov.radar_rgb, fixed, strict=True):
        if site:  # a fixed site: a tall box
            g.add(
                gt.mjGEOM_BOX,
                [0.8 * s, 0.8 * s, 1.5 * s],
                [x, y, 1.5 * s + 5.0],
                [*rgb, 1.0],
                emission=0.6,
            )
        else:
            g.add(
                gt.mjGEOM_CYLINDER,
                [s, 0.3 * s, 0],
                [x, y, 0.3 * s + 5.0],
                [*rgb, 1.0],
                emission=0.6,
            )
    for rgb, wps in ov.waypoints:  # waypoint missions: small boxes joined by thin lines
        for p in wps:
            g.add(gt.mjGEOM_BOX, [0.35 * s] * 3, p, [*rgb, 0.7])
        g.polyline(wps, [*rgb, 0.5], 1.0)
    for target, mean, sigma, rgb, on in zip(
        ov.target, ov.mean, ov.sigma, ov.target_rgb, here, strict=True
    ):
        if not on:  # absent (appear / leave): not drawn
            continue
        g.add(gt.mjGEOM_SPHERE, [0.7 * s] * 3, target, [*rgb, 1.0])
        g.add(gt.mjGEOM_SPHERE, [0.35 * s] * 3, mean, [1.0, 1.0, 1.0, 1.0])
        size = np.maximum(2.0 * sigma, 0.05 * s)  # 2-sigma semi-axes
        g.add(gt.mjGEOM_ELLIPSOID, size, mean, [1.0, 1.0, 0.4, 0.35])
    for x, y, *_rest in ov.radar:
        g.ring((x, y), ov.r2t, [0.9, 0.1, 0.1, 0.8])
        g.ring((x, y), ov.r2r, [0.1, 0.1, 0.1, 0.9])
    for n, rgb in enumerate(ov.radar_rgb):
        g.polyline(_lifted(ov.trail[:, n, :2], 1.0), [*rgb, 0.6], 3.0)
    for path, w in zip(ov.samples, ov.weight, strict=True):
        rgba = [0.3 + 0.7 * w, 0.3 - 0.2 * w, 0.6 - 0.6 * w, 0.25 + 0.7 * w]
        for n in range(path.shape[1]):
            if not g.polyline(_lifted(path[:, n], 0.7), rgba, 1.0):
                return


def draw_matplotlib(ax, ov: StepOverlay):
    """Draws ``ov`` on a top-down matplotlib axes (x right, y up, metres).

    Returns:
        The ``LineCollection`` of MPPI samples (coloured by relative weight), for a colorbar.
    """
    from matplotlib.collections import LineCollection
    from matplotlib.patches import Circle, Ellipse

    n_radars = ov.radar.shape[0]
    fixed = np.zeros(n_radars, bool) if ov.fixed is None else np.asarray(ov.fixed, bool)
    segs = [ov.samples[j, :, n] for j in range(len(ov.weight)) for n in range(n_radars)]
    lines = LineCollection(
        segs,
        array=np.repeat(ov.weight, n_radars),
        cmap="plasma",
        linewidths=0.8,
        alpha=0.8,
        zorder=2,
    )
    ax.add_collection(lines)
    for n, ((x, y), rgb) in enumerate(zip(ov.radar[:, :2], ov.radar_rgb, strict=True)):
        ax.add_patch(Circle((x, y), ov.r2t, fill=False, ec="tab:red", lw=0.8, ls="--"))
        ax.add_patch(Circle((x, y), ov.r2r, fill=False, ec="k", lw=0.8))
        ax.plot(ov.trail[:, n, 0], ov.trail[:, n, 1], color=rgb, lw=1.5, zorder=3)
        site = bool(fixed[n])
        label = None if n != int(np.argmax(fixed == site)) else ("fixed site" if site else "radar")
        ax.plot(
            x,
            y,
            "^" if site else "s",
            color=rgb,
            ms=11 if site else 8,
            mec="k",
            zorder=4,
            label=label,
        )
    for j, (rgb, wps) in enumerate(ov.waypoints):
        ax.plot(
            wps[:, 0],
            wps[:, 1],
            ":",
            color=rgb,
            lw=1.0,
            marker="D",
            ms=4,
            zorder=3,
            label="waypoints" if j == 0 else None,
        )
    for m, rgb in enumerate(ov.target_rgb):
        if ov.present is not None and not ov.present[m]:
            continue  # absent (appear / leave)
        (ex, ey), (sx, sy) = ov.mean[m, :2], ov.sigma[m, :2]
        first = m == 0
        ax.add_patch(Ellipse((ex, ey), 4 * sx, 4 * sy, fill=False, ec=rgb, lw=1.0, zorder=5))
        ax.plot(*ov.target[m, :2], "x", color=rgb, ms=7, zorder=5, label="drone" if first else None)
        ax.plot(
            ex, ey, "o", mfc="none", mec=rgb, ms=5, zorder=5, label="estimate" if first else None
        )
    return lines
