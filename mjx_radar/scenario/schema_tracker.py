"""The ``[tracker]`` table of a scenario: multi-target tracking options (docs/tracking.md,
docs/track_management.md).

Part of :mod:`mjx_radar.scenario.schema` (re-exported there as ``config.TrackerConfig``).
``association`` picks how the per-target bank shares a cluttered scan between the drones
(issue 35): the per-target PDA (today's default), JPDA or GNN, with the JPDA's and GNN's
options. ``management = "known"`` (the default) is every earlier tracker: the filter
knows how many drones exist and when each appears; ``"managed"`` runs the track table of
docs/track_management.md: tracks are born from returns no track explains, confirmed
M-of-N, deleted after missed scans or when their position covariance grows past a bound,
and the planner plans for the confirmed ones. Every field is static (part of the
compiled shape). Cross-field rules: association's in :mod:`mjx_radar.scenario.plausibility`,
management's and the MHT's in :mod:`mjx_radar.scenario.tracker_checks`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from mjx_radar.io.checks import choice, flag, rule
from mjx_radar.registry import ASSOCIATORS

MAX_EVENTS = 50_000  # joint events (G + 1)^M of the exact enumeration and GNN
MAX_STAR_WORK = 500_000  # events x M! target permutations of JPDA*
MAX_TUPLES = 4096  # (G + 1)^N radar tuples per target of the multi-sensor JPDA
MAX_CHILDREN = 1_000_000  # K (G + 1)^M children per radar and scan of the MHT
_DELETE_COV = "managed: a track whose tr P_pos exceeds this is deleted"
_VANISH = "managed: consecutive misses that delete a track no radar sees (0: off)"


@dataclass(frozen=True)
class TrackerConfig:
    """Data association of cluttered scans (docs/tracking.md).

    ``association``: "pda" (each target on its own: the neighbours' returns count as
    clutter), "jpda" (joint probabilistic data association over all targets, per radar
    and scan), "gnn" (global nearest neighbour: the best joint assignment, hard) or "mht"
    (the ``hypotheses`` most probable association histories, each a bank, kept across
    scans; the estimate is the heaviest one's; events over ``candidates`` per target).
    ``marginals``: JPDA's marginals, "exact" (enumeration of the joint events over each
    target's ``candidates`` best gated measurements) or "lbp" (loopy belief propagation,
    ``lbp_iterations`` sweeps, over every measurement) or "multisensor" (every radar's
    scan at once: a target's hypothesis is a tuple of one return or a miss per radar over
    its ``candidates`` best per radar, scored with the stacked innovation; the ``tuples``
    best per target enter the joint events). ``jpda_star``: JPDA* (Blom & Bloem), which
    keeps only the most probable of permuted joint events (no coalescence). Used only with clutter
    (``[detection] clutter_density > 0``); without clutter the returns are labelled.
    The managed track table (``management = "managed"``) takes "pda", "gnn" (the best
    joint assignment of its slots) or "jpda" with ``marginals = "lbp"`` (the joint
    marginals by belief propagation; docs/track_management.md), with or without clutter.
    """

    association: str = field(
        default="pda",
        metadata=choice(
            "pda",
            "jpda",
            "gnn",
            "mht",
            registry=ASSOCIATORS,
            doc=(
                "association of cluttered scans: per-target PDA, joint JPDA, GNN assignment, "
                "mht (the K best association histories across scans), or one registered "
                "with mjx_radar.register_associator; the managed table takes pda, gnn "
                "(its joint assignment), jpda (lbp marginals) or a registered one"
            ),
        ),
    )
    marginals: str = field(
        default="exact",
        metadata=choice(
            "exact",
            "lbp",
            "multisensor",
            doc=(
                "jpda: exact (enumerated events), lbp (loopy belief propagation) or "
                "multisensor (one return per radar per target, all radars jointly)"
            ),
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
    tuples: int = field(
        default=8,
        metadata=rule(
            int, 2, 64, doc="jpda multisensor: radar tuples kept per target, K (K^M joint events)"
        ),
    )
    hypotheses: int = field(
        default=16,
        metadata=rule(int, 1, 1024, doc="mht: global hypotheses kept across scans, K"),
    )
    merge_distance: float = field(
        default=1.0,
        metadata=rule(float, 0.0, 1e6, doc="mht: merge threshold, largest diagonal d^2 (0: off)"),
    )
    merge_screen: int = field(
        default=4,
        metadata=rule(int, 1, 64, doc="mht: children screened for merging, in units of K"),
    )
    merge_labels: bool = field(
        default=False,
        metadata=flag("mht: merge hypotheses that are label permutations of each other (M <= 6)"),
    )
    branch_scans: int = field(
        default=0,
        metadata=rule(
            int,
            0,
            100000,
            doc=(
                "mht: scans in which the hypotheses branch (0: every scan); later scans "
                "give each hypothesis JPDA's soft update, weighted by its likelihood"
            ),
        ),
    )
    settle_scans: int = field(
        default=0,
        metadata=rule(
            int,
            0,
            100000,
            doc=(
                "mht: after this many scans (>= branch_scans > 0) only the "
                "settled_hypotheses heaviest hypotheses go on (0: all K, always)"
            ),
        ),
    )
    settled_hypotheses: int = field(
        default=16,
        metadata=rule(int, 1, 1024, doc="mht: hypotheses kept after settle_scans, K2 <= K"),
    )
    miss_noise: float = field(
        default=0.0,
        metadata=rule(
            float,
            0.0,
            1e4,
            doc=(
                "mht with branch_scans: position variance [m^2] a track gains along a "
                "radar's line of sight per scan it takes none of that radar's returns, "
                "weighted P_D beta_0 (0: none)"
            ),
        ),
    )
    plan_on: str = field(
        default="best",
        metadata=choice(
            "best",
            "mixture",
            doc="mht: the planner's estimate: the heaviest hypothesis or the mixture",
        ),
    )
    estimate: str = field(
        default="best",
        metadata=choice("best", "consensus", doc="mht: the heaviest hypothesis or the consensus"),
    )
    consensus_scale: float = field(
        default=5.0,
        metadata=rule(float, 0.0, 1e5, lo_open=True, unit="m", doc="mht consensus: kernel scale s"),
    )
    management: str = field(
        default="known",
        metadata=choice(
            "known",
            "managed",
            doc=(
                "known: the filter knows the drones and when they appear; managed: a track "
                "table with birth, M-of-N confirmation and deletion (docs/track_management.md)"
            ),
        ),
    )
    max_tracks: int = field(
        default=16, metadata=rule(int, 1, 256, doc="managed: capacity K of the track table")
    )
    confirm_m: int = field(
        default=3, metadata=rule(int, 1, 30, doc="managed: hits needed in the last confirm_n scans")
    )
    confirm_n: int = field(
        default=5, metadata=rule(int, 1, 30, doc="managed: window of the M-of-N confirmation")
    )
    delete_misses: int = field(
        default=20,
        metadata=rule(int, 1, 100000, doc="managed: consecutive missed scans that delete a track"),
    )
    delete_cov: float = field(
        default=2500.0,
        metadata=rule(float, 0.0, 1e12, lo_open=True, unit="m^2", doc=_DELETE_COV),
    )
    vanish_misses: int = field(default=0, metadata=rule(int, 0, 100000, doc=_VANISH))
    hit_radars: int = field(
        default=0,
        metadata=rule(
            int,
            0,
            64,
            doc=(
                "managed: radars with a return in a track's gate for a hit "
                "(0: 3 for range, 1 for range-azimuth; at most n_radars)"
            ),
        ),
    )
    birth_radars: int = field(
        default=0,
        metadata=rule(
            int,
            0,
            64,
            doc=(
                "managed: radars whose returns must fit a new track "
                "(0: 4 for range, 1 for range-azimuth; at most n_radars)"
            ),
        ),
    )
    max_births: int = field(
        default=2, metadata=rule(int, 1, 32, doc="managed: new tracks per scan at most")
    )
    birth_height: float = field(
        default=60.0,
        metadata=rule(
            float, -1e4, 1e4, unit="m", doc="managed: height prior of a new track; h0 of height_std"
        ),
    )
    birth_height_std: float = field(
        default=100.0,
        metadata=rule(
            float, 0.0, 1e5, lo_open=True, unit="m", doc="managed: std of that height prior"
        ),
    )
    birth_speed_std: float = field(
        default=30.0,
        metadata=rule(
            float, 0.0, 1e4, lo_open=True, unit="m/s", doc="managed: velocity std of a new track"
        ),
    )
    birth_scans: int = field(
        default=1,
        metadata=rule(
            int,
            1,
            10,
            doc=(
                "managed: consecutive scans a birth candidate must fit with constant "
                "velocity before it becomes a track (1: one-scan births)"
            ),
        ),
    )
    height_std: float = field(
        default=0.0,
        metadata=rule(
            float,
            0.0,
            1e5,
            unit="m",
            doc=(
                "managed and mht: std of a per-scan pseudo-measurement of each track's height "
                "at birth_height (mht: it also weighs the hypotheses; 0: off)"
            ),
        ),
    )
    birth_shared: int = field(
        default=0,
        metadata=rule(
            int, 0, 64, doc="managed: returns of a new track that live tracks claim, at most"
        ),
    )
    height_scans: int = field(
        default=0,
        metadata=rule(
            int,
            0,
            100000,
            doc="height_std only on tracks younger than this (mht: first scans; 0: all)",
        ),
    )
    tentative_weight: float = field(
        default=0.0,
        metadata=rule(float, 0.0, 1.0, doc="managed: planner weight of tentative tracks"),
    )

    def radars_needed(self, n_radars: int, dim: int) -> tuple[int, int]:
        """``(hit_radars, birth_radars)`` with the automatic values resolved."""
        hit = self.hit_radars or (min(3, n_radars) if dim == 1 else 1)
        birth = self.birth_radars or (min(4, n_radars) if dim == 1 else 1)
        return hit, birth


#: the earlier name of the table's class (track management)
TrackManagementConfig = TrackerConfig
