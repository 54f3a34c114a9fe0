"""The ``[detection]`` table of a scenario (issue 23): Pd model, clutter, association.

Part of :mod:`mjx_radar.scenario.schema` (re-exported there as ``config.DetectionConfig``), kept
in its own module so the configuration stays one screenful per concern. Every field's
allowed range is its metadata (:mod:`mjx_radar.io.checks`); cross-field rules (clutter
needs the per-target filter, the per-scan cap) are in :mod:`mjx_radar.scenario.plausibility`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from mjx_radar.io.checks import choice, flag, rule, runtime


@dataclass(frozen=True)
class DetectionConfig:
    """Detection probability, false alarms and association (issue 23, docs/detection.md).

    Off by default (``model = "perfect"``, no clutter): the paper's measurements. The
    numbers are runtime parameters (:class:`mjx_radar.estimation.sensor.detection.DetectionParams`);
    the model, the clutter switch, the cap and the planner switch are static.
    """

    model: str = field(
        default="perfect",
        metadata=choice(
            "perfect",
            "swerling1",
            "fixed",
            doc="Pd: every pair detected, Swerling I square-law Pd = pfa^(1/(1+SNR)), or fixed_pd",
        ),
    )
    pfa: float = field(
        default=1e-6,
        metadata=runtime(
            rule(
                float,
                0.0,
                0.1,
                lo_open=True,
                doc="false-alarm probability of the detector (swerling1)",
            )
        ),
    )
    fixed_pd: float = field(
        default=1.0,
        metadata=rule(float, 0.0, 1.0, lo_open=True, doc="Pd of every pair (model = fixed)"),
    )
    gain_db: float = field(
        default=0.0,
        metadata=runtime(
            rule(
                float,
                -100.0,
                200.0,
                unit="dB",
                doc="detector processing gain over the radar equation's SNR (swerling1)",
            )
        ),
    )
    planner: bool = field(
        default=True,
        metadata=flag(
            "Pd-aware planning: the information costs use the expected FIM Pd*J "
            "(clutter: PDA factor)"
        ),
    )
    clutter_density: float = field(
        default=0.0,
        metadata=rule(
            float,
            0.0,
            1.0,
            unit="1/m",
            doc="false alarms per scan per radar per metre of the range window (0: no clutter)",
        ),
    )
    clutter_range_min: float = field(
        default=0.0,
        metadata=runtime(
            rule(float, 0.0, 1e5, unit="m", doc="clutter range window start (one-way range)")
        ),
    )
    clutter_range_max: float = field(
        default=1000.0,
        metadata=runtime(
            rule(float, 0.0, 1e5, unit="m", doc="clutter range window end (one-way range)")
        ),
    )
    max_false_alarms: int = field(
        default=16,
        metadata=rule(
            int, 1, 256, doc="cap on false alarms per radar per scan (buffer: M + cap measurements)"
        ),
    )
    gate_probability: float = field(
        default=0.99,
        metadata=rule(
            float, 0.5, 0.999999, doc="validation gate probability P_G (chi-square gate)"
        ),
    )

    @property
    def detects(self) -> bool:
        """Whether detections are drawn: a Pd model other than "perfect" and not
        ``fixed_pd = 1`` (every pair detected: the paper's program, bit for bit)."""
        return self.model == "swerling1" or (self.model == "fixed" and self.fixed_pd < 1.0)

    @property
    def clutter(self) -> bool:
        """Whether false alarms are drawn."""
        return self.clutter_density > 0.0
