"""Coplanar-radar z-mirror and lost-track rates with and without terrain (docs/terrain.md).

paper_4r4t (DDR-SFIM) on flat ground vs the same scenario on a gentle undulating terrain
(+-20 m, slopes below 8 deg, made here: no file needed), which gives the radars different
heights without masking lines of sight (``visible_pairs`` is printed to check that).
Mirror: a target's estimate on the other side of the ground plane than its truth
(``z_hat * z < 0``) for >= 40 consecutive filter steps (1 s), as the lost-track
detector defines it (env/track_health.py); with terrain the radars are no
longer coplanar, so the mirror of the range geometry is no longer z -> -z.

Usage: ``python benchmarks/studies/measure_terrain_mirror.py [TRIALS] [STEPS] [ROLLOUTS]``
(defaults 16, 600, analytic).
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

import mjx_radar


def undulating(path: Path) -> None:
    c = np.linspace(-800.0, 800.0, 41)
    x, y = np.meshgrid(c, c)
    h = 20.0 + 12.0 * np.sin(x / 110.0) * np.cos(y / 150.0) + 8.0 * np.sin((x + y) / 190.0)
    np.save(path, h)


def mirror_trials(run) -> np.ndarray:
    """[T] bool: some target's estimate on the wrong side of z = 0 for >= 40 steps."""
    mean = np.asarray(run.arrays["mean"])  # [T, K, 6M]
    truth = np.asarray(run.arrays["target"])  # [T, K, M, 6]
    t, k, m = truth.shape[:3]
    wrong = mean.reshape(t, k, m, 6)[..., 2] * truth[..., 2] < 0  # [T, K, M]
    run_len = np.zeros((t, m), int)
    hit = np.zeros(t, bool)
    for step in range(k):
        run_len = np.where(wrong[:, step], run_len + 1, 0)
        hit |= (run_len >= 40).any(-1)
    return hit


def main(trials: int, steps: int, rollouts: str) -> None:
    base = mjx_radar.load_scenario("paper_4r4t").replace(mpc={"rollout": rollouts})
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "undulating.npy"
        undulating(path)
        hilly = base.replace(name="paper_4r4t_terrain", terrain={
            "path": str(path), "extent_x": 1600.0, "extent_y": 1600.0})  # fmt: skip
        for s in (base, hilly):
            run = mjx_radar.simulate(s, "ddr-sfim", trials=trials, steps=steps, progress=False)
            m = run.metrics
            last = m[m.step == m.step.max()]
            z = np.asarray(run.arrays["radar"])[..., 2]
            print(
                f"{s.name}: trials {trials}, mirror {mirror_trials(run).mean():.3f}, "
                f"lost at last step {last.lost.mean():.3f}, ever lost "
                f"{m.groupby('trial').lost.max().mean():.3f}, rmse_pos median "
                f"{m.rmse_pos.median():.2f} m, visible_pairs min {m.visible_pairs.min()}, "
                f"radar z {z.min():.1f}..{z.max():.1f} m",
                flush=True,
            )


if __name__ == "__main__":
    a = [*sys.argv[1:], None, None, None]
    main(int(a[0] or 16), int(a[1] or 600), a[2] or "analytic")
