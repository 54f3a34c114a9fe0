"""Clutter, PDA in the closed loop and the planner's PDA information factor (issue 23)."""

import math

import jax
import numpy as np
import pytest
from scipy.stats import norm

from mjx_radar.engine import runner
from mjx_radar.engine.run_spec import run_spec
from mjx_radar.estimation.data_association import pda
from mjx_radar.estimation.sensor import clutter
from mjx_radar.task.params import detection_of

STEPS = 40
TRIALS = np.arange(4)
_irf = jax.jit(pda.irf)  # one program per shape (not op by op)


def test_irf_without_clutter_is_pd_times_the_gated_second_moment():
    """λ = 0: the score is z_1 for a detected return in the gate, so q = P_D E[z²; |z| < g]
    = P_D (P_G − 2 g φ(g)) (1-D; closed form). Monte Carlo error with 8000 draws: the
    sd of z² is ~1.4, so ~0.016 relative; tolerance 0.05."""
    pg = 0.99
    g = norm.ppf(0.5 + pg / 2)
    t = pda.irf_table(1, pg)
    want = pda.IRF_PD * (pg - 2 * g * norm.pdf(g))
    np.testing.assert_allclose(t[:, 0], want, atol=0.05 * want.max())
    assert np.all(np.diff(t[-1]) <= 1e-3)  # more clutter, less information
    assert t[-1, -1] < 0.1 * t[-1, 0]
    q = np.asarray(_irf(t, np.float32(0.55), np.float32(0.0)))
    np.testing.assert_allclose(q, 0.5 * (t[5, 0] + t[6, 0]), rtol=1e-5)  # interpolation


def test_clutter_counts_are_poisson_within_the_window(tiny):
    s = tiny.replace(filter={"structure": "per-target"},
                     detection={"clutter_density": 0.002, "clutter_range_min": 100.0,
                                "clutter_range_max": 600.0})  # fmt: skip
    p = detection_of(s)
    sample = jax.jit(jax.vmap(lambda k: clutter.sample_clutter(k, p, 2, 8, 1)))  # one program
    z, valid, count = sample(jax.random.split(jax.random.PRNGKey(0), 4000))
    lam = 0.002 * 500.0
    c = np.asarray(count)
    assert abs(c.mean() - lam) < 4 * math.sqrt(lam / c.size)
    r = np.asarray(z)[..., 0][np.asarray(valid)] / 2
    assert r.min() >= 100.0 and r.max() <= 600.0 and abs(r.mean() - 350) < 5


@pytest.mark.slow  # the PDA itself: tests/test_pda.py against the textbook (suite time)
def test_pda_closed_loop_tracks_in_clutter(tiny):
    """Per-target PDA with Pd 0.9 and 1 false alarm per radar and scan: the recorded false
    alarms are Poisson(1) per radar, and the track error stays within 3x the clutter-free
    error of the same detections."""
    base = tiny.replace(filter={"structure": "per-target"})
    det = {"model": "fixed", "fixed_pd": 0.9, "clutter_range_max": 500.0}
    clean = runner.run_trials(run_spec(base.replace(detection=det)), "stationary", 3, TRIALS, STEPS)
    s = base.replace(detection={**det, "clutter_density": 0.002})
    res = runner.run_trials(run_spec(s), "stationary", 3, TRIALS, STEPS)
    fa = res["false_alarms"]
    n = fa.size * s.n_radars
    assert abs(fa.sum() / n - 1.0) < 4 * math.sqrt(1.0 / n), fa.mean()
    np.testing.assert_array_equal(res["detections"], clean["detections"])  # same draws
    assert np.all(np.isfinite(res["rmse_pos"])) and not res["diverged"].any()
    late = slice(STEPS // 2, None)
    assert res["rmse_pos"][:, late].mean() < 3 * clean["rmse_pos"][:, late].mean()


@pytest.mark.parametrize("ccr", [False, True])
def test_planner_factor_is_the_table_at_the_whitened_density(tiny, ccr):
    from mjx_radar.task.task import build

    s = tiny.replace(filter={"structure": "per-target"},
                     detection={"model": "swerling1", "gain_db": 27.0,
                                "clutter_density": 0.002, "clutter_range_max": 500.0})  # fmt: skip
    task, params = build(s, "ccr-sfim" if ccr else "ddr-sfim", 0)
    d = np.array([150.0, 400.0, 900.0])
    pd = np.array([0.9, 0.5, 0.1], np.float32)
    factor = jax.jit(
        lambda params, pd, d2: pda.planner_factor(s.detection, task.measurement, params)(pd, d2)
    )
    got = np.asarray(factor(params, pd, (d**2).astype(np.float32)))  # one program
    c = float(params.noise.c)
    var = float(params.noise.sigma_r2) * np.ones(3) if ccr else c * d**4
    lam_w = 0.002 * 500.0 / (2 * 500.0) * np.sqrt(var)  # λ_c / V · sqrt(det R)
    want = np.asarray(_irf(pda.irf_table(1, 0.99), pd, lam_w.astype(np.float32)))
    np.testing.assert_allclose(got, want, rtol=1e-4)
    assert np.all(got < pd)
