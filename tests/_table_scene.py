"""A track-table scene shared by the associator tests (tests/test_managed_*.py).

raid_4r8t managed (no clutter): a drone's track A at the drone, a second track B
``ghost_x`` metres beside it, an empty slot; each radar's noiseless return of the drone
and one more return far from both. The associators' arguments do not depend on which
association the scenario names, so one build serves every associator.
"""

from __future__ import annotations

import functools

import jax.numpy as jnp
import numpy as np

from mjx_radar.estimation.sensor import clutter
from mjx_radar.scenario.reader import load_scenario
from mjx_radar.task.task import build

MANAGED_GNN = {"management": "managed", "association": "gnn", "max_tracks": 6}
PER_TARGET = {"structure": "per-target", "ground_prior": True}


@functools.cache
def _task():
    s = load_scenario("raid_4r8t").replace(tracker=MANAGED_GNN, filter=PER_TARGET)
    return s, *build(s, "stationary")


def table_scene(ghost_x: float = 12.0):
    """``((means, covs, on, zs, valid, radar), args)``: the associator's inputs and the
    arguments its builder takes (``track_update.pda_associator`` and its twins)."""
    s, task, params = _task()
    n = task.fleet.n_radars
    angle = 2 * np.pi * np.arange(n) / n
    radar = jnp.asarray(np.stack([500 * np.cos(angle), 500 * np.sin(angle), 0 * angle], 1))
    radar = radar.astype(jnp.float32)
    z = task.measurement.predict(radar, jnp.array([[0.0, 0.0, 60.0]])).reshape(n, 1, -1)
    far = task.measurement.predict(radar, jnp.array([[900.0, 900.0, 60.0]])).reshape(n, 1, -1)
    zs, valid = jnp.concatenate([z, far], 1), jnp.ones((n, 2), bool)
    means = jnp.array([[0.0, 0, 60, 0, 0, 0], [ghost_x, 0, 60, 0, 0, 0], [0.0] * 6])
    covs = jnp.stack([jnp.diag(jnp.array([400.0, 400, 400, 25, 25, 25]))] * 3)
    on = jnp.array([True, True, False])  # slot 2 empty
    dp = params.detection
    density = clutter.density(dp, task.measurement.dim) if s.detection.clutter else 1e-6
    args = (task.measurement, params.noise, params.method.ccr, task.detection.model, dp)
    args = (*args, density, dp.gate, dp.gate_probability, False)
    return (means, covs, on, zs, valid, radar), args
