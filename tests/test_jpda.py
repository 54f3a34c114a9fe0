"""JPDA and GNN of the bank against Stone Soup on the same numbers (issue 35).

Stone Soup's ``JPDA`` data associator with its ``PDAHypothesiser`` enumerates every joint
event over all measurements (no candidate truncation) and normalises; its posterior is
the Gaussian-mixture reduction of the per-hypothesis Kalman updates (the missed one the
prediction), which is the PDA mixture formula. Ours (``association.exact_marginals``
with G = L, then ``pda.mixture``) must give the same marginals and moments. The
predictions are made at the tracks' own time (Stone Soup's predictor then returns the
prior), so only the association and the update are compared. Float64 on both sides:
the tolerance 1e-9 (relative) is round-off of a few 4x4 solves and sums of ~50 events.
"""

import datetime

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.stats import chi2

from mjx_radar.estimation.data_association import jpda, pda

stonesoup = pytest.importorskip("stonesoup")
from stonesoup.dataassociator.neighbour import GNNWith2DAssignment  # noqa: E402
from stonesoup.dataassociator.probability import JPDA  # noqa: E402
from stonesoup.hypothesiser.distance import DistanceHypothesiser  # noqa: E402
from stonesoup.hypothesiser.probability import PDAHypothesiser  # noqa: E402
from stonesoup.measures import SquaredMahalanobis  # noqa: E402
from stonesoup.models.measurement.linear import LinearGaussian  # noqa: E402
from stonesoup.models.transition.linear import (  # noqa: E402
    CombinedLinearGaussianTransitionModel,
    ConstantVelocity,
)
from stonesoup.predictor.kalman import KalmanPredictor  # noqa: E402
from stonesoup.types.detection import Detection  # noqa: E402
from stonesoup.types.state import GaussianState  # noqa: E402
from stonesoup.types.track import Track  # noqa: E402
from stonesoup.updater.kalman import KalmanUpdater  # noqa: E402

T0 = datetime.datetime(2026, 1, 1)
H = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0]])  # state [x, vx, y, vy], measure (x, y)


def _problem(seed, m=3, n_clutter=4, spread=2.0):
    """M tracks close together, their returns and clutter around them (2-D positions)."""
    rng = np.random.default_rng(seed)
    R = np.diag([0.4, 0.7])
    means, covs = [], []
    for t in range(m):
        x = np.array([spread * t, 1.0, 0.5 * spread * t, -1.0]) + rng.normal(0, 0.3, 4)
        A = rng.normal(size=(4, 4)) * 0.3
        means.append(x)
        covs.append(A @ A.T + np.diag([1.0, 0.5, 1.2, 0.5]))
    zs = [H @ x + rng.normal(0, 1.0, 2) for x in means[:-1]]  # the last target missed
    zs += list(rng.uniform(-2, 2 + spread * m, size=(n_clutter, 2)))
    return np.array(means), np.array(covs), np.array(zs), R


def _h(v):
    return jnp.asarray(H) @ v


def _stonesoup_jpda(means, covs, zs, R, pd, lam, pg):
    model = LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=R)
    trans = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.0)] * 2)
    updater = KalmanUpdater(model)
    hyp = PDAHypothesiser(
        KalmanPredictor(trans), updater, clutter_spatial_density=lam, prob_detect=pd, prob_gate=pg
    )
    tracks = [Track([GaussianState(x, P, timestamp=T0)]) for x, P in zip(means, covs, strict=True)]
    dets = [Detection(z, timestamp=T0, measurement_model=model) for z in zs]
    out = JPDA(hyp).associate(set(tracks), set(dets), T0)
    betas, posts = [], []
    for tr in tracks:
        beta = np.zeros(1 + len(dets))
        xs, ws, Ps = [], [], []
        for h in out[tr]:
            w = float(h.probability)
            if h:
                beta[1 + dets.index(h.measurement)] = w
                post = updater.update(h)
            else:
                beta[0] = w
                post = h.prediction
            xs.append(np.asarray(post.state_vector, float).ravel())
            Ps.append(np.asarray(post.covar, float))
            ws.append(w)
        ws, xs = np.array(ws), np.array(xs)
        mean = ws @ xs
        cov = sum(
            w * (P + np.outer(x - mean, x - mean)) for w, x, P in zip(ws, xs, Ps, strict=True)
        )
        betas.append(beta)
        posts.append((mean, cov))
    return np.array(betas), posts


def _ours(means, covs, zs, R, pd, lam, pg, kind="exact", g=None):
    m, n_meas = len(means), len(zs)
    with jax.enable_x64(True):
        assoc = jpda.rule(kind, candidates=g or n_meas, iterations=200)

        @jax.jit
        def update(means, covs, zs, R, pd, lam, gate, pg):
            h = lambda v: jnp.asarray(H) @ v  # noqa: E731
            valid = jnp.ones(zs.shape[0], bool)
            return jpda.joint_update(means, covs, zs, valid, h, R, pd, lam, gate, pg, assoc)

        (x, P), (b0, b) = update(
            jnp.asarray(means), jnp.asarray(covs), jnp.asarray(zs), jnp.asarray(R),
            jnp.full(m, pd), jnp.float64(lam), jnp.float64(chi2.ppf(pg, 2)), jnp.float64(pg),
        )  # fmt: skip
        return np.asarray(x), np.asarray(P), np.asarray(b0), np.asarray(b)


@pytest.mark.parametrize(("seed", "pd", "lam"), [(0, 0.9, 0.02), (1, 0.7, 0.1), (2, 0.99, 0.005)])
def test_jpda_marginals_and_posterior_match_stonesoup(seed, pd, lam):
    pg = 0.99
    means, covs, zs, R = _problem(seed)
    want_beta, want_post = _stonesoup_jpda(means, covs, zs, R, pd, lam, pg)
    x, P, b0, b = _ours(means, covs, zs, R, pd, lam, pg)
    shared = np.sum((b > 1e-6).sum(0) > 1)
    assert shared >= 1  # a measurement in two targets' gates: the association is joint
    np.testing.assert_allclose(b0, want_beta[:, 0], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(b, want_beta[:, 1:], rtol=1e-9, atol=1e-12)
    for t, (mean, cov) in enumerate(want_post):
        np.testing.assert_allclose(x[t], mean, rtol=1e-9, atol=1e-10)
        np.testing.assert_allclose(P[t], cov, rtol=1e-9, atol=1e-10)


def test_jpda_of_one_target_is_its_pda():
    """One target: every joint event is a PDA hypothesis; exact and LBP give the PDA."""
    means, covs, zs, R = _problem(3, m=1, n_clutter=5, spread=0.5)
    pd, lam, pg = 0.8, 0.05, 0.99
    with jax.enable_x64(True):
        (xp, Pp), (b0p, bp) = jax.jit(pda.pda_update, static_argnums=4)(
            jnp.asarray(means[0]), jnp.asarray(covs[0]), jnp.asarray(zs),
            jnp.ones(len(zs), bool), _h, jnp.asarray(R),
            jnp.float64(pd), jnp.float64(lam), jnp.float64(chi2.ppf(pg, 2)), jnp.float64(pg),
        )  # fmt: skip
    assert 0.0 < float(b0p) < 0.9 and np.sum(np.asarray(bp) > 0) >= 2
    for kind in ("exact", "lbp"):
        x, P, b0, b = _ours(means, covs, zs, R, pd, lam, pg, kind=kind)
        np.testing.assert_allclose(b[0], np.asarray(bp), rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(x[0], np.asarray(xp), rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(P[0], np.asarray(Pp), rtol=1e-12, atol=1e-12)


def test_gnn_matches_stonesoup_assignment_with_equal_innovation_covariances():
    """Stone Soup's GNNWith2DAssignment minimises the summed distances. With every track's
    S equal (same P), our objective Σ (d²/2 + log b) with miss cost 0 is the same problem
    as squared Mahalanobis costs with a missed distance −2 log b (each target's costs moved
    by one constant); b > exp(−γ/2) keeps ungated pairs out of the optimum."""
    means, covs, zs, R = _problem(4, m=3, n_clutter=4, spread=1.0)
    covs = np.broadcast_to(covs[0], covs.shape).copy()
    pd, pg = 0.9, 0.99
    S = H @ covs[0] @ H.T + R
    lam = 0.3  # b below
    b = lam * np.sqrt(np.linalg.det(2 * np.pi * S)) * (1 - pd * pg) / pd
    assert b > np.exp(-0.5 * chi2.ppf(pg, 2))
    model = LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=R)
    trans = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.0)] * 2)
    hyp = DistanceHypothesiser(
        KalmanPredictor(trans), KalmanUpdater(model), SquaredMahalanobis(), -2 * np.log(b)
    )
    tracks = [Track([GaussianState(x, P, timestamp=T0)]) for x, P in zip(means, covs, strict=True)]
    dets = [Detection(z, timestamp=T0, measurement_model=model) for z in zs]
    out = GNNWith2DAssignment(hyp).associate(set(tracks), set(dets), T0)
    want = [(1 + dets.index(out[t].measurement)) if out[t] else 0 for t in tracks]
    _, _, b0, bm = _ours(means, covs, zs, R, pd, lam, pg, kind="gnn")
    got = [0 if b0[t] == 1 else 1 + int(np.argmax(bm[t])) for t in range(len(tracks))]
    assert got == want
    assert sum(w > 0 for w in want) >= 2  # assignments made, not all missed


def _radar_model_class():
    """A Stone Soup measurement model of ours: round-trip range (and azimuth) of radar r."""
    from stonesoup.base import Property
    from stonesoup.models.measurement.nonlinear import NonLinearGaussianMeasurement
    from stonesoup.types.array import StateVector

    class RadarRange(NonLinearGaussianMeasurement):
        radar: np.ndarray = Property(doc="radar position [3]")
        azimuth: bool = Property(default=False)

        @property
        def ndim_meas(self):
            return 2 if self.azimuth else 1

        def function(self, state, noise=False, **kwargs):
            d = np.asarray(state.state_vector, float)[:3, 0] - self.radar
            out = [2.0 * np.linalg.norm(d)] + ([np.arctan2(d[1], d[0])] if self.azimuth else [])
            return StateVector(out)

    return RadarRange


@pytest.mark.slow  # ~20 s each on a busy 2-core CPU (Stone Soup's Python loops, one jit)
@pytest.mark.parametrize("model_name", ["range", "range-azimuth"])
def test_sequential_bank_update_matches_stonesoup_cubature_jpda(model_name):
    """Our measurement models in ``jpda.update_bank`` (3 drones 8 m apart, two radars, radar
    after radar) against Stone Soup's JPDA with its ``CubatureKalmanUpdater`` (alpha = 1:
    the 2n-point CKF, ours) and the same h. CCR noise (constant R) so the two filters share
    R exactly (ours evaluates DDR's R at the predicted measurement, Stone Soup's is fixed).
    Azimuths stay far from ±π (no wrap). Tolerance 1e-8: our Cholesky adds a ~1e-13
    relative jitter to P before the cubature points."""
    from mjx_radar.estimation.sensor.measurement import RangeAzimuthModel, RangeModel
    from mjx_radar.estimation.sensor.noise import NoiseParams

    model = RangeModel() if model_name == "range" else RangeAzimuthModel()
    az = model.dim == 2
    rng = np.random.default_rng(7)
    radars = np.array([[300.0, 40.0, 0.0], [-50.0, 260.0, 0.0]])
    truth = np.array([[0.0, 0, 50, 5, 2, 0], [8.0, 3, 55, 4, 3, 0], [3.0, 9, 48, 6, 1, 0]])
    means = truth + rng.normal(0, [2, 2, 2, 1, 1, 1], truth.shape)
    covs = np.stack([np.diag([6.0, 5.0, 7.0, 2.0, 2.0, 2.0])] * 3)
    sr2, saz2 = 1.5, 1e-4
    R = np.diag([sr2, saz2][: model.dim])
    zs = []
    for r in radars:
        d = truth[:, :3] - r
        z = np.stack([2 * np.linalg.norm(d, axis=1), np.arctan2(d[:, 1], d[:, 0])], -1)
        z = z[:, : model.dim] + rng.normal(size=(3, model.dim)) * np.sqrt(np.diag(R))
        clutter = z[:1] + rng.normal(0, 4, size=(2, model.dim)) * [1.0, 0.02][: model.dim]
        zs.append(np.concatenate([z[[0, 2]], clutter]))  # target 1 missed
    zs = np.stack(zs)  # [N, L, dim]
    pd, lam, pg = 0.9, 0.02 if not az else 2.0, 0.99

    from stonesoup.updater.kalman import CubatureKalmanUpdater

    trans = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.0)] * 3)
    tracks = [Track([GaussianState(x, P, timestamp=T0)]) for x, P in zip(means, covs, strict=True)]
    cls = _radar_model_class()
    for i, r in enumerate(radars):
        mm = cls(ndim_state=6, mapping=(0, 1, 2), noise_covar=R, radar=r, azimuth=az)
        upd = CubatureKalmanUpdater(mm)
        hyp = PDAHypothesiser(KalmanPredictor(trans), upd, lam, prob_detect=pd, prob_gate=pg)
        dets = [Detection(z, timestamp=T0, measurement_model=mm) for z in zs[i]]
        out = JPDA(hyp).associate(set(tracks), set(dets), T0)
        new = []
        for tr in tracks:
            ws = np.array([float(h.probability) for h in out[tr]])
            posts = [upd.update(h) if h else h.prediction for h in out[tr]]
            xs = np.array([np.asarray(p.state_vector, float).ravel() for p in posts])
            mean = ws @ xs
            cov = sum(
                w * (np.asarray(p.covar) + np.outer(x - mean, x - mean))
                for w, x, p in zip(ws, xs, posts, strict=True)
            )
            new.append(Track([GaussianState(mean, cov, timestamp=T0)]))
        tracks = new

    with jax.enable_x64(True):
        one = jnp.float64(1.0)
        noise = NoiseParams(one, jnp.float64(sr2), one, jnp.float64(saz2))
        pd_nm = jnp.full((2, 3), pd)
        gate = jnp.float64(chi2.ppf(pg, model.dim))

        @jax.jit
        def update(means, covs, zs, radars):
            valid = jnp.ones(zs.shape[:2], bool)
            return jpda.update_bank(
                means, covs, zs, valid, radars, model, noise, True, pd_nm, jnp.float64(lam),
                gate, jnp.float64(pg), jpda.rule("exact", candidates=zs.shape[1]),
            )  # fmt: skip

        x, P = update(*(jnp.asarray(a) for a in (means, covs, zs, radars)))
        valid = jnp.ones(zs.shape[:2], bool)
        args = (jnp.asarray(zs), valid, jnp.asarray(radars), model, noise, True, pd_nm)
        xp, _ = pda.update_bank(jnp.asarray(means), jnp.asarray(covs), *args, lam, gate, pg)
    assert np.abs(np.asarray(xp) - np.asarray(x)).max() > 1e-3  # joint != per-target PDA
    for t, tr in enumerate(tracks):
        np.testing.assert_allclose(np.asarray(x[t]), np.asarray(tr.state_vector).ravel(), rtol=1e-8)
        np.testing.assert_allclose(np.asarray(P[t]), np.asarray(tr.covar), rtol=1e-8, atol=1e-9)
    assert np.abs(np.asarray(x) - means).max() > 0.1  # the scans moved the estimates
