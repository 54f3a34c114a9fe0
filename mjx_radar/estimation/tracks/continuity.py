"""Track continuity from the per-step GOSPA assignments: label switches and broken tracks.

Input: the assignment ``a[t, k, i]`` of each truth i at step k of trial t (the
estimate, i.e. the track slot, it is assigned to with ``d < c`` in the optimal GOSPA
assignment, :func:`mjx_radar.estimation.tracks.gospa.set_metrics`; -1 when unassigned), the
truths' presence and the tracks' existence. Events per trial and step (their sums
over the steps are the per-trial counts):

* **label switch** (track-centric): track j is assigned at step k to truth i, and the
  last truth it was assigned to (at any earlier step of its life, unassigned steps
  skipped) is another truth ``i' != i``. The memory is cleared while the track does
  not exist (a slot reused by a new track starts afresh). Two tracks that swap their
  truths count two switches.
* **broken track** (truth-centric): truth i is present at steps k − 1 and k, assigned
  to track j at k − 1, and at k assigned to another track or to none (a track lost, a
  swap, a coalescence onto a neighbour). A track regained later is no new break.

Stone Soup's GOSPA switching term (``GOSPAMetric.switching_penalty``) counts related
changes of the truth-to-track map (half for a change to or from "unassigned", one for a
change between two tracks); tests/test_gospa.py checks the assignments against it.
"""

from __future__ import annotations

import numpy as np

__all__ = ["continuity_events"]


def continuity_events(assignment, present, exists) -> tuple[np.ndarray, np.ndarray]:
    """Label switches and broken tracks per trial and step.

    Args:
        assignment: ``[T, K, M]`` int, the track of each truth (-1: none).
        present: ``[T, K, M]`` bool, truths present.
        exists: ``[T, K, J]`` bool, tracks existing (J track slots).

    Returns:
        ``(label_switches [T, K], broken_tracks [T, K])`` event counts (int64); step 0
        has none.
    """
    a = np.asarray(assignment, np.int64)
    here, alive = np.asarray(present, bool), np.asarray(exists, bool)
    t, k, m = a.shape
    j = alive.shape[-1]
    prev = a[:, :-1]
    keep = here[:, 1:] & here[:, :-1] & (prev >= 0)
    broken = np.zeros((t, k), np.int64)
    broken[:, 1:] = (keep & (a[:, 1:] != prev)).sum(-1)
    # the truth of each track at each step: the inverse of the assignment
    owner = np.full((t, k, j + 1), -1, np.int64)  # slot j: the "unassigned" bin
    tt, kk, ii = np.meshgrid(np.arange(t), np.arange(k), np.arange(m), indexing="ij")
    slot = np.where(a >= 0, a, j)
    owner[tt, kk, slot] = ii
    owner = owner[..., :j]
    switches = np.zeros((t, k), np.int64)
    last = np.full((t, j), -1, np.int64)
    for step in range(k):
        now = owner[:, step]
        last = np.where(alive[:, step], last, -1)
        switches[:, step] = ((now >= 0) & (last >= 0) & (now != last)).sum(-1)
        last = np.where(now >= 0, now, last)
    return switches, broken
