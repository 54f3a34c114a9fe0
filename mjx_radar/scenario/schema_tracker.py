"""The ``[tracker]`` table of a scenario: multi-target tracking options (docs/tracking.md).

Part of :mod:`mjx_radar.scenario.schema` (re-exported there as ``config.TrackerConfig``).
``association`` picks how the per-target bank shares a cluttered scan between the drones
(issue 35): the per-target PDA (today's default), JPDA or GNN; the other fields are the
JPDA's and GNN's options. Every field is static (part of the compiled shape). Cross-field
rules (joint association needs clutter; the enumeration's size; JPDA* needs the exact
marginals) are in :mod:`mjx_radar.scenario.plausibility`. New tracking options (track
management) belong here too: one field each, with its rule in the metadata.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from mjx_radar.io.checks import choice, flag, rule

MAX_EVENTS = 50_000  # joint events (G + 1)^M of the exact enumeration and GNN
MAX_STAR_WORK = 500_000  # events x M! target permutations of JPDA*


@dataclass(frozen=True)
class TrackerConfig:
    """Data association of cluttered scans (docs/tracking.md).

    ``association``: "pda" (each target on its own: the neighbours' returns count as
    clutter), "jpda" (joint probabilistic data association over all targets, per radar
    and scan) or "gnn" (global nearest neighbour: the best joint assignment, hard).
    ``marginals``: JPDA's marginals, "exact" (enumeration of the joint events over each
    target's ``candidates`` best gated measurements) or "lbp" (loopy belief propagation,
    ``lbp_iterations`` sweeps, over every measurement). ``jpda_star``: JPDA* (Blom &
    Bloem), which keeps only the most probable of joint events that are permutations of
    each other, against track coalescence. Used only with clutter
    (``[detection] clutter_density > 0``); without clutter the returns are labelled.
    """

    association: str = field(
        default="pda",
        metadata=choice(
            "pda",
            "jpda",
            "gnn",
            doc="association of cluttered scans: per-target PDA, joint JPDA, or GNN assignment",
        ),
    )
    marginals: str = field(
        default="exact",
        metadata=choice(
            "exact", "lbp", doc="jpda: exact (enumerated events) or lbp (loopy belief propagation)"
        ),
    )
    jpda_star: bool = field(
        default=False,
        metadata=flag("jpda, exact: JPDA* (keep the best of permuted events; no coalescence)"),
    )
    candidates: int = field(
        default=4,
        metadata=rule(int, 1, 16, doc="jpda exact, gnn: gated measurements per target, G"),
    )
    lbp_iterations: int = field(
        default=20, metadata=rule(int, 1, 1000, doc="jpda lbp: message-passing sweeps")
    )
