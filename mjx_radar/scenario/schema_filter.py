"""The ``[filter]`` table of a scenario: the tracking filter and its options.

Part of :mod:`mjx_radar.scenario.schema` (re-exported there as ``config.FilterConfig``), kept in
its own module so the configuration stays one screenful per concern. Every field's
allowed range is its metadata (:mod:`mjx_radar.io.checks`); cross-field rules (the IMM
needs the per-target bank in the covariance form, no clutter) are in
:mod:`mjx_radar.scenario.plausibility`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from mjx_radar.io.checks import choice, flag, rule
from mjx_radar.registry import TRACKERS


@dataclass(frozen=True)
class FilterConfig:
    """The tracking filter (SPEC §4 and its options).

    ``structure``: "joint" (the paper's one CKF over all 6M dimensions) or "per-target"
    (M independent 6-D CKFs, :mod:`mjx_radar.estimation.filters.filter_bank`: the natural filter
    for independent targets measured separately; it differs in the cubature rule only).
    ``ground_prior``: reflect a target's estimate to z >= 0 after each update
    (:mod:`mjx_radar.estimation.filters.ground_prior`; drones fly above the radars' ground
    plane). Off for the paper's reproduction.
    ``form``: "covariance" (the paper's CKF) or "sqrt"
    (:mod:`mjx_radar.estimation.filters.ckf_sqrt`).
    ``motion``: the per-target motion model, "cv" (the paper's) or "imm": an interacting
    multiple model of CV and coordinated turns at ``±imm_turn_rate`` in the horizontal
    plane with mode-switch probability ``imm_switch_prob`` per second
    (:mod:`mjx_radar.estimation.filters.imm`, docs/filters.md; static: part of the compiled shape).
    """

    structure: str = field(
        default="joint", metadata=choice("joint", "per-target", doc="filter structure")
    )
    ground_prior: bool = field(default=False, metadata=flag("reflect estimates to z >= 0"))
    form: str = field(
        default="covariance",
        metadata=choice(
            "covariance",
            "sqrt",
            doc="CKF form: covariance P, or square-root S (P = S S^T; docs/filters.md)",
        ),
    )
    motion: str = field(
        default="cv",
        metadata=choice(
            "cv",
            "imm",
            doc=(
                "per-target motion model: CV, or an IMM of CV and coordinated turns at "
                "+-imm_turn_rate (needs structure = per-target; docs/filters.md)"
            ),
        ),
    )
    imm_turn_rate: float = field(
        default=0.4,
        metadata=rule(
            float,
            0.0,
            10.0,
            unit="rad/s",
            doc="IMM: turn rate w of the two coordinated-turn modes (+w, -w; horizontal plane)",
        ),
    )
    imm_switch_prob: float = field(
        default=0.2,
        metadata=rule(
            float,
            0.0,
            1.0,
            doc="IMM: probability of leaving the current mode within one second (Markov chain)",
        ),
    )
    tracker: str = field(
        default="auto",
        metadata=choice(
            "auto",
            registry=TRACKERS,
            doc=(
                "the tracker: auto (composed from the options above, [detection] and "
                "[tracker]: docs/tracking.md, Roles), the built-in name they compose, or one "
                "registered with mjx_radar.register_tracker"
            ),
        ),
    )
