"""The associator door: register_associator checks the plug-in in one line, a registered
associator drives the per-target bank and the managed track table, and the example's
auction (examples/_auction.py) finds the least-cost assignment of scipy's
linear_sum_assignment."""

from __future__ import annotations

import sys
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

import mjx_radar
from mjx_radar import env as radar_env
from mjx_radar.contracts import PluginError
from mjx_radar.env import scan, trackers
from mjx_radar.io.checks import ScenarioError
from mjx_radar.registry import ASSOCIATORS
from mjx_radar.scenario.reader import load_scenario
from mjx_radar.task.task import build

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "examples"))
from _auction import BIG, assign, auction_associator  # noqa: E402


@pytest.fixture
def cleanup():
    yield
    for name in ("door_a", "door_boom", "door_shape", "auction"):
        mjx_radar.unregister_associator(name)


@pytest.fixture(scope="module")
def clutter():
    return mjx_radar.load_scenario("clutter_3r4t")


@pytest.mark.parametrize("seed", range(12))
def test_auction_is_the_least_cost_assignment(seed):
    """Tracks x (returns + one private miss column each): the auction's total equals
    linear_sum_assignment's within K eps, and so does its assignment (gaps > K eps)."""
    rng = np.random.default_rng(seed)
    k, ell, gate = int(rng.integers(1, 6)), int(rng.integers(0, 8)), 9.0
    d2 = rng.uniform(0.0, 14.0, (k, ell))
    d2 = np.where(d2 < gate, d2, BIG)  # outside the gate
    miss = np.where(np.eye(k, dtype=bool), gate, BIG)
    cost = np.concatenate([d2, miss], axis=1)
    col = np.asarray(jax.jit(assign)(jnp.asarray(cost, jnp.float32)))
    rows, ref = linear_sum_assignment(cost)
    assert sorted(set(col)) == sorted(col) and (col >= 0).all()  # a matching
    best = cost[rows, ref].sum()
    assert cost[np.arange(k), col].sum() <= best + k * 1e-3 + 1e-4
    np.testing.assert_array_equal(col, ref)


def test_associator_registration(cleanup):
    with pytest.raises(TypeError, match="associator 'door_a': a class or function, not dict"):
        mjx_radar.register_associator("door_a", {"associate": None})
    with pytest.raises(PluginError, match=r"^associator 'door_a': the factory .* \(task, par"):
        mjx_radar.register_associator("door_a", lambda task: None)
    with pytest.raises(ValueError, match="a built-in associator"):
        mjx_radar.register_associator("GNN", lambda task, params: None)
    mjx_radar.register_associator("door_a", auction_associator)
    assert ASSOCIATORS.key(("door_a",))[0][0] == "door_a"  # its code: the cache key


def test_an_associator_without_clutter_or_a_table_is_refused(cleanup):
    mjx_radar.register_associator("door_a", auction_associator)
    smoke = mjx_radar.load_scenario("smoke")
    with pytest.raises(ScenarioError, match='^tracker.association = "door_a": needs clutter'):
        smoke.replace(tracker={"association": "door_a"})
    table = {"association": "door_a", "management": "managed"}  # the table takes it
    s = load_scenario("paper_3r4t").replace(filter={"structure": "per-target"}, tracker=table)
    assert s.tracker.association == "door_a" and not s.detection.clutter


def _update(s):
    """The composed tracker's update of one cluttered scan (one jitted call: eagerly,
    each of its small ops compiles on its own)."""
    task, params = build(s, "stationary")
    ops = trackers.make(task, params)
    n, m, cap = task.fleet.n_radars, task.n_targets, s.detection.max_false_alarms
    mean = jnp.asarray(np.asarray(s.target_init, np.float32).reshape(-1))
    cov = jnp.eye(6 * m, dtype=jnp.float32)
    angle = 2 * np.pi * np.arange(n) / n
    radar = jnp.asarray(
        np.stack([600 * np.cos(angle), 600 * np.sin(angle), 0 * angle], 1), jnp.float32
    )
    truth = mean.reshape(m, 6)[:, :3]
    z = task.measurement.predict(radar, truth).reshape(n, m, -1)  # [N, M, dim] noiseless
    zs = jnp.concatenate([z, jnp.full((n, cap, z.shape[-1]), 5e3, z.dtype)], axis=1)
    valid = jnp.arange(m + cap)[None, :].repeat(n, 0) < m
    sc = scan.Scan(None, jnp.int32(n * m), jnp.int32(n * m), jnp.int32(0), zs, valid)
    return jax.jit(ops.update)(mean, cov, (), z, radar, sc, None), mean


def test_a_factory_or_associate_that_breaks_the_contract_is_one_line(clutter, cleanup):
    mjx_radar.register_associator("door_boom", lambda task, params: task.no_such_field)
    s = clutter.replace(tracker={"association": "door_boom"})
    with pytest.raises(PluginError, match=r"associator 'door_boom': factory\(\) raised Attr"):
        radar_env.make(s)

    def shape(task, params):
        return lambda means, covs, live, zs, valid, r: (means, covs, jnp.zeros(3))

    mjx_radar.register_associator("door_shape", shape)
    s = clutter.replace(tracker={"association": "door_shape"})
    with pytest.raises(
        PluginError, match=r"^associator 'door_shape': associate\(\) returned a nll"
    ):
        _update(s)


def test_a_registered_associator_drives_the_bank(clutter, cleanup):
    """Noiseless returns at the truth, clutter far away: the auction assigns each drone
    its own return, as the built-in GNN bank (a second implementation: enumerated joint
    events), so both give the same Kalman updates; the means stay at the truth."""
    mjx_radar.register_associator("auction", auction_associator)
    (mean, cov, _), truth = _update(clutter.replace(tracker={"association": "auction"}))
    (mean_g, cov_g, _), _ = _update(clutter.replace(tracker={"association": "gnn"}))
    np.testing.assert_allclose(mean, truth, atol=1e-3)
    np.testing.assert_allclose(cov, cov_g, atol=1e-5)  # float32 round-off of P - K S K'
    xy = np.asarray(jnp.diag(cov)).reshape(-1, 6)[:, :2]
    assert (xy < 0.99).all()  # every drone updated (P = I before; radars on the ground)


@pytest.mark.slow  # a closed-loop compile (~1 min on CPU); CI runs the bank's loop
def test_the_example_drives_the_managed_table(clutter, cleanup):
    """The example's associator in the managed track table's closed loop (1 trial, 8
    steps; the bank's loop: tests/test_examples.py::test_custom_associator)."""
    mjx_radar.register_associator("auction", auction_associator)
    s = clutter.replace(
        mpc={"rollout": "analytic"},
        tracker={"association": "auction", "management": "managed", "max_tracks": 6},
    )
    run = mjx_radar.simulate(s, "stationary", trials=1, steps=8, seed=0, progress=False)
    assert np.isfinite(run.summary()["rmse_pos"])
