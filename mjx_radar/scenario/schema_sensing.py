"""The sensing tables of a scenario: ``[radar_equation]`` and ``[measurement]``.

Part of :mod:`mjx_radar.scenario.schema` (re-exported there), kept in its own module so
the schema stays one screenful per concern. Every field's allowed range is its metadata
(:mod:`mjx_radar.io.checks`); the radar equation's numbers are runtime arguments of the
compiled programs (``runtime``), the measurement model is part of the compiled shape.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from mjx_radar.io.checks import choice, rule, runtime
from mjx_radar.registry import SENSORS
from mjx_radar.scenario.schema_world import positive


@dataclass(frozen=True)
class RadarEquation:
    """Radar-equation parameters (SPEC §1, paper Table "Radar Equation")."""

    fc: float = field(default=1e8, metadata=positive("carrier frequency", "Hz", hi=1e12))
    loss: float = field(default=1.0, metadata=positive("general loss factor L"))
    gain_tx: float = field(default=200.0, metadata=positive("transmit gain"))
    gain_rx: float = field(default=200.0, metadata=positive("receive gain"))
    r_ref: float = field(
        default=500.0,
        metadata=rule(float, 1.0, 1e5, doc="range at which SNR equals snr_db", unit="m"),
    )
    rcs: float = field(default=1.0, metadata=positive("radar cross section", "m^2"))
    power_tx: float = field(default=1000.0, metadata=positive("transmit power", "W"))
    snr_db: float = field(
        default=-20.0, metadata=rule(float, -200.0, 200.0, doc="SNR at r_ref", unit="dB")
    )


@dataclass(frozen=True)
class MeasurementConfig:
    """Measurement model of each radar-target pair (see
    :mod:`mjx_radar.estimation.sensor.measurement`).

    ``model``: "range" (round-trip range, SPEC §1) or "range-azimuth" (range plus
    monopulse azimuth). The azimuth noise follows from the radar equation with the
    beamwidth and monopulse slope below.
    """

    model: str = field(
        default="range",
        metadata=choice(
            "range",
            "range-azimuth",
            registry=SENSORS,
            doc="measurement model (or a sensor registered with mjx_radar.register_sensor)",
        ),
    )
    beamwidth_deg: float = field(
        default=3.0, metadata=runtime(positive("3 dB beamwidth theta_3dB", "deg", hi=90.0))
    )
    monopulse_slope: float = field(
        default=1.6, metadata=runtime(positive("monopulse slope k_m", hi=10.0))
    )
