"""Lost-track counts of a study's cells (``run.json`` / ``study.json``; docs/statistics.md).

Trial rate: the fraction of trials lost at any step ("ever lost"); step rate: the fraction
of (trial, step) pairs flagged lost. :func:`lost_by_trial` of a table's parts (a study's
chunks) concatenated gives the same :func:`lost_counts_by_cell` as the whole table.
"""

from __future__ import annotations

import numpy as np

__all__ = ["lost_by_trial", "lost_counts", "lost_counts_by_cell"]


def lost_counts(lost: np.ndarray) -> dict:
    """Lost-track counts of one scenario and method (for run.json / study.json).

    Args:
        lost: [T, K] bool per trial and step.

    Returns:
        ``{"trials": T, "trials_lost": n, "trial_rate": n / T, "step_rate": mean(lost)}``.
    """
    lost = np.asarray(lost, bool)
    return _counts(lost.shape[0], int(lost.any(axis=1).sum()), int(lost.sum()), lost.size)


def _counts(trials: int, trials_lost: int, steps_lost: int, steps: int) -> dict:
    nan = float("nan")
    return {
        "trials": trials,
        "trials_lost": trials_lost,
        "trial_rate": trials_lost / trials if trials else nan,
        "step_rate": steps_lost / steps if steps else nan,
    }


def lost_by_trial(frame):
    """Per scenario, method and trial of a long table: ``any``, ``sum``, ``size`` of ``lost``."""
    return frame.groupby(["scenario", "method", "trial"], observed=True)["lost"].agg(
        ["any", "sum", "size"]
    )


def lost_counts_by_cell(frame=None, by_trial=None) -> dict:
    """``{"SCENARIO/METHOD": lost_counts}`` of a long table (``scenario``, ``method``,
    ``trial``, ``lost`` per step, every trial with the same steps): :func:`lost_counts` of
    each cell's ``[T, K]`` table, exactly, from one grouping (not a pivot per cell); or
    of ``by_trial``, the :func:`lost_by_trial` of the table's parts concatenated."""
    agg = lost_by_trial(frame) if by_trial is None else by_trial
    cells = agg.groupby(level=[0, 1], observed=True).agg(["sum", "size"])
    cols = (("any", "size"), ("any", "sum"), ("sum", "sum"), ("size", "sum"))  # as _counts
    return {f"{sc}/{m}": _counts(*(int(c[k]) for k in cols)) for (sc, m), c in cells.iterrows()}
