"""The managed table's altitude pseudo-measurement (``[tracker] height_std``).

References: numpy's matrix Kalman update ``x + P Hᵀ (H P Hᵀ + R)⁻¹ (z − H x)`` in
float64, and the Kalman–Bucy steady state of a double integrator (closed form).
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.linalg import solve_discrete_are

from mjx_radar.env import managed
from mjx_radar.estimation.tracks import altitude, track_table
from mjx_radar.io.checks import ScenarioError
from mjx_radar.scenario.reader import load_scenario
from mjx_radar.task.task import build


def _random_spd(rng, n):
    a = rng.normal(size=(n, n))
    return a @ a.T + n * np.eye(n)


def test_height_update_matches_matrix_kalman():
    rng = np.random.default_rng(1)
    k = 5
    mean = rng.normal(0.0, 50.0, (k, 6)).astype(np.float32).astype(np.float64)
    cov = np.stack([_random_spd(rng, 6) * 10.0 for _ in range(k)]).astype(np.float32)
    cov = cov.astype(np.float64)
    on = np.array([True, True, False, True, True])
    h0, var = 60.0, 30.0**2
    m, p = altitude.height_update(jnp.asarray(mean), jnp.asarray(cov), jnp.asarray(on), h0, var)
    H = np.zeros((1, 6))
    H[0, 2] = 1.0
    for i in range(k):
        if not on[i]:  # an empty slot is left alone
            np.testing.assert_array_equal(np.asarray(m[i]), mean[i])
            np.testing.assert_array_equal(np.asarray(p[i]), cov[i])
            continue
        S = H @ cov[i] @ H.T + var
        G = cov[i] @ H.T @ np.linalg.inv(S)
        ref_m = mean[i] + (G @ (np.array([h0]) - H @ mean[i])).ravel()
        ref_p = (np.eye(6) - G @ H) @ cov[i]
        # float32 against float64: |x| ~ 1e2, P ~ 1e2
        np.testing.assert_allclose(np.asarray(m[i]), ref_m, rtol=0, atol=1e-3)
        np.testing.assert_allclose(np.asarray(p[i]), ref_p, rtol=1e-4, atol=1e-3)


def test_steady_state_height_variance_is_the_riccati_solution():
    """Repeated every scan after a CV prediction, the height variance settles at the
    discrete algebraic Riccati equation's solution (scipy), ≈ the continuous closed form
    √2 q^{1/4} (σ_a² Δt)^{3/4} of the module docstring (17 m at σ_a = 150 m)."""
    dt, q, sa = 0.025, 10.0, 150.0
    q2 = q * np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
    ref = solve_discrete_are(np.array([[1.0, 0.0], [dt, 1.0]]), [[1.0], [0.0]], q2, [[sa**2]])
    a = np.eye(6)
    a[2, 5] = dt
    q6 = np.zeros((6, 6))
    q6[np.ix_([2, 5], [2, 5])] = q2
    a, q6 = jnp.asarray(a, jnp.float32), jnp.asarray(q6, jnp.float32)
    on = jnp.ones(1, bool)

    def scan(carry, _):
        m, p = carry
        p = a @ p @ a.T + q6
        pred = p[0, 2, 2]
        m, p = altitude.height_update(m, p, on, 60.0, sa**2)
        return (m, p), pred

    start = (jnp.zeros((1, 6)), 1e4 * jnp.eye(6)[None])
    _, pred = jax.jit(lambda c: jax.lax.scan(scan, c, None, length=6000))(start)
    # float32 sums of Q (1e-5 m² a scan) into P (~300 m²): 1 % is the precision
    assert abs(float(pred[-1]) / ref[0, 0] - 1.0) < 0.01
    closed = np.sqrt(2.0) * q**0.25 * (sa**2 * dt) ** 0.75
    assert abs(np.sqrt(ref[0, 0]) / np.sqrt(closed) - 1.0) < 0.01


def test_height_std_is_validated_and_managed_only():
    sc = load_scenario("raid_4r8t")
    with pytest.raises(ScenarioError, match="height_std"):
        sc.replace(tracker={"management": "managed", "height_std": -1.0})
    with pytest.raises(ScenarioError, match="height_std"):  # read only by the managed table
        sc.replace(tracker={"height_std": 50.0})


def test_managed_tracker_applies_it_after_the_prediction():
    """``[tracker] height_std`` reaches the managed tracker: a live slot's predicted
    height is pulled to birth_height by the scalar update; empty slots and the default
    (off) are untouched."""
    sc = load_scenario("raid_4r8t").replace(
        filter={"structure": "per-target", "ground_prior": True},
        tracker={"management": "managed", "max_tracks": 3, "height_std": 40.0},
    )
    task, params = build(sc, "stationary")
    ops = managed.managed_tracker(task, params)
    table = track_table.empty(3, 4, jnp.float32, float(params.p0))
    table = track_table.insert(
        table,
        jnp.asarray([[0.0, 500.0, 200.0, 0.0, -20.0, 0.0]] * 3, jnp.float32),
        jnp.broadcast_to(jnp.eye(6, dtype=jnp.float32) * 400.0, (3, 6, 6)),
        jnp.asarray([True, False, False]),
    )
    _, _, out = ops.predict(None, None, table)
    off = build(sc.replace(tracker={"height_std": 0.0}), "stationary")
    _, _, ref = managed.managed_tracker(*off).predict(None, None, table)
    pzz = float(ref.cov[0, 2, 2])  # the CV prediction alone
    expect = float(ref.mean[0, 2]) + pzz / (pzz + 40.0**2) * (60.0 - float(ref.mean[0, 2]))
    assert abs(float(out.mean[0, 2]) - expect) < 1e-3 and float(ref.mean[0, 2]) == 200.0
    np.testing.assert_array_equal(np.asarray(out.mean[1:]), np.asarray(ref.mean[1:]))


def test_height_scans_limits_it_to_young_tracks():
    """With ``height_scans = H`` a track of age < H takes the pseudo-measurement and an
    older one only the CV prediction (the same numbers as with height_std off)."""
    sc = load_scenario("raid_4r8t").replace(
        filter={"structure": "per-target", "ground_prior": False},
        tracker={"management": "managed", "max_tracks": 2, "height_std": 40.0},
    )
    table = track_table.insert(
        track_table.empty(2, 4, jnp.float32, 50.0),
        jnp.asarray([[0.0, 500.0, 200.0, 0.0, -20.0, 0.0]] * 2, jnp.float32),
        jnp.broadcast_to(jnp.eye(6, dtype=jnp.float32) * 400.0, (2, 6, 6)),
        jnp.asarray([True, True]),
    )
    table = table._replace(age=jnp.asarray([199, 200], jnp.int32))
    young = build(sc.replace(tracker={"height_scans": 200}), "stationary")
    always = build(sc, "stationary")
    off = build(sc.replace(tracker={"height_std": 0.0}), "stationary")
    _, _, out = managed.managed_tracker(*young).predict(None, None, table)
    _, _, every = managed.managed_tracker(*always).predict(None, None, table)
    _, _, cv = managed.managed_tracker(*off).predict(None, None, table)
    np.testing.assert_array_equal(np.asarray(out.mean[0]), np.asarray(every.mean[0]))
    np.testing.assert_array_equal(np.asarray(out.cov[0]), np.asarray(every.cov[0]))
    np.testing.assert_array_equal(np.asarray(out.mean[1]), np.asarray(cv.mean[1]))
    np.testing.assert_array_equal(np.asarray(out.cov[1]), np.asarray(cv.cov[1]))
    assert float(every.mean[0, 2]) < float(cv.mean[0, 2]) - 1.0  # it did pull the young one
    with pytest.raises(ScenarioError, match="height_scans"):
        sc.replace(tracker={"height_scans": -1})
    with pytest.raises(ScenarioError, match="height_scans = 200: read only with"):
        sc.replace(tracker={"height_scans": 200, "height_std": 0.0})
    with pytest.raises(ScenarioError, match="height_scans = 200: read only with"):  # managed
        load_scenario("raid_4r8t").replace(tracker={"height_scans": 200})
