"""The tracker's roles from a scenario's ``[filter]``, ``[tracker]`` and ``[detection]`` tables.

A tracker is composed of roles (docs/tracking.md, "Roles"), each picked by the options:

* the **filter form**: ``"ckf"`` (the joint CKF, ``filter.structure = "joint"``),
  ``"bank"`` (per-target CKFs, ``"per-target"``), ``"imm"`` (``filter.motion = "imm"``);
  ``filter.form`` (covariance or square root) applies to the first two;
* the **associator** of unlabelled scans, ``tracker.association``: a built-in (``pda``,
  ``jpda``, ``gnn``, ``mht``: they drive the per-target bank; ``pda``, ``gnn`` and ``jpda``
  with ``marginals = "lbp"`` also the managed track table) or one of
  :func:`mjx_radar.register_associator` (it drives both). None when the returns are
  labelled (no clutter, known drones);
* the **management**: ``"known"`` drones, or ``"managed"`` (the track table's initiator
  and deleter: births, M-of-N confirmation, deletion; docs/track_management.md).

``[filter] tracker`` names a whole registered tracker (:func:`mjx_radar.register_tracker`),
which replaces the roles; a built-in name there must be the one the options compose.
:func:`check` refuses, in one line naming the field and what is allowed, an option the
composed tracker would not read (a role's option set while another role is chosen).
Pure Python: ``mjx-radar validate`` stays light.
"""

from __future__ import annotations

import dataclasses
from typing import NamedTuple

from mjx_radar.io.checks import ScenarioError
from mjx_radar.registry import ASSOCIATORS, TRACKERS

__all__ = ["Roles", "roles", "composed", "check", "TABLE_ASSOCIATORS"]

#: the built-in associators that also drive the managed track table (registered ones do)
TABLE_ASSOCIATORS = ("pda", "gnn", "jpda")
#: ``[tracker]`` options and the associators that read them (jpda's by marginals)
_ASSOCIATION_FIELDS = {
    "marginals": ("jpda",),
    "lbp_iterations": ("jpda/lbp",),
    "tuples": ("jpda/multisensor",),
    "candidates": ("jpda/exact", "jpda/multisensor", "gnn", "mht"),
    "hypotheses": ("mht",),
    "merge_distance": ("mht",),
    "merge_screen": ("mht",),
    "merge_labels": ("mht",),
    "branch_scans": ("mht",),
    "settle_scans": ("mht",),
    "settled_hypotheses": ("mht",),
    "miss_noise": ("mht",),
    "plan_on": ("mht",),
    "estimate": ("mht",),
    "consensus_scale": ("mht",),
}
#: ``[tracker]`` options of the managed track table (initiator, deleter, table)
_MANAGED_FIELDS = (
    "max_tracks",
    "confirm_m",
    "confirm_n",
    "delete_misses",
    "delete_cov",
    "vanish_misses",
    "hit_radars",
    "birth_radars",
    "max_births",
    "birth_height_std",
    "birth_speed_std",
    "birth_scans",
    "birth_shared",
    "tentative_weight",
)
#: ``[tracker]`` options of the altitude prior, read by the managed table and the MHT
_ALTITUDE_FIELDS = ("birth_height", "height_std", "height_scans")
#: ``[filter]`` options of the IMM form
_IMM_FIELDS = ("imm_turn_rate", "imm_switch_prob")


class Roles(NamedTuple):
    """The roles a scenario's tracker is composed of (module docstring)."""

    form: str  # "ckf", "bank" or "imm"
    associator: str | None  # tracker.association, or None: labelled returns
    management: str  # "known" or "managed"
    plugin: str | None  # a registered whole tracker (filter.tracker), or None


def roles(tables) -> Roles:
    """The roles of ``tables``' ``filter``, ``tracker`` and ``detection`` tables (a
    :class:`~mjx_radar.task.task.RadarTask` or a scenario)."""
    f, t = tables.filter, tables.tracker
    plugin = f.tracker if f.tracker.lower() in TRACKERS.registered() else None
    managed = t.management == "managed" or f.tracker == "managed"
    form = "imm" if f.motion == "imm" else "bank" if f.structure == "per-target" else "ckf"
    unlabelled = tables.detection.clutter or managed
    return Roles(form, t.association if unlabelled else None, ("known", "managed")[managed], plugin)


def composed(tables) -> str:
    """The name of the tracker ``tables``' roles make (:func:`roles`): the plug-in's,
    ``"managed"``, the associator's (the per-target bank it drives) or the filter form's."""
    return _name(roles(tables))


def _name(r: Roles) -> str:
    if r.plugin is not None:
        return r.plugin
    if r.management == "managed":
        return "managed"
    return r.associator or r.form


def registered_associator(name: str | None) -> bool:
    """Whether ``name`` is an associator registered from a script (not a built-in)."""
    return name is not None and name.lower() in ASSOCIATORS.registered()


def check(s) -> None:
    """Refuses a scenario whose options the composed tracker would not all read.

    Raises:
        ScenarioError: one line naming the field, its value and what is allowed.
    """
    r = roles(s)
    name = _name(r)
    f = s.filter
    if f.tracker != "auto" and r.plugin is None and f.tracker != name:
        raise ScenarioError(
            f'filter.tracker = "{f.tracker}": the options compose "{name}" (filter.structure, '
            f"motion, [detection] clutter, [tracker] association and management); allowed: "
            f"auto, {name}, or a registered tracker"
        )
    if r.plugin is not None:  # a whole tracker of its own: it may read any option
        return
    if r.form != "imm":
        _unused(s.filter, "filter", _IMM_FIELDS, 'filter.motion = "imm"')
    if r.management != "managed":
        _unused(s.tracker, "tracker", _MANAGED_FIELDS, 'tracker.management = "managed"')
        if r.associator != "mht":
            needs = 'tracker.management = "managed" or tracker.association = "mht"'
            _unused(s.tracker, "tracker", _ALTITUDE_FIELDS, needs)
    if registered_associator(r.associator):  # it may read any association option
        return
    assoc = r.associator or ""
    if assoc == "gnn" and r.management == "managed":  # the table's GNN: exact, no G
        _unused(s.tracker, "tracker", ("candidates",), 'tracker.management = "known"')
    rule = f"{assoc}/{s.tracker.marginals}" if assoc == "jpda" else assoc
    for field, readers in _ASSOCIATION_FIELDS.items():
        if not any(rule.startswith(who) for who in readers):
            _unused(s.tracker, "tracker", (field,), " or ".join(map(_who, readers)))


def _unused(table, label: str, fields, needs: str) -> None:
    """Refuses a non-default value of ``fields`` of ``table`` (read only with ``needs``)."""
    defaults = {fl.name: fl.default for fl in dataclasses.fields(table)}
    for name in fields:
        value = getattr(table, name)
        if value != defaults[name]:
            raise ScenarioError(
                f"{label}.{name} = {_toml(value)}: read only with {needs}; here it would be "
                f"ignored: remove it (default {_toml(defaults[name])})"
            )


def _who(reader: str) -> str:
    assoc, _, marginals = reader.partition("/")
    out = f'tracker.association = "{assoc}"'
    return f'{out} (marginals = "{marginals}")' if marginals else out


def _toml(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    return f'"{value}"' if isinstance(value, str) else repr(value)
