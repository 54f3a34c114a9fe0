"""``mjx-radar snapshot``: the paper's two-panel figure of one step of a saved run.

Left: the top-down scene at step K (the overlays of :mod:`mjx_radar.viz.overlays`:
radars with their trails and R2T / R2R rings, true drones, CKF estimates with
2-sigma ellipses, MPPI samples coloured by weight) over the obstacle footprints.
Right: ``log det`` of the DDR standard Fisher information (SPEC §5) of a target
placed at each point of a grid over the free space, at the drones' mean altitude,
for the radar positions at step K (:func:`fim_heatmap`, JAX, vmapped over the
grid), with the footprints masked out.

Footprints come from the planner's own signed distance
(:func:`mjx_radar.world.obstacles.union_sdf`, exact per obstacle: rotated boxes,
discs, convex hulls of meshes): a grid cell is an obstacle iff ``φ <= 0`` at its
centre (:func:`obstacle_mask`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mjx_radar.errors import InputError
from mjx_radar.io.atomic import atomic_write, check_writable
from mjx_radar.viz.overlays import draw_matplotlib, step_overlay
from mjx_radar.viz.run_dir import Trial, load_trial

FORMATS = (".png", ".pdf", ".svg")
FOOTPRINT_CELLS = 400  # obstacle grid points along the longer side of the scene panel


def fim_heatmap(radar_pos, xs, ys, z, C):
    """``log det`` of the DDR SFIM of a single target at each grid point.

    Args:
        radar_pos: ``[N, 3]`` radar positions [m].
        xs: ``[G]`` grid x coordinates [m].
        ys: ``[Gy]`` grid y coordinates [m].
        z: target altitude [m] (scalar).
        C: range-noise constant of the DDR model (scalar, or ``[N, 1]`` per radar).

    Returns:
        ``[Gy, G]`` numpy array, entry ``[i, j]`` for the target at ``(xs[j], ys[i], z)``.
    """
    import jax
    import jax.numpy as jnp

    from mjx_radar.estimation.information import fisher

    radar_pos = jnp.asarray(radar_pos)
    gx, gy = jnp.meshgrid(jnp.asarray(xs), jnp.asarray(ys))
    points = jnp.stack([gx, gy, jnp.full_like(gx, z)], axis=-1).reshape(-1, 1, 3)

    def one(p):
        return fisher.logdet(fisher.sfim(radar_pos, p, C)[0])

    return np.asarray(jax.jit(jax.vmap(one))(points)).reshape(gx.shape)


def map_grid(lo, hi, cells: int) -> tuple[np.ndarray, np.ndarray]:
    """``(xs [nx], ys [ny])``: about ``cells`` points along the longer side of ``[lo, hi]``."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    n_x, n_y = np.maximum(np.round(cells * (hi - lo) / np.max(hi - lo)).astype(int), 2)
    return np.linspace(lo[0], hi[0], n_x), np.linspace(lo[1], hi[1], n_y)


def obstacle_mask(obstacles, xs, ys) -> np.ndarray:
    """``[ny, nx]`` bool: True where ``(xs[j], ys[i])`` lies in a footprint (``φ <= 0``)."""
    if not obstacles:
        return np.zeros((len(ys), len(xs)), bool)
    from mjx_radar.world.obstacles import union_sdf

    gx, gy = np.meshgrid(np.asarray(xs, float), np.asarray(ys, float))
    return union_sdf(tuple(obstacles), np.stack([gx, gy], -1)) <= 0.0


def _draw_footprints(ax, tr: Trial, lo, hi) -> None:
    """The footprints as a filled grey image of :func:`obstacle_mask` (``gid="obstacles"``)."""
    if not tr.scene.obstacles.present:
        return
    xs, ys = map_grid(lo, hi, FOOTPRINT_CELLS)
    mask = obstacle_mask(tr.scene.obstacles.shapes, xs, ys)
    dx, dy = (xs[1] - xs[0]) / 2, (ys[1] - ys[0]) / 2  # cell centres at the grid points
    ax.imshow(
        np.ma.masked_where(~mask, np.ones(mask.shape)),
        origin="lower",
        extent=(xs[0] - dx, xs[-1] + dx, ys[0] - dy, ys[-1] + dy),
        cmap="gray",
        vmin=0.0,
        vmax=2.5,  # 1.0 -> 0.4 grey
        alpha=0.5,
        interpolation="nearest",
        zorder=1,
        gid="obstacles",
    )


def vehicle_outlines(moving, t: float) -> list[np.ndarray]:
    """``[V, 2]`` footprint outline of each moving obstacle at time ``t`` (host)."""
    from mjx_radar.world.moving import geometry, moving_params, pose

    xy, unit = (np.asarray(a, float) for a in pose(moving_params(moving, np.float32), t))
    half, cyl, _ = geometry(moving)
    out = []
    for c, u, (hl, hw), is_cyl in zip(xy, unit, half, cyl, strict=True):
        if is_cyl:
            a = np.linspace(0.0, 2 * np.pi, 33)
            out.append(c + hl * np.stack([np.cos(a), np.sin(a)], -1))
        else:
            v = np.array([-u[1], u[0]])
            out.append(
                c + np.array([hl * u + hw * v, -hl * u + hw * v, -hl * u - hw * v, hl * u - hw * v])
            )
    return out


def _draw_vehicles(ax, tr: Trial, k: int) -> None:
    """The moving obstacles at step ``k``'s time ``(k + 1) dt`` (``gid="moving"``)."""
    from matplotlib.patches import Polygon

    for poly in vehicle_outlines(tr.scene.moving.vehicles, (k + 1) * tr.dt):
        ax.add_patch(
            Polygon(poly, closed=True, fc=(0.75, 0.2, 0.15), ec="k", lw=0.5, zorder=3, gid="moving")
        )


def _draw_terrain(ax, tr: Trial, lo, hi) -> None:
    """Terrain heights as a shaded image (``gid="terrain"``), slopes beyond the vehicle
    limit hatched (``gid="steep"``)."""
    t = tr.scene.ground.config
    if t is None:
        return
    from mjx_radar.world import terrain

    xs, ys = map_grid(lo, hi, FOOTPRINT_CELLS // 2)
    gx, gy = np.meshgrid(xs, ys)
    xy = np.stack([gx, gy], -1)
    h = terrain.height_np(t, xy)
    ext = (xs[0], xs[-1], ys[0], ys[-1])
    ax.imshow(h, origin="lower", extent=ext, cmap="terrain", alpha=0.55, zorder=0, gid="terrain")
    grade = np.asarray(terrain.slope(terrain.terrain_grid(t), xy.astype(np.float32)))
    steep = grade > terrain.max_grade(t)
    if steep.any():
        ax.contourf(
            xs,
            ys,
            steep.astype(float),
            levels=[0.5, 1.5],
            colors="none",
            hatches=["////"],
            zorder=0.5,
        ).set_gid("steep")


def masked_fraction(tr: Trial, k: int, xs, ys, z: float) -> np.ndarray:
    """``[ny, nx]`` fraction of the radars whose line of sight to ``(x, y, z)`` is blocked
    (obstacles and terrain, :mod:`mjx_radar.world.occlusion`) at step ``k``."""
    ground, obstacles = tr.scene.ground, tr.scene.obstacles
    if not (ground.present or obstacles.present):
        return np.zeros((len(ys), len(xs)))
    from mjx_radar.world import occlusion

    occ = ground.occluding(obstacles.occluders)
    gx, gy = np.meshgrid(xs, ys)
    pts = np.stack([gx, gy, np.full_like(gx, z)], -1).reshape(-1, 3).astype(np.float32)
    vis = np.asarray(occlusion.line_of_sight(occ, tr.radar[k, :, :3].astype(np.float32), pts))
    return 1.0 - vis.mean(0).reshape(gx.shape)


def snapshot_figure(tr: Trial, k: int, grid: int = 120):
    """The two-panel figure of filter step ``k`` (0-based) of a trial (caller closes it)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    lo, hi = tr.bounds()
    xs, ys = map_grid(lo, hi, grid)
    z = float(tr.target[k, :, 2].mean())
    c = tr.meta.get("noise_constants")  # a mixed fleet: each radar's C, [N, 1]
    c = tr.meta["noise_constant"] if c is None else np.asarray(c)[:, None]
    heat = fim_heatmap(tr.radar[k, :, :3], xs, ys, z, c)
    heat = np.ma.masked_where(obstacle_mask(tr.scene.obstacles.shapes, xs, ys), heat)
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.6), constrained_layout=True)
    _draw_terrain(left, tr, lo, hi)
    _draw_footprints(left, tr, lo, hi)
    lines = draw_matplotlib(left, step_overlay(tr, k))
    fig.colorbar(lines, ax=left, label="MPPI sample weight (relative)", shrink=0.8)
    left.legend(loc="upper left", fontsize=7)
    im = right.imshow(heat, origin="lower", extent=(lo[0], hi[0], lo[1], hi[1]), cmap="viridis")
    fig.colorbar(im, ax=right, label=r"$\log\det J$ (DDR SFIM) [log m$^{-2}$]", shrink=0.8)
    masked = masked_fraction(tr, k, xs, ys, z)
    if masked.any():  # darker where more radars are blocked; the heat map ignores masking
        right.imshow(
            np.ma.masked_where(masked == 0, masked),
            origin="lower",
            cmap="Greys",
            vmin=0.0,
            vmax=1.25,
            alpha=0.6,
            extent=(lo[0], hi[0], lo[1], hi[1]),
            gid="masked",
        )
    if tr.scene.moving.present:  # vehicles at the step's time, on both panels
        _draw_vehicles(left, tr, k)
        _draw_vehicles(right, tr, k)
    right.plot(*tr.radar[k, :, :2].T, "s", color="w", mec="k", ms=7)
    right.plot(*tr.target[k, :, :2].T, "x", color="r", ms=7)
    for ax, title in ((left, "scene"), (right, f"SFIM log det at z = {z:.0f} m")):
        ax.set(xlim=(lo[0], hi[0]), ylim=(lo[1], hi[1]), xlabel="x [m]", ylabel="y [m]")
        ax.set_aspect("equal")
        ax.set_title(f"{title}, t = {(k + 1) * tr.dt:.2f} s", fontsize=10)
    return fig


def snapshot(run_dir, step: int, trial: int = 0, out_path=None, grid: int = 120) -> Path:
    """Writes the two-panel figure of filter step ``step`` (1-based) of one trial.

    Args:
        run_dir: a complete run directory.
        step: filter step in ``[1, K]`` (the ``step`` column of ``metrics.parquet``).
        trial: trial index in ``[0, T)``.
        out_path: image file (``.png``, ``.pdf``, ``.svg``); default
            ``run_dir/snapshot_step{step}.png``.
        grid: heat-map grid points along the longer side, in [2, 1000].

    Returns:
        The path written.

    Raises:
        InputError: bad run directory, trial, step, grid, extension or an
            unwritable ``out_path`` (all checked before drawing).
    """
    import matplotlib.pyplot as plt

    out_path = Path(out_path or Path(run_dir) / f"snapshot_step{step}.png")
    if out_path.suffix.lower() not in FORMATS:
        raise InputError(f"--out = {str(out_path)!r}: extension must be .png, .pdf or .svg")
    if not 2 <= grid <= 1000:
        raise InputError(f"--grid = {grid}: must be in [2, 1000]")
    tr = load_trial(run_dir, trial)
    if not 1 <= step <= tr.steps:
        raise InputError(f"--step = {step}: must be in [1, {tr.steps}]")
    check_writable(out_path, "--out")
    fig = snapshot_figure(tr, step - 1, grid)
    fmt = out_path.suffix.lower().lstrip(".")
    try:
        atomic_write(out_path, lambda tmp: fig.savefig(tmp, dpi=110, format=fmt))
    finally:
        plt.close(fig)
    return out_path
