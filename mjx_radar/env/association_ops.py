"""The joint-association trackers ``"jpda"`` and ``"gnn"`` (issue 35, docs/tracking.md).

Both are the per-target bank (covariance form) of :func:`mjx_radar.env.filter_ops.clutter_bank`
whose cluttered scans are shared between the targets jointly, radar after radar
(:func:`mjx_radar.estimation.data_association.jpda.update_bank`), with the options of the scenario's
``[tracker]`` table: JPDA with exact marginals over each target's ``candidates`` best
gated measurements (optionally JPDA*), loopy-BP marginals (``lbp_iterations``) or the
multi-sensor JPDA (all radars at once, ``tuples``), and GNN, the best joint assignment.
Without clutter (labelled returns) both are the bank.
"""

from __future__ import annotations

from mjx_radar.env.filter_ops import FilterOps, clutter_bank
from mjx_radar.estimation.data_association import jpda
from mjx_radar.task.task import RadarTask


def jpda_bank(task: RadarTask, params) -> FilterOps:
    """``"jpda"``: JPDA of cluttered scans (``tracker.marginals``: exact, lbp or multisensor)."""
    t = task.tracker
    assoc = jpda.rule(t.marginals, t.candidates, t.lbp_iterations, t.jpda_star, t.tuples)
    return clutter_bank(task, params, assoc)


def gnn_bank(task: RadarTask, params) -> FilterOps:
    """``"gnn"``: global nearest neighbour (the most probable joint event, hard weights)."""
    return clutter_bank(task, params, jpda.rule("gnn", task.tracker.candidates))
