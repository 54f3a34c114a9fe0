"""PDA update vs a hand-written textbook PDA on a linear case (issue 23)."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.stats import chi2

from mjx_radar.estimation.data_association import pda


def textbook_pda(x, P, Z, valid, H, R, pd, lam, pg):
    """Bar-Shalom, Daum & Huang (2009), eqs. 33-47, written out in numpy float64."""
    zhat = H @ x
    S = H @ P @ H.T + R
    W = P @ H.T @ np.linalg.inv(S)
    gamma = chi2.ppf(pg, len(zhat))
    nus, lik = [], []
    for z, ok in zip(Z, valid, strict=True):
        nu = z - zhat
        if ok and nu @ np.linalg.solve(S, nu) < gamma:
            nus.append(nu)
            gauss = math.exp(-0.5 * nu @ np.linalg.solve(S, nu)) / math.sqrt(
                np.linalg.det(2 * math.pi * S)
            )
            lik.append(gauss * pd / lam)  # L_i = N(nu; 0, S) P_D / lambda
    den = 1.0 - pd * pg + sum(lik)
    beta = [li / den for li in lik]
    beta0 = (1.0 - pd * pg) / den
    nu = sum((b * v for b, v in zip(beta, nus, strict=True)), np.zeros_like(zhat))
    xp = x + W @ nu
    Pc = P - W @ S @ W.T
    spread = sum((b * np.outer(v, v) for b, v in zip(beta, nus, strict=True)), 0 * S)
    Pt = W @ (spread - np.outer(nu, nu)) @ W.T
    return xp, beta0 * P + (1 - beta0) * Pc + Pt, beta0


@jax.jit  # one program for every case (suite time: eager ops compile one by one)
def _pda_linear(x, P, Z, valid, H, R, pd, lam, gamma, pg):
    return pda.pda_update(x, P, Z, valid, lambda v: H @ v, R, pd, lam, gamma, pg)


@pytest.mark.parametrize("lam", [1e-4, 0.05, 2.0])
@pytest.mark.parametrize("pd", [0.3, 0.9, 1.0])
def test_pda_update_matches_textbook_on_a_linear_case(lam, pd):
    rng = np.random.default_rng(int(lam * 1000) + int(pd * 10))
    n, p, L = 4, 2, 7
    A = rng.normal(size=(n, n))
    P = A @ A.T + n * np.eye(n)
    x = rng.normal(size=n)
    H = rng.normal(size=(p, n))
    R = np.diag([0.5, 2.0])
    S = H @ P @ H.T + R
    Ls = np.linalg.cholesky(S)
    Z = H @ x + (Ls @ rng.normal(size=(p, L)) * np.array([0.3, 0.8, 1.5, 2.5, 4.0, 1.0, 0.1])).T
    valid = np.array([1, 1, 1, 1, 1, 0, 1], bool)  # one empty slot of the buffer
    pg = 0.99
    want = textbook_pda(x, P, Z, valid, H, R, pd, lam, pg)
    with jax.enable_x64(True):  # float64 so the comparison can be tight
        (xm, Pm), (beta0, beta) = _pda_linear(
            jnp.asarray(x), jnp.asarray(P), jnp.asarray(Z), jnp.asarray(valid),
            jnp.asarray(H), jnp.asarray(R), jnp.float64(pd), jnp.float64(lam),
            jnp.float64(chi2.ppf(pg, p)), jnp.float64(pg),
        )  # fmt: skip
        xm, Pm, beta0, beta = (np.asarray(a) for a in (xm, Pm, beta0, beta))
    gated = sum(valid[i] and (Z[i] - H @ x) @ np.linalg.solve(S, Z[i] - H @ x) < chi2.ppf(pg, p)
                for i in range(L))  # fmt: skip
    assert 2 <= gated < valid.sum()  # some in the gate, some outside: both paths tested
    np.testing.assert_allclose(np.asarray(xm), want[0], rtol=1e-9, atol=1e-10)
    np.testing.assert_allclose(np.asarray(Pm), want[1], rtol=1e-9, atol=1e-10)
    np.testing.assert_allclose(float(beta0), want[2], rtol=1e-9, atol=1e-12)
    assert abs(float(beta0) + float(np.sum(beta)) - 1.0) < 1e-12


def test_no_measurements_or_pd_zero_leave_the_prediction():
    x, P = jnp.arange(4.0), jnp.eye(4) * 2.0
    H = jnp.eye(2, 4)
    z = jnp.ones((3, 2))
    update = jax.jit(lambda valid, pd: pda.pda_update(x, P, z, valid, lambda v: H @ v, jnp.eye(2),
                                                      pd, 0.1, 9.21, 0.99))  # fmt: skip
    for valid, pd in ((jnp.zeros(3, bool), 0.9), (jnp.ones(3, bool), 0.0)):
        (xm, Pm), (b0, _) = update(valid, jnp.float32(pd))  # one program for both cases
        np.testing.assert_allclose(np.asarray(xm), np.asarray(x), atol=1e-6)
        np.testing.assert_allclose(np.asarray(Pm), np.asarray(P), atol=1e-6)
        assert float(b0) == pytest.approx(1.0)


def test_mixed_fleet_noise_per_radar_in_the_bank_and_the_planner_factor():
    """[N] noise constants (a [[radar_override]] radar equation) with clutter: radar n's
    own constants in the bank's update and the planner's factor (was a broadcast error)."""
    from types import SimpleNamespace

    from mjx_radar.estimation.sensor.measurement import RangeModel
    from mjx_radar.estimation.sensor.noise import NoiseParams

    n, m, k = 2, 2, 3
    shared = NoiseParams(*(jnp.float32(v) for v in (1e-6, 1.0, 1e-6, 1.0)))
    mixed = NoiseParams(*(jnp.full((n,), v, jnp.float32) for v in shared))
    means = jnp.array([[0.0, 0.0, 50.0, 1.0, 1.0, 0.0], [20.0, 0.0, 60.0, 0.0, 1.0, 0.0]])
    covs = jnp.broadcast_to(jnp.eye(6) * 25.0, (m, 6, 6))
    radars = jnp.array([[300.0, 0.0, 0.0], [-300.0, 0.0, 0.0]])
    zs = jnp.full((n, k, 1), 600.0)
    valid = jnp.ones((n, k), bool)
    pd = jnp.full((n, m), 0.9)
    args = (zs, valid, radars, RangeModel())
    tail = (False, pd, 1e-3, 9.0, 0.99)
    bank = jax.jit(lambda noise: pda.update_bank(means, covs, *args, noise, *tail))
    got = bank(mixed)
    want = bank(shared)
    np.testing.assert_allclose(got[0], want[0], rtol=1e-5)
    sc = SimpleNamespace(detection=SimpleNamespace(clutter=True, gate_probability=0.99))
    det = SimpleNamespace(clutter_rate=5.0, clutter_min=0.0, clutter_max=1e3)
    for noise in (shared, mixed):
        params = SimpleNamespace(noise=noise, method=SimpleNamespace(ccr=False), detection=det)
        factor = pda.planner_factor(sc.detection, RangeModel(), params)
        q = jax.jit(factor)(jnp.full((4, n, 5), 0.9), jnp.full((4, n, 5), 1e4))
        assert q.shape == (4, n, 5) and bool(jnp.all(jnp.isfinite(q)))
