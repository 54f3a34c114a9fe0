"""Multi-sensor JPDA (radar tuples, all radars jointly) against independent references.

* a plain numpy enumeration of every joint event of 2 targets and 2 radars (each target
  one return or a miss per radar, no return to two targets), with a linear measurement
  model (for which the cubature moments are exact) and scipy's Gaussian density: the
  tuple marginals and the mixture posterior to 1e-9 (float64; both sides are exact, the
  difference is round-off and the ~1e-13 relative jitter of our Cholesky);
* with one radar the multi-sensor JPDA is the per-radar exact JPDA (same events), with
  the range model: 1e-10.
"""

import dataclasses
import itertools

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.stats import chi2, multivariate_normal

from mjx_radar.estimation.data_association import jpda, multisensor
from mjx_radar.estimation.sensor.noise import NoiseParams


@dataclasses.dataclass(frozen=True)
class _Linear:
    """z_n = u_n · p with u_n = radar_pos[n] (a linear 1-D measurement), variance ``var``."""

    var: float
    dim: int = 1

    def predict(self, radar_pos, target_pos):
        return jnp.einsum("nk,mk->nm", radar_pos, target_pos)[..., None]

    def variance(self, z_hat, noise, ccr):
        return jnp.full(z_hat.shape, self.var, z_hat.dtype)

    def residual(self, a, b):
        return a - b


def _reference(means, covs, zs, U, var, pd, lam, pg):
    """Every event enumerated in numpy: marginal mixture posterior per target."""
    m, n = means.shape[0], U.shape[0]
    gate = chi2.ppf(pg, 1)
    H = np.zeros((n, 6))
    H[:, :3] = U
    tuples = []  # per target: (tuple, weight, mean, cov)
    for t in range(m):
        x, P = means[t], covs[t]
        S = H @ P @ H.T + var * np.eye(n)
        opts = []
        for i in range(n):
            nu = zs[i, :, 0] - H[i] @ x
            opts.append([-1] + [j for j in range(zs.shape[1]) if nu[j] ** 2 / S[i, i] < gate])
        rows = []
        for tup in itertools.product(*opts):
            d = [i for i in range(n) if tup[i] >= 0]
            if not d:
                rows.append((tup, 1.0, x, P))
                continue
            nu = np.array([zs[i, tup[i], 0] - H[i] @ x for i in d])
            Sd = S[np.ix_(d, d)]
            w = multivariate_normal(np.zeros(len(d)), Sd).pdf(nu)
            w *= np.prod([pd / (lam * (1 - pd * pg)) for _ in d])
            K = P @ H[d].T @ np.linalg.inv(Sd)
            rows.append((tup, w, x + K @ nu, P - K @ Sd @ K.T))
        tuples.append(rows)
    marg = [np.zeros(len(r)) for r in tuples]
    for ev in itertools.product(*[range(len(r)) for r in tuples]):
        picks = [tuples[t][k][0] for t, k in enumerate(ev)]
        clash = any(
            a[i] >= 0 and a[i] == b[i]
            for a, b in itertools.combinations(picks, 2)
            for i in range(n)
        )
        if not clash:
            w = np.prod([tuples[t][k][1] for t, k in enumerate(ev)])
            for t, k in enumerate(ev):
                marg[t][k] += w
    out = []
    for t in range(m):
        beta = marg[t] / marg[t].sum()
        xs = np.array([r[2] for r in tuples[t]])
        mean = beta @ xs
        cov = sum(
            b * (r[3] + np.outer(r[2] - mean, r[2] - mean))
            for b, r in zip(beta, tuples[t], strict=True)
        )
        out.append((mean, cov))
    return out


def test_tuple_marginals_match_a_plain_enumeration():
    rng = np.random.default_rng(3)
    U = np.array([[1.0, 0.2, 0.1], [0.1, 1.0, 0.3]])  # two radars' directions
    truth = np.array([[0.0, 0, 50, 1, 0, 0], [4.0, 3, 52, 0, 1, 0]])
    means = truth + rng.normal(0, 1.5, truth.shape)
    covs = np.stack([np.diag([6.0, 5.0, 7.0, 2.0, 2.0, 2.0])] * 2)
    var, pd, lam, pg = 1.0, 0.9, 0.05, 0.99
    z = np.einsum("nk,mk->nm", U, truth[:, :3]) + rng.normal(size=(2, 2))
    zs = np.concatenate([z, z[:, :1] + rng.normal(0, 3, (2, 1))], axis=1)[..., None]  # [2, 3, 1]
    ref = _reference(means, covs, zs, U, var, pd, lam, pg)
    with jax.enable_x64(True):
        one = jnp.float64(1.0)
        update = jax.jit(
            lambda x, P, z, u: multisensor.update_bank(
                x, P, z, jnp.ones((2, 3), bool), u, _Linear(var), NoiseParams(one, one, one, one),
                True, jnp.full((2, 2), pd), jnp.float64(lam), jnp.float64(chi2.ppf(pg, 1)),
                jnp.float64(pg), 3, 16,
            )
        )  # fmt: skip
        x, P = update(*(jnp.asarray(a) for a in (means, covs, zs, U)))
    for t, (mean, cov) in enumerate(ref):
        np.testing.assert_allclose(np.asarray(x[t]), mean, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(np.asarray(P[t]), cov, rtol=1e-9, atol=1e-9)
    assert np.abs(np.asarray(x) - means).max() > 0.1  # the scans moved the estimates


@pytest.mark.parametrize("model_name", ["range", "range-azimuth"])
def test_one_radar_is_the_exact_jpda(model_name):
    from mjx_radar.estimation.sensor.measurement import RangeAzimuthModel, RangeModel

    model = RangeModel() if model_name == "range" else RangeAzimuthModel()
    rng = np.random.default_rng(5)
    radar = np.array([[300.0, 40.0, 0.0]])
    truth = np.array([[0.0, 0, 50, 5, 2, 0], [8.0, 3, 55, 4, 3, 0], [3.0, 9, 48, 6, 1, 0]])
    means = truth + rng.normal(0, 2, truth.shape)
    covs = np.stack([np.diag([6.0, 5.0, 7.0, 2.0, 2.0, 2.0])] * 3)
    d = truth[:, :3] - radar[0]
    z = np.stack([2 * np.linalg.norm(d, axis=1), np.arctan2(d[:, 1], d[:, 0])], -1)[:, : model.dim]
    z = z + rng.normal(size=z.shape) * [1.2, 0.01][: model.dim]
    zs = np.concatenate([z, z[:1] + [3.0, 0.02][: model.dim]])[None]  # [1, 4, dim]
    lam = 0.02 if model.dim == 1 else 2.0
    with jax.enable_x64(True):
        one = jnp.float64(1.0)
        noise = NoiseParams(one, jnp.float64(1.5), one, jnp.float64(1e-4))
        args = (jnp.asarray(means), jnp.asarray(covs), jnp.asarray(zs), jnp.ones((1, 4), bool))
        args += (jnp.asarray(radar), model, noise, True, jnp.full((1, 3), 0.9), jnp.float64(lam))
        args += (jnp.float64(chi2.ppf(0.99, model.dim)), jnp.float64(0.99))
        x1, P1 = jax.jit(lambda: jpda.update_bank(*args, jpda.rule("exact", candidates=4)))()
        ms = jpda.rule("multisensor", candidates=4, tuples=5)
        x2, P2 = jax.jit(lambda: jpda.update_bank(*args, ms))()
    np.testing.assert_allclose(np.asarray(x2), np.asarray(x1), rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(np.asarray(P2), np.asarray(P1), rtol=1e-10, atol=1e-10)
