"""The ``"mht"`` tracker: K association histories kept across scans (docs/tracking.md).

Selected by ``[tracker] association = "mht"`` (cluttered scans only). Its own state
(``modes``) is a :class:`~mjx_radar.estimation.data_association.mht.HypState`: ``hypotheses`` (K)
global
hypotheses, each a per-target bank (covariance form) with its log weight. Per scan
every hypothesis is predicted, then every radar's scan makes the children of every
hypothesis and joint event over each target's ``candidates`` best returns, pruned to
the K heaviest (:func:`mjx_radar.estimation.data_association.mht.update_bank`). The joint estimate
the
loop carries (``mean [6M]``, ``cov [6M, 6M]``: metrics, lost-track detector, planner)
is the heaviest hypothesis's bank (with ``estimate = "consensus"`` the hypothesis with the
most posterior weight near it: :mod:`~mjx_radar.estimation.data_association.mht_estimate`),
so the planner plans for that hypothesis; with
``plan_on = "mixture"`` the planner sees the moment-matched mixture of the hypotheses
instead (:mod:`~mjx_radar.estimation.data_association.mht_mixture`, ``FilterOps.plan_view``),
while the metrics keep the heaviest's. The
filter's Pd of a pair is the model's at each hypothesis's predicted range (0 where the
line of sight is blocked), as in the PDA and JPDA banks. With ``branch_scans = B > 0`` only
the first B scans branch (``begin`` sets the state's scan counter from the loop's step);
later scans give each hypothesis JPDA's soft update weighted by its likelihood
(:func:`mjx_radar.estimation.data_association.mht.soft_update`); with ``settle_scans = S``
only the ``settled_hypotheses`` heaviest go on after S scans
(:func:`mjx_radar.estimation.data_association.mht.settled`); ``miss_noise`` spreads a track
along the line of sight of a radar whose returns it misses in those scans
(:func:`mjx_radar.estimation.data_association.pda.miss_inflation`); ``height_std > 0``
holds every hypothesis's heights near ``birth_height`` and weighs the hypotheses by it
(:func:`altitude_prior`), with ``height_scans = H > 0`` over the first H scans only.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
from jax.scipy.special import logsumexp

from mjx_radar.env import filter_ops
from mjx_radar.env.filter_ops import FilterOps
from mjx_radar.errors import ScenarioError
from mjx_radar.estimation.data_association import mht, mht_estimate, mht_mixture, mht_settle
from mjx_radar.estimation.filters import filter_bank, ground_prior
from mjx_radar.estimation.sensor import clutter, detection
from mjx_radar.estimation.tracks import altitude
from mjx_radar.physics import target_motion
from mjx_radar.task.task import RadarTask

__all__ = ["mht_bank", "altitude_prior"]


def _ground(hyp: mht.HypState) -> mht.HypState:
    """Every hypothesis's targets below ground reflected (``filter.ground_prior``)."""

    def one(means, covs):
        mean, cov = ground_prior.apply_ground_prior(*filter_bank.bank_to_joint(means, covs))
        return filter_bank.joint_to_bank(mean, cov)

    means, covs = jax.vmap(one)(hyp.means, hyp.covs)
    return hyp._replace(means=means, covs=covs)


def altitude_prior(hyp: mht.HypState, h0: float, var: float, scans: int = 0) -> mht.HypState:
    """Every hypothesis's targets take the pseudo-measurement ``z = h₀`` of their height
    with variance ``σ_a² = var`` (:func:`~mjx_radar.estimation.tracks.altitude.height_update`),
    and every hypothesis is weighed by its predictive likelihood,
    ``log w_h += Σ_t log N(h₀; x_ht,z, P_ht,zz + σ_a²)`` (renormalised; empty slots stay
    empty): a prior on the drones' flight altitude that also ranks the hypotheses. With
    ``scans = H > 0`` (static, ``height_scans``) only while ``hyp.scans <= H`` (the
    first H scans; ``hyp`` unchanged afterwards)."""
    if scans:
        held = altitude_prior(hyp, h0, var)
        on = hyp.scans <= scans
        return jax.tree.map(lambda a, b: jnp.where(on, a, b), held, hyp)
    s = hyp.covs[..., 2, 2] + var  # [K, M]
    ll = -0.5 * jnp.sum((hyp.means[..., 2] - h0) ** 2 / s + jnp.log(2 * jnp.pi * s), -1)
    logw = jnp.where(jnp.isfinite(hyp.logw), hyp.logw + ll, -jnp.inf)
    on = jnp.ones(hyp.means.shape[1], bool)
    means, covs = jax.vmap(lambda x, p: altitude.height_update(x, p, on, h0, var))(
        hyp.means, hyp.covs
    )
    return hyp._replace(means=means, covs=covs, logw=logw - logsumexp(logw))


def mht_bank(task: RadarTask, params) -> FilterOps:
    """``"mht"``: the K-best multiple-hypothesis tracker (module docstring)."""
    model, t, det = task.measurement, task.tracker, task.detection
    if not det.clutter:  # filter.tracker = "mht" by name: the scans must be unlabelled
        raise ScenarioError(
            'filter.tracker = "mht": needs clutter (detection.clutter_density > 0); without '
            "it the returns are labelled"
        )
    dp = params.detection
    a6, q6 = task.a6_filter, params.sigma_w2 * task.w6_filter_unit
    ccr = params.method.ccr
    dt = task.timing.dt_filter
    merge = (float(t.merge_distance), int(t.merge_screen), bool(t.merge_labels))
    settle = (int(t.settle_scans), int(t.settled_hypotheses))
    live = settle if t.branch_scans > 0 else (0, 0)  # settling needs branch_scans

    scale = float(t.consensus_scale)

    def consensus(hyp):
        return mht_estimate.consensus(hyp.means, hyp.covs, hyp.logw, scale)

    pick = consensus if t.estimate == "consensus" else mht.best  # the reported hypothesis

    def joint(hyp):
        return filter_bank.bank_to_joint(*pick(hyp))

    def predict(mean, cov, modes):
        modes = mht.predict(modes, a6, q6, live)
        return (*joint(modes), modes)

    def after(modes):  # every hypothesis's priors after a scan
        if t.height_std > 0:  # the altitude prior (off by default)
            h0, var = float(t.birth_height), float(t.height_std) ** 2
            modes = altitude_prior(modes, h0, var, int(t.height_scans))
        return _ground(modes) if task.filter.ground_prior else modes

    def update(mean, cov, modes, z, radar_pos, scan_, los=None):
        def pd_fn(pos):  # [K, M, 3] -> [N, K, M]
            d2 = jnp.sum((pos[None] - radar_pos[:, None, None, :]) ** 2, -1)
            pd = detection.pair_probability(det.model, dp, d2)
            return pd if los is None else jnp.where(los[:, None, :], pd, 0.0)

        tail = (clutter.density(dp, model.dim), dp.gate, dp.gate_probability, t.candidates)
        tail = (*tail, merge, int(t.branch_scans), settle, float(t.miss_noise))
        args = (scan_.zs, scan_.valid, radar_pos, model, params.noise, ccr, pd_fn)
        modes = mht_settle.live_only(mht.update_bank(modes, *args, *tail), live, after)
        return (*joint(modes), modes)

    def begin(modes, mean, cov, k):  # appearing targets restart in every hypothesis
        if t.branch_scans > 0:  # the scans before this one, from the loop's step k (1-based)
            modes = modes._replace(scans=jnp.asarray(k, jnp.int32) - 1)
        if params.motion is None:
            return modes
        new = target_motion.appears_between(params.motion, (k - 1) * dt, k * dt)  # [M]
        means, covs = filter_bank.joint_to_bank(mean, cov)
        sel = lambda a, b: jnp.where(new.reshape((-1,) + (1,) * (a.ndim - 1)), a, b)  # noqa: E731
        return modes._replace(
            means=jax.vmap(sel, (None, 0))(means, modes.means),
            covs=jax.vmap(sel, (None, 0))(covs, modes.covs),
        )

    def init(mean, cov):
        return mht.init(*filter_bank.joint_to_bank(mean, cov), t.hypotheses)

    def mixture(mean, cov, modes):  # what the planner sees with plan_on = "mixture"
        return filter_bank.bank_to_joint(*mht_mixture.mixture(modes.means, modes.covs, modes.logw))

    def keep(ok_pred, ok, post, pred, prev):  # the scan counter: the loop's, in every trial
        return filter_ops.keep(ok_pred, ok, post, pred, prev)._replace(scans=post.scans)

    view = mixture if t.plan_on == "mixture" else None
    return FilterOps(predict, update, begin, init, plan_view=view, keep=keep)
