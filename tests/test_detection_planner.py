"""Pd-aware planning: the expected Fisher information under detection (issue 23)."""

import jax
import numpy as np
import pytest

from mjx_radar.estimation.information import fisher
from mjx_radar.task import costs
from mjx_radar.task.costs import Horizon
from mjx_radar.task.task import build

H, P = 2, 12  # horizon steps, cubature points of one target


def _pair_fim(radar, target, c):
    """DDR range information of one pair (numpy float64): (4/(C r^4) + 8/r^2) u u^T."""
    d = target - radar
    r2 = d @ d
    return (4.0 / (c * r2 * r2) + 8.0 / r2) * np.outer(d, d) / r2


def _logdet(j):
    return np.linalg.slogdet(j + fisher.INFO_FLOOR * np.eye(3))[1]


@pytest.fixture(scope="module")
def case(tiny):
    s = tiny.replace(
        n_radars=3, target_init=[tiny.target_init[0]],
        detection={"model": "swerling1", "gain_db": 27.0, "pfa": 1e-6},
    )  # fmt: skip
    task, params = build(s, "ddr-sfim", 0)
    rng = np.random.default_rng(3)
    radar = np.zeros((H, 3, 6))
    radar[..., :2] = rng.uniform(-400, 400, (H, 3, 2))
    pts = np.zeros((H, P, 1, 6))
    pts[..., :3] = np.array([0.0, 0.0, 55.0]) + rng.normal(0, 30, (H, P, 1, 3))
    hz = Horizon(np.zeros((H, 3, 2), np.float32), radar.astype(np.float32),
                 pts.astype(np.float32), np.eye(6)[None].astype(np.float32))  # fmt: skip
    eq = s.radar_eq
    k_snr = 10 ** ((eq.snr_db + 27.0) / 10) / s.n_targets * eq.r_ref**4
    return s, task, params, hz, radar, pts, k_snr, float(params.noise.c)


def _pd(radar, target, k_snr):
    d2 = np.sum((target - radar) ** 2)
    return 1e-6 ** (1.0 / (1.0 + k_snr / d2**2))


def _x64(tree):
    def cast(a):
        a_ = np.asarray(a)
        return a_.astype(np.float64) if np.issubdtype(a_.dtype, np.floating) else a

    return jax.tree.map(cast, tree)


def test_information_cost_is_log_det_of_the_pd_weighted_fim(case):
    """In float64 the planner's cost equals the numpy reference to 2e-6; the float32
    program agrees to 0.02 (these FIMs have condition numbers up to ~2e4, the 3x3
    log det of float32 entries loses ~0.5% there, measured 0.015)."""
    s, task, params, hz, radar, pts, k_snr, c = case
    with jax.enable_x64(True):
        got64 = np.asarray(costs.information(Horizon(*_x64(tuple(hz))), task, _x64(params)))
    got = np.asarray(costs.information(hz, task, params))
    want = np.zeros(H)
    pds = []
    for h in range(H):
        for p in range(P):
            t = pts[h, p, 0, :3]
            pd = [_pd(radar[h, n, :3], t, k_snr) for n in range(3)]
            pds += pd
            j = sum(pd[n] * _pair_fim(radar[h, n, :3], t, c) for n in range(3))
            want[h] -= _logdet(j) / P
    assert 0.1 < np.mean(pds) < 0.95  # Pd matters here
    np.testing.assert_allclose(got64, want, atol=2e-6)  # inputs rounded to float32
    np.testing.assert_allclose(got, want, atol=0.02)


def test_expected_fim_cost_matches_monte_carlo_over_detection_draws(case):
    """The FIM averaged over 40 000 Bernoulli(Pd) detection draws of every pair tends to
    the Pd-weighted FIM; its cost must agree with the planner's within the Monte Carlo
    error (relative sd of an entry <= sqrt((1 - Pd) / (Pd n)) ~ 1e-2 here, so the log det
    of a 3x3 matrix to ~3e-2; tolerance 0.1)."""
    s, task, params, hz, radar, pts, k_snr, c = case
    got = np.asarray(costs.information(hz, task, params))
    rng = np.random.default_rng(5)
    n = 40_000
    mc = np.zeros(H)
    for h in range(H):
        for p in range(P):
            t = pts[h, p, 0, :3]
            pd = np.array([_pd(radar[h, n_, :3], t, k_snr) for n_ in range(3)])
            hits = rng.uniform(size=(n, 3)) < pd  # [draws, radars]
            jn = np.stack([_pair_fim(radar[h, n_, :3], t, c) for n_ in range(3)])
            j_mc = np.einsum("dn,nij->ij", hits.astype(float), jn) / n
            mc[h] -= _logdet(j_mc) / P
    np.testing.assert_allclose(got, mc, atol=0.1)
    # and the cost without the Pd weights (planner = false) is clearly different
    s_off = s.replace(detection={"model": "swerling1", "gain_db": 27.0, "planner": False})
    task_off, params_off = build(s_off, "ddr-sfim", 0)
    off = np.asarray(costs.information(hz, task_off, params_off))
    assert np.all(off < got - 1.0)  # more information when every pair counts fully
