"""The ``[terrain]`` table's dataclass (docs/terrain.md); re-exported by
:mod:`mjx_radar.scenario.schema`.

Kept apart from :mod:`mjx_radar.scenario.schema` only for its size; the rules are field metadata
as everywhere (:mod:`mjx_radar.io.checks`), read by :mod:`mjx_radar.scenario.terrain`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from mjx_radar.io.checks import flag, rule


def positive(doc: str, unit: str = "", hi: float = float("inf")) -> dict:
    """Metadata of a float in (0, hi]."""
    return rule(float, 0.0, hi, lo_open=True, doc=doc, unit=unit)


@dataclass(frozen=True)
class Terrain:
    """A height field the radars drive on (docs/terrain.md); the ``[terrain]`` table.

    ``path``: a ``.npy`` array ``[ny, nx]`` (float or integer heights h = height_scale *
    value, row 0 at y = -extent_y / 2, column 0 at x = -extent_x / 2) or a grayscale PNG
    (8- or 16-bit; h = height_scale * value / max code, the image's top row is north).
    The grid is centred on the origin; outside it the edge heights continue. Read and
    checked by :mod:`mjx_radar.scenario.terrain`; absent = the flat ground z = 0.
    """

    path: str = ""
    extent_x: float = field(default=1000.0, metadata=positive("x side of the grid", "m", hi=2e5))
    extent_y: float = field(default=1000.0, metadata=positive("y side of the grid", "m", hi=2e5))
    height_scale: float = field(
        default=1.0, metadata=positive("metres per unit of the file (PNG: per full code)", "m", 1e4)
    )
    max_slope_deg: float = field(
        default=25.0,
        metadata=rule(
            float,
            0.0,
            90.0,
            lo_open=True,
            doc="steepest slope a radar drives on (keep-out beyond; the plant stops a radar there)",
            unit="deg",
        ),
    )
    alpha_slope: float = field(
        default=1000.0,
        metadata=rule(
            float,
            0.0,
            1e9,
            doc="planner weight of slope beyond the limit (per unit of grade, per radar and step)",
        ),
    )
    antenna_height: float = field(
        default=2.0,
        metadata=rule(float, 0.0, 100.0, doc="radar antenna above the ground point", unit="m"),
    )
    targets_agl: bool = field(
        default=False,
        metadata=flag(
            "target start z is height above the terrain (false: absolute z; a "
            "target starting below the terrain is refused)"
        ),
    )
