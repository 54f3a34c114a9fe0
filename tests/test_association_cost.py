"""The planner's association term (``[mpc] alpha_assoc``, :func:`mjx_radar.task.costs.association`):
the expected number of drone pairs whose ranges coincide at a radar, against a plain
loop over radars, pairs and cubature points, a closed form, and the scenario's rules."""

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_radar import load_scenario
from mjx_radar.io.checks import ScenarioError
from mjx_radar.scenario.edit import validate
from mjx_radar.task import costs
from mjx_radar.task.task import build


def _task(alpha=2.5, scale=4.0):
    s = load_scenario("smoke")
    s = dataclasses.replace(s, mpc=dataclasses.replace(s.mpc, alpha_assoc=alpha, assoc_scale=scale))
    return build(s)


def _reference(radar, points, alpha, scale, weight=None):
    """Σ over radars n and pairs i < j of exp(-(r_ni - r_nj)^2 / (2 s^2)), averaged over the
    points, by loops (float64)."""
    hh, p, m = points.shape[:3]
    out = np.zeros(hh)
    w = np.ones(m) if weight is None else weight
    for t in range(hh):
        for q in range(p):
            for n in range(radar.shape[1]):
                r = [math.dist(radar[t, n, :3], points[t, q, i, :3]) for i in range(m)]
                for i in range(m):
                    for j in range(i + 1, m):
                        out[t] += w[i] * w[j] * math.exp(-0.5 * ((r[i] - r[j]) / scale) ** 2) / p
    return alpha * out


def test_closed_form_one_radar_two_targets():
    task, params = _task(alpha=3.0, scale=5.0)
    radar = np.zeros((1, 1, 6), np.float32)
    pts = np.zeros((1, 2, 2, 6), np.float32)  # two points, both at the means
    pts[..., 0, 0], pts[..., 1, 0] = 100.0, 103.0  # ranges 100 and 103 m: gap 3 m
    hz = costs.Horizon(jnp.zeros((1, 1, 2)), jnp.asarray(radar), jnp.asarray(pts), None)
    got = float(costs.association(hz, task, params._replace(target_weight=None))[0])
    assert got == pytest.approx(3.0 * math.exp(-0.5 * (3.0 / 5.0) ** 2), rel=1e-6)


def test_matches_loops_with_spread_points_and_presence_weights():
    rng = np.random.default_rng(3)
    task, params = _task(alpha=2.5, scale=4.0)
    radar = np.zeros((3, 2, 6))
    radar[..., :2] = rng.uniform(-200, 200, (3, 2, 2))
    pts = rng.normal(0.0, 1.0, (3, 8, 4, 6))
    pts[..., :3] = pts[..., :3] * 3.0 + np.array([[0, 0, 50], [6, 4, 55], [10, 9, 50], [3, -5, 60]])
    hz = costs.Horizon(jnp.zeros((3, 2, 2)), jnp.asarray(radar, jnp.float32),
                       jnp.asarray(pts, jnp.float32), None)  # fmt: skip
    ref = _reference(radar, pts, 2.5, 4.0)
    assert ref.min() > 0.5  # close drones: the pairs' ranges often coincide within 4 m
    fn = jax.jit(lambda h, p: costs.association(h, task, p))
    np.testing.assert_allclose(fn(hz, params._replace(target_weight=None)), ref, rtol=2e-5)
    w = np.array([1.0, 0.0, 1.0, 0.5])  # an absent target's pairs cost nothing
    got = fn(hz, params._replace(target_weight=jnp.asarray(w, jnp.float32)))
    np.testing.assert_allclose(got, _reference(radar, pts, 2.5, 4.0, w), rtol=2e-5)


def test_term_is_listed_only_when_weighted():
    assert "association" not in [t.name for t in build(load_scenario("smoke"))[0].terms]
    assert [t.name for t in _task()[0].terms].count("association") == 1


@pytest.mark.parametrize(
    ("field", "value", "words"),
    [("alpha_assoc", -1.0, "alpha_assoc = -1.0"), ("assoc_scale", 0.0, "assoc_scale = 0.0")],
)
def test_bad_values_name_the_field(field, value, words):
    s = load_scenario("smoke")
    with pytest.raises(ScenarioError, match=words):
        validate(dataclasses.replace(s, mpc=dataclasses.replace(s.mpc, **{field: value})))
