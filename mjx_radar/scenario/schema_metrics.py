"""The ``[metrics]`` table of a scenario (issue 35): GOSPA / OSPA settings.

Part of :mod:`mjx_radar.scenario.schema` (re-exported there as ``config.MetricsConfig``).
Host settings (:func:`mjx_radar.io.checks.host`): the metrics are computed on the host
after the run (:func:`mjx_radar.rundir.results.set_columns`), so changing them
recompiles nothing and leaves every other number of a run unchanged.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from mjx_radar.io.checks import host, rule


@dataclass(frozen=True)
class MetricsConfig:
    """GOSPA / OSPA cutoff and order (docs/tracking_metrics.md).

    ``gospa_cutoff = 50 m``: the lost-track detector's error floor
    (:class:`mjx_radar.env.track_health.HealthConfig` ``error_floor_m``), 4x the initial
    position spread ``sqrt(tr P0_pos) ≈ 12 m`` and about the spread of the paper's initial
    drone positions: an estimate within c of a drone counts as localisation error, one
    farther as a missed drone plus a false track (c^p/2 each). ``gospa_order = 1``: the
    parts add up to GOSPA in metres (p = 2 would weight large errors like an RMSE).
    """

    gospa_cutoff: float = field(
        default=50.0,
        metadata=host(
            rule(
                float,
                0.0,
                1e5,
                lo_open=True,
                unit="m",
                doc="GOSPA / OSPA cutoff c: the most one target or track can cost",
            )
        ),
    )
    gospa_order: float = field(
        default=1.0,
        metadata=host(rule(float, 1.0, 10.0, doc="GOSPA / OSPA order p (1: parts in metres)")),
    )
