"""The fixed random streams of a trial (common random numbers, SPEC §9).

A trial's key is ``fold_in(PRNGKey(seed), trial)`` split into five streams, so every
method sees the same placement, initial estimate error, drone noise, measurement
noise and planner draws.
"""

from __future__ import annotations

from typing import NamedTuple

import jax


class TrialStreams(NamedTuple):
    placement: jax.Array
    estimate: jax.Array
    drones: jax.Array
    measurement: jax.Array
    planner: jax.Array


def trial_streams(seed: int, trial) -> TrialStreams:
    """The fixed random streams of one trial (identical for every method)."""
    key = jax.random.fold_in(jax.random.PRNGKey(seed), trial)
    return TrialStreams(*jax.random.split(key, 5))
