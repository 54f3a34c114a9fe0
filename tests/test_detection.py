"""Detection probability and missed detections (issue 23, docs/detection.md)."""

import dataclasses
import math

import jax.numpy as jnp
import numpy as np
import pytest

from mjx_radar.engine import runner
from mjx_radar.engine.run_spec import run_spec
from mjx_radar.estimation.sensor import detection
from mjx_radar.io.checks import ScenarioError
from mjx_radar.rundir import results
from mjx_radar.scenario.schema import DetectionConfig
from mjx_radar.task.params import detection_of

STEPS = 40  # ten control periods of the tiny scenario
TRIALS = np.arange(4)


@pytest.mark.parametrize("pfa", [1e-6, 1e-3])
@pytest.mark.parametrize("snr", [0.0, 1.0, 10.0, 50.0])
def test_swerling1_formula_matches_monte_carlo_of_exponential_returns(pfa, snr):
    """Square-law detector, one pulse: noise power ~ Exp(mean 1), so the threshold of
    false-alarm probability pfa is T = -ln(pfa); a Swerling I echo plus noise is
    Exp(mean 1 + SNR). The detected fraction of 400 000 draws must be within 5
    binomial standard errors of pfa ** (1 / (1 + SNR))."""
    rng = np.random.default_rng(11)
    n = 400_000
    thr = -math.log(pfa)
    noise_only = rng.exponential(1.0, n)
    echo = rng.exponential(1.0 + snr, n)
    pd = float(detection.detection_probability(snr, pfa))
    assert abs(np.mean(noise_only > thr) - pfa) <= 5 * math.sqrt(pfa * (1 - pfa) / n) + 1 / n
    assert abs(np.mean(echo > thr) - pd) <= 5 * math.sqrt(pd * (1 - pd) / n) + 1 / n


def test_pair_probability_uses_the_radar_equation_snr(tiny):
    s = tiny.replace(detection={"model": "swerling1", "gain_db": 30.0, "pfa": 1e-4})
    p = detection_of(s)
    eq = s.radar_eq
    d = np.array([100.0, 400.0, 900.0])
    snr = 10 ** ((eq.snr_db + 30.0) / 10) / s.n_targets * (eq.r_ref / d) ** 4
    want = 1e-4 ** (1 / (1 + snr))
    got = detection.pair_probability("swerling1", p, jnp.asarray(d**2, jnp.float32))
    np.testing.assert_allclose(np.asarray(got), want, rtol=2e-5)
    fixed = detection.pair_probability("fixed", p._replace(fixed_pd=jnp.float32(0.3)), d**2)
    np.testing.assert_array_equal(np.asarray(fixed), np.float32(0.3))


def _with(s, **det):
    return s.replace(detection=det)


def test_run_detection_rate_within_binomial_error_of_the_modelled_pd(tiny):
    """Swerling I Pd along the recorded true geometry (numpy, float64) vs the detections a
    stationary run records: sum of detections within 4 standard deviations
    sqrt(sum Pd (1 - Pd)) of sum Pd (independent Bernoulli draws)."""
    s = _with(tiny, model="swerling1", gain_db=27.0, pfa=1e-6)
    res = runner.run_trials(run_spec(s), "stationary", 3, TRIALS, STEPS, full=True)
    d = np.linalg.norm(res["target"][:, :, None, :, :3] - res["radar"][:, :, :, None, :3], axis=-1)
    eq = s.radar_eq
    snr = 10 ** ((eq.snr_db + 27.0) / 10) / s.n_targets * (eq.r_ref / d) ** 4
    pd = 1e-6 ** (1 / (1 + snr))  # [T, K, N, M]
    assert 0.2 < pd.mean() < 0.9  # a test that can fail either way
    got = res["detections"].sum()
    sd = math.sqrt(np.sum(pd * (1 - pd)))
    assert abs(got - pd.sum()) <= 4 * sd, (got, pd.sum(), sd)
    assert np.all(res["detections"] <= res["visible_pairs"])
    assert np.all(np.isfinite(res["rmse_pos"]))


@pytest.mark.slow  # one more program; the Swerling run above tests the rate already
def test_fixed_pd_run_rate(tiny):
    s = _with(tiny, model="fixed", fixed_pd=0.6)
    res = runner.run_trials(run_spec(s), "stationary", 3, TRIALS, STEPS, full=False)
    n = res["visible_pairs"].sum()
    rate = res["detections"].sum() / n
    assert abs(rate - 0.6) <= 4 * math.sqrt(0.6 * 0.4 / n), rate


def test_fixed_pd_one_equals_perfect_detection_exactly(tiny):
    """fixed_pd = 1 detects every pair: it runs the paper's program, numbers bit for bit."""
    one = _with(tiny, model="fixed", fixed_pd=1.0)
    assert not one.detection.detects
    base = runner.run_trials(run_spec(tiny), "ddr-sfim", 5, TRIALS[:2], 8, full=False)
    got = runner.run_trials(run_spec(one), "ddr-sfim", 5, TRIALS[:2], 8, full=False)
    for k in results.METRIC_COLUMNS:
        np.testing.assert_array_equal(got[k], base[k], err_msg=k)
    np.testing.assert_array_equal(base["detections"], base["visible_pairs"])


@pytest.mark.slow
def test_pd_just_below_one_agrees_to_round_off(tiny):
    """Pd just below 1 runs the detection program (draws, masked updates, Pd-weighted
    planner information): with every pair detected (P(a miss in 64 draws) ~ 1e-5) it
    must agree with the paper's numbers to float32 round-off of a differently fused
    program over 8 steps (measured ~2e-4 relative)."""
    base = runner.run_trials(run_spec(tiny), "ddr-sfim", 5, TRIALS[:2], 8, full=False)
    near = runner.run_trials(run_spec(_with(tiny, model="fixed", fixed_pd=1.0 - 2e-7)),
                             "ddr-sfim", 5, TRIALS[:2], 8, full=False)  # fmt: skip
    np.testing.assert_array_equal(near["detections"], near["visible_pairs"])
    for k in ("rmse_pos", "rmse_state", "crlb_pos"):
        np.testing.assert_allclose(near[k], base[k], rtol=2e-3, err_msg=k)


@pytest.mark.parametrize(
    ("table", "field"),
    [
        ({"model": "rayleigh"}, "detection.model"),
        ({"pfa": 0.0}, "detection.pfa"),
        ({"pfa": 0.5}, "detection.pfa"),
        ({"fixed_pd": 1.5}, "detection.fixed_pd"),
        ({"fixed_pd": 0.0}, "detection.fixed_pd"),
        ({"gain_db": "x"}, "detection.gain_db"),
        ({"planner": 1}, "detection.planner"),
        ({"clutter_density": -1.0}, "detection.clutter_density"),
        ({"max_false_alarms": 0}, "detection.max_false_alarms"),
        ({"gate_probability": 1.0}, "detection.gate_probability"),
        ({"clutter_range_max": -3.0}, "detection.clutter_range_max"),
        ({"bogus": 1}, "detection.bogus"),
    ],
)
def test_bad_detection_fields_give_one_line(tiny, table, field):
    with pytest.raises(ScenarioError) as err:
        tiny.replace(detection=table)
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith(field), msg


def test_clutter_beyond_the_cap_is_refused_naming_the_cap(tiny):
    s = tiny.replace(filter={"structure": "per-target"}, detection={"max_false_alarms": 8})
    with pytest.raises(ScenarioError, match="detection.max_false_alarms = 8"):
        s.replace(detection={"clutter_density": 0.01, "max_false_alarms": 8})
    # lambda = 1: P(> 8) = 1.1e-6 is just over the limit; lambda = 0.5: 3.4e-9
    with pytest.raises(ScenarioError, match="max_false_alarms = 8"):
        s.replace(detection={"clutter_density": 0.001, "max_false_alarms": 8})
    ok = s.replace(detection={"clutter_density": 0.0005, "max_false_alarms": 8})
    assert ok.detection.clutter
    with pytest.raises(ScenarioError, match='filter.form = "sqrt"'):
        ok.replace(filter={"form": "sqrt"})
    with pytest.raises(ScenarioError, match='filter.structure = "per-target"'):
        tiny.replace(detection={"clutter_density": 0.001})


def test_defaults_are_perfect_detection():
    d = DetectionConfig()
    assert not d.detects and not d.clutter
    assert dataclasses.asdict(d)["model"] == "perfect"


@pytest.mark.parametrize("dof", [1, 2, 3])
def test_gate_quantile_closed_forms_match_scipy(dof):
    """The gate γ (closed forms for dof 1 and 2, no scipy.stats import) vs scipy's chi2."""
    from scipy.stats import chi2

    for p in (0.5, 0.9, 0.95, 0.99, 0.999, 0.9999, 0.999999):
        got = detection.chi2_quantile(p, dof)
        assert got == pytest.approx(chi2.ppf(p, dof), rel=1e-10), (p, dof)
