"""``mjx-radar snapshot``: the paper's two-panel figure of one step of a saved run.

Left: the top-down scene at step K (radars with their trails and R2T / R2R rings,
true drones, CKF estimates with 2-sigma ellipses, MPPI samples coloured by
weight). Right: ``log det`` of the DDR standard Fisher information (SPEC §5) of a
target placed at each point of a grid over the free space, at the drones' mean
altitude, for the radar positions at step K (:func:`fim_heatmap`, JAX, vmapped
over the grid). Obstacle footprints are masked out of the heat map.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from mjx_radar.cli.args import positive_int
from mjx_radar.errors import InputError
from mjx_radar.viz.render import RADAR_RGB, TARGET_RGB, Trial, load_trial


def fim_heatmap(radar_pos, xs, ys, z, C):
    """``log det`` of the DDR SFIM of a single target at each grid point.

    Args:
        radar_pos: ``[N, 3]`` radar positions [m].
        xs: ``[G]`` grid x coordinates [m].
        ys: ``[Gy]`` grid y coordinates [m].
        z: target altitude [m] (scalar).
        C: range-noise constant of the DDR model.

    Returns:
        ``[Gy, G]`` numpy array, entry ``[i, j]`` for the target at ``(xs[j], ys[i], z)``.
    """
    import jax
    import jax.numpy as jnp

    from mjx_radar.estimation import fisher

    radar_pos = jnp.asarray(radar_pos)
    gx, gy = jnp.meshgrid(jnp.asarray(xs), jnp.asarray(ys))
    points = jnp.stack([gx, gy, jnp.full_like(gx, z)], axis=-1).reshape(-1, 1, 3)

    def one(p):
        return fisher.logdet(fisher.sfim(radar_pos, p, C)[0])

    return np.asarray(jax.jit(jax.vmap(one))(points)).reshape(gx.shape)


def _obstacle_mask(obstacles, gx, gy) -> np.ndarray:
    """True where a grid point lies inside an obstacle's footprint (box or cylinder)."""
    mask = np.zeros(gx.shape, bool)
    for obs in obstacles:
        dx, dy = gx - obs.pos[0], gy - obs.pos[1]
        if obs.kind == "cylinder":
            mask |= dx**2 + dy**2 <= obs.size[0] ** 2
        elif obs.kind == "box":
            c, s = np.cos(obs.yaw), np.sin(obs.yaw)
            u, v = c * dx + s * dy, -s * dx + c * dy
            mask |= (np.abs(u) <= obs.size[0]) & (np.abs(v) <= obs.size[1])
    return mask


def _scene_panel(ax, tr: Trial, k: int) -> None:
    from matplotlib.collections import LineCollection
    from matplotlib.patches import Circle, Ellipse

    c = tr.control_index(k)
    w = tr.sample_weight[c] / max(float(tr.sample_weight[c].max()), 1e-12)
    order = np.argsort(w)
    segs = [tr.sample_xy[c, j, :, n] for j in order for n in range(tr.radar.shape[1])]
    cols = np.repeat(w[order], tr.radar.shape[1])
    lines = LineCollection(segs, array=cols, cmap="plasma", linewidths=0.8, alpha=0.8, zorder=2)
    ax.add_collection(lines)
    trail = tr.trail(k)
    for n, (x, y) in enumerate(tr.radar[k, :, :2]):
        rgb = RADAR_RGB[n % len(RADAR_RGB)]
        ax.add_patch(Circle((x, y), tr.meta["r2t"], fill=False, ec="tab:red", lw=0.8, ls="--"))
        ax.add_patch(Circle((x, y), tr.meta["r2r"], fill=False, ec="k", lw=0.8))
        ax.plot(trail[:, n, 0], trail[:, n, 1], color=rgb, lw=1.5, zorder=3)
        ax.plot(x, y, "s", color=rgb, ms=8, mec="k", zorder=4, label="radar" if n == 0 else None)
    for m in range(tr.target.shape[1]):
        rgb = TARGET_RGB[m % len(TARGET_RGB)]
        (ex, ey), (sx, sy) = tr.mean[k, m, :2], tr.sigma[k, m, :2]
        ax.add_patch(Ellipse((ex, ey), 4 * sx, 4 * sy, fill=False, ec=rgb, lw=1.0, zorder=5))
        ax.plot(
            *tr.target[k, m, :2], "x", color=rgb, ms=7, zorder=5, label="drone" if m == 0 else None
        )  # noqa: E501
        ax.plot(
            ex, ey, "o", mfc="none", mec=rgb, ms=5, zorder=5, label="estimate" if m == 0 else None
        )  # noqa: E501
    for obs in tr.scenario.obstacles:
        ax.add_patch(Circle(obs.pos[:2], max(obs.size[:2]), color="0.4", alpha=0.5))
    ax.figure.colorbar(lines, ax=ax, label="MPPI sample weight (relative)", shrink=0.8)
    ax.legend(loc="upper left", fontsize=7)


def snapshot(run_dir, step: int, trial: int = 0, out_path=None, grid: int = 120) -> Path:
    """Writes the two-panel figure of filter step ``step`` (1-based) of one trial.

    Args:
        run_dir: a complete run directory.
        step: filter step in ``[1, K]`` (the ``step`` column of ``metrics.parquet``).
        trial: trial index in ``[0, T)``.
        out_path: image file (``.png``, ``.pdf``, ``.svg``); default
            ``run_dir/snapshot_step{step}.png``.
        grid: heat-map grid points along the longer side.

    Returns:
        The path written.

    Raises:
        InputError: bad run directory, trial or step.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tr = load_trial(run_dir, trial)
    if not 1 <= step <= tr.steps:
        raise InputError(f"--step = {step}: must be in [1, {tr.steps}]")
    out_path = Path(out_path or Path(run_dir) / f"snapshot_step{step}.png")
    k = step - 1
    lo, hi = tr.bounds()
    n_x, n_y = np.maximum(np.round(grid * (hi - lo) / np.max(hi - lo)).astype(int), 2)
    xs, ys = np.linspace(lo[0], hi[0], n_x), np.linspace(lo[1], hi[1], n_y)
    z = float(tr.target[k, :, 2].mean())
    heat = fim_heatmap(tr.radar[k, :, :3], xs, ys, z, tr.meta["noise_constant"])
    heat = np.ma.masked_where(_obstacle_mask(tr.scenario.obstacles, *np.meshgrid(xs, ys)), heat)
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.6), constrained_layout=True)
    _scene_panel(left, tr, k)
    im = right.imshow(heat, origin="lower", extent=(lo[0], hi[0], lo[1], hi[1]), cmap="viridis")
    fig.colorbar(im, ax=right, label=r"$\log\det J$ (DDR SFIM) [log m$^{-2}$]", shrink=0.8)
    right.plot(*tr.radar[k, :, :2].T, "s", color="w", mec="k", ms=7)
    right.plot(*tr.target[k, :, :2].T, "x", color="r", ms=7)
    for ax, title in ((left, "scene"), (right, f"SFIM log det at z = {z:.0f} m")):
        ax.set(xlim=(lo[0], hi[0]), ylim=(lo[1], hi[1]), xlabel="x [m]", ylabel="y [m]")
        ax.set_aspect("equal")
        ax.set_title(f"{title}, t = {(k + 1) * tr.dt:.2f} s", fontsize=10)
    out_path.parent.mkdir(parents=True, exist_ok=True)
    tmp = out_path.with_name(f".{out_path.stem}.partial{out_path.suffix}")
    try:
        fig.savefig(tmp, dpi=110, format=out_path.suffix.lstrip(".") or "png")
        tmp.replace(out_path)
    finally:
        plt.close(fig)
        tmp.unlink(missing_ok=True)
    return out_path


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("run_dir", type=Path, help="a complete run directory (mjx-radar run --out)")
    p.add_argument("--step", type=int, required=True, help="filter step K in [1, steps]")
    p.add_argument("--trial", type=int, default=0, help="trial index (default 0)")
    p.add_argument("--out", type=Path, default=None, help="image (RUN_DIR/snapshot_stepK.png)")
    p.add_argument("--grid", type=positive_int("--grid", 1000), default=120, help="heat-map grid")


def main(args) -> int:
    if args.out is not None and args.out.suffix.lower() not in (".png", ".pdf", ".svg"):
        raise InputError(f"--out = {str(args.out)!r}: extension must be .png, .pdf or .svg")
    path = snapshot(args.run_dir, args.step, args.trial, args.out, args.grid)
    print(f"wrote {path}")
    return 0
