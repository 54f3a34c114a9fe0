"""Writes the bundled terrain tile ``scenarios/terrain/hills.png`` (no downloads).

A 41 x 41 grid over 1600 m x 1600 m (40 m cells), heights in metres:

* a north-south ridge along ``x = 220 + 0.2 y`` (Gaussian cross-section, sigma 50 m,
  crest 75 m, with a saddle down to ~30 m around y = -200): it blocks lines of sight
  from radars west of it to drones east of it at low elevation, and its flanks (up
  to ~42 deg) are steeper than the default vehicle limit of 25 deg;
* a round hill of 45 m (sigma 110 m) at (-300, 280);
* a gentle undulation of +-6 m.

Stored as a 16-bit grayscale PNG with the heights divided by ``SCALE`` (the
scenario's ``terrain.height_scale``); row 0 of the image is the north edge.
Run: ``python scripts/make_terrain_tile.py [OUT.png]``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

EXTENT = 1600.0  # m, both sides
NODES = 41
SCALE = 100.0  # m per full 16-bit code: heights must stay below it


def heights() -> np.ndarray:
    """``[ny, nx]`` heights [m], row 0 at y = -EXTENT / 2 (south)."""
    c = np.linspace(-EXTENT / 2, EXTENT / 2, NODES)
    x, y = np.meshgrid(c, c)  # [ny, nx]
    crest = 75.0 - 45.0 * np.exp(-0.5 * ((y + 200.0) / 120.0) ** 2)  # saddle near y = -200
    ridge = crest * np.exp(-0.5 * ((x - 220.0 - 0.2 * y) / 50.0) ** 2)
    hill = 45.0 * np.exp(-0.5 * ((x + 300.0) ** 2 + (y - 280.0) ** 2) / 110.0**2)
    wave = 6.0 * np.sin(x / 170.0) * np.cos(y / 230.0) + 6.0
    return ridge + hill + wave


def main(out: Path) -> None:
    from PIL import Image

    h = heights()
    assert h.min() >= 0.0 and h.max() < SCALE, (h.min(), h.max())
    codes = np.round(h / SCALE * 65535.0).astype(np.uint16)[::-1]  # image rows north first
    Image.fromarray(codes).save(out)  # uint16: mode "I;16"
    print(f"{out}: {h.shape[1]} x {h.shape[0]} nodes, heights {h.min():.1f} to {h.max():.1f} m")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else
         Path(__file__).resolve().parents[1] / "scenarios" / "terrain" / "hills.png")  # fmt: skip
