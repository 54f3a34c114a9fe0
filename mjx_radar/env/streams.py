"""The fixed random streams of a trial (common random numbers, SPEC §9).

A trial's key is ``fold_in(PRNGKey(seed), trial)`` split into five streams (plus the
detection streams of issue 23, folded in separately), so every
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


def trial_key(seed, trial) -> jax.Array:
    """The key of trial ``trial`` of base seed ``seed``: ``fold_in(PRNGKey(seed), trial)``.

    The environment's ``reset(key)`` takes it: every stream of the trial derives from it.
    """
    return jax.random.fold_in(jax.random.PRNGKey(seed), trial)


def streams_of(key) -> TrialStreams:
    """The five fixed streams of the trial whose key is ``key`` (:func:`trial_key`)."""
    return TrialStreams(*jax.random.split(key, 5))


def trial_streams(seed: int, trial) -> TrialStreams:
    """The fixed random streams of one trial (identical for every method)."""
    return streams_of(trial_key(seed, trial))


DETECTION_TAG = 0xDE7EC7  # fold_in tag of the detection streams (the five above unchanged)


class DetectionStreams(NamedTuple):
    detection: jax.Array  # Uniform draws of the detections, fold_in(., step)
    clutter: jax.Array  # false-alarm counts and positions, fold_in(., step)


def detection_streams_of(key) -> DetectionStreams:
    """The detection and clutter streams of the trial whose key is ``key``."""
    return DetectionStreams(*jax.random.split(jax.random.fold_in(key, DETECTION_TAG), 2))


def detection_streams(seed: int, trial) -> DetectionStreams:
    """The detection and clutter streams of one trial (issue 23).

    Derived by ``fold_in`` of the trial key with :data:`DETECTION_TAG`, so the five
    streams of :func:`trial_streams` -- and every number of a run without detection --
    stay exactly as they were (common random numbers across methods as well).
    """
    return detection_streams_of(trial_key(seed, trial))
