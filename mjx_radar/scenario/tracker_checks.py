"""Cross-field rules of the ``[tracker]`` table (docs/track_management.md, docs/tracking.md).

:func:`check`: the managed table's needs (its associators, M-of-N, radars, the filter);
:func:`check_mht`: the MHT's size limits. Called by :mod:`mjx_radar.scenario.plausibility`.
"""

from __future__ import annotations

import math

from mjx_radar.io.checks import ScenarioError
from mjx_radar.registry import ASSOCIATORS
from mjx_radar.scenario.schema_tracker import MAX_CHILDREN, TrackerConfig
from mjx_radar.scenario.tracker_roles import TABLE_ASSOCIATORS

__all__ = ["check", "check_mht"]


def check_mht(t: TrackerConfig, m: int) -> None:
    """The MHT's limits (``association = "mht"``, M targets): its children per radar and
    scan ``hypotheses · (candidates + 1)^M`` at most ``MAX_CHILDREN``; settling and the
    miss noise after the branching scans, settling to at most K hypotheses; label-free
    merging and the consensus estimate (M! orders) for M <= 6."""
    children = t.hypotheses * (t.candidates + 1) ** m
    if children > MAX_CHILDREN:
        raise ScenarioError(
            f"tracker.hypotheses = {t.hypotheses}: hypotheses x (candidates + 1)^M = "
            f"{children} children per radar and scan exceed {MAX_CHILDREN}; "
            f"lower it or tracker.candidates"
        )
    if t.settle_scans > 0 and not 0 < t.branch_scans <= t.settle_scans:
        raise ScenarioError(
            f"tracker.settle_scans = {t.settle_scans}: needs tracker.branch_scans in "
            f"1..{t.settle_scans} (got {t.branch_scans}); the hypotheses settle after branching"
        )
    if t.miss_noise > 0 and t.branch_scans == 0:
        raise ScenarioError(
            f"tracker.miss_noise = {t.miss_noise}: needs tracker.branch_scans >= 1 (it acts "
            f"in the soft scans that follow the branching ones)"
        )
    if t.settle_scans > 0 and t.settled_hypotheses > t.hypotheses:
        raise ScenarioError(
            f"tracker.settled_hypotheses = {t.settled_hypotheses}: must be <= "
            f"tracker.hypotheses = {t.hypotheses}"
        )
    if t.estimate != "consensus" and t.consensus_scale != TrackerConfig.consensus_scale:
        raise ScenarioError(
            f"tracker.consensus_scale = {t.consensus_scale}: read only with "
            f'tracker.estimate = "consensus" (here "{t.estimate}"); remove it'
        )
    if t.height_std == 0 and t.birth_height != TrackerConfig.birth_height:
        raise ScenarioError(
            f"tracker.birth_height = {t.birth_height}: the MHT reads it only as the altitude "
            f"prior's h0, with tracker.height_std > 0; remove it"
        )
    if t.height_scans and t.branch_scans == 0:
        raise ScenarioError(
            f"tracker.height_scans = {t.height_scans}: the MHT limits the altitude prior to "
            f"its first scans with tracker.branch_scans >= 1 (the scan counter); set it"
        )
    if t.estimate == "consensus" and m > 6:
        raise ScenarioError(
            f'tracker.estimate = "consensus": compares M! = {math.factorial(m)} target '
            f'orders for M = {m} targets; at most 6 targets (set it "best")'
        )
    if t.merge_labels and m > 6:
        raise ScenarioError(
            f"tracker.merge_labels = true: compares M! = {math.factorial(m)} target orders "
            f"for M = {m} targets; at most 6 targets (set it false)"
        )


def check(s) -> None:
    """Cross-field rules of ``[tracker]`` (a no-op unless ``management = "managed"``)."""
    t = s.tracker
    if t.management != "managed" and s.filter.tracker != "managed":
        return
    if (
        t.association not in TABLE_ASSOCIATORS
        and t.association.lower() not in ASSOCIATORS.registered()
    ):
        names = ", ".join(f'"{a}"' for a in TABLE_ASSOCIATORS)
        raise ScenarioError(
            f'tracker.association = "{t.association}": the managed tracker takes {names} '
            f"or a registered associator ({t.association} drives the per-target bank only)"
        )
    if t.association == "jpda" and t.marginals != "lbp":
        raise ScenarioError(
            f'tracker.marginals = "{t.marginals}": the managed tracker\'s JPDA takes "lbp" '
            f"(an enumeration over its max_tracks slots would be (candidates + 1)^K events)"
        )
    if t.confirm_m > t.confirm_n:
        raise ScenarioError(
            f"tracker.confirm_m = {t.confirm_m}: must be <= tracker.confirm_n = {t.confirm_n}"
        )
    if t.height_scans and not t.height_std:
        raise ScenarioError(
            f"tracker.height_scans = {t.height_scans}: read only with tracker.height_std > 0 "
            f"(the altitude pseudo-measurement it limits to young tracks); remove it"
        )
    for name in ("hit_radars", "birth_radars"):
        v = getattr(t, name)
        if v > s.n_radars:
            raise ScenarioError(f"tracker.{name} = {v}: must be <= n_radars = {s.n_radars}")
    dim = 2 if s.measurement.model == "range-azimuth" else 1
    if dim == 1 and s.n_radars < 3:
        raise ScenarioError(
            f'tracker.management = "managed": range-only births need n_radars >= 3 '
            f"(multilateration), got {s.n_radars}"
        )
    f = s.filter
    if f.structure != "per-target" or f.form != "covariance" or f.motion != "cv":
        raise ScenarioError(
            'tracker.management = "managed": needs filter.structure = "per-target", '
            f'form = "covariance", motion = "cv" (got "{f.structure}", "{f.form}", "{f.motion}")'
        )
    if f.tracker not in ("auto", "managed"):
        raise ScenarioError(
            f'tracker.management = "managed": filter.tracker must be "auto", got "{f.tracker}"'
        )
