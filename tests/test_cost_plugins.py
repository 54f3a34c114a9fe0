"""Cost terms in the one plug-in registry (mjx_radar.registry.COST_TERMS): the built-in
terms listed there, a registered term in the objective of the scenarios it is enabled
for (after the built-in ones, under its own name), its code in the cache key, and the
term's value against a closed form on a hand-made horizon."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest

import mjx_radar
from mjx_radar.contracts import PluginError
from mjx_radar.registry import COST_TERMS
from mjx_radar.task import cost_plugins, costs

BUILT_IN = (
    "information",
    "radar_radar",
    "radar_target",
    "obstacle",
    "moving_obstacle",
    "terrain_slope",
    "control_effort",
    "association",
)


@pytest.fixture
def cleanup():
    yield
    for name in ("Far_Away", "only_paper"):
        mjx_radar.unregister_cost_term(name)


def _far_away(weight):
    def far_away(h, task, params):  # weight x metres beyond 100 m, per step
        r = jnp.linalg.norm(h.radar[..., :2], axis=-1)  # [H, N]
        return weight * jnp.maximum(r - 100.0, 0.0).sum(-1)

    return far_away


def test_builtin_terms_are_in_the_registry():
    assert COST_TERMS.names()[: len(BUILT_IN)] == BUILT_IN
    assert cost_plugins.BUILT_IN == BUILT_IN
    assert COST_TERMS.get("radar_target") is costs.radar_target  # "module:attr", imported
    with pytest.raises(ValueError, match="not a built-in term"):
        mjx_radar.register_cost_term("Obstacle", _far_away(1.0))


def test_registered_term_in_the_objective_and_the_key(cleanup):
    smoke = mjx_radar.load_scenario("smoke")
    paper = mjx_radar.load_scenario("paper_3r4t")
    key0 = cost_plugins.registry_key()
    mjx_radar.register_cost_term("Far_Away", _far_away(2.0))
    mjx_radar.register_cost_term("only_paper", _far_away(1.0), enabled=lambda s: s.n_radars == 3)
    assert COST_TERMS.names()[-2:] == ("far_away", "only_paper")
    names = [t.name for t in costs.cost_terms(smoke)]
    assert names[-1] == "Far_Away" and "only_paper" not in names  # its own spelling
    assert [t.name for t in costs.cost_terms(paper)][-2:] == ["Far_Away", "only_paper"]

    key = cost_plugins.registry_key()
    assert key != key0 and [n for n, _ in key] == ["far_away", "only_paper"]
    mjx_radar.register_cost_term("Far_Away", _far_away(2.0))  # same code, same key
    assert cost_plugins.registry_key() == key
    mjx_radar.register_cost_term("Far_Away", _far_away(3.0))  # a closure value changed
    assert cost_plugins.registry_key()[0][1] != key[0][1]
    mjx_radar.unregister_cost_term("FAR_AWAY")
    assert "far_away" not in COST_TERMS and cost_plugins.registry_key()[0][0] == "only_paper"


def test_registered_term_value_and_shape(cleanup):
    mjx_radar.register_cost_term("Far_Away", _far_away(2.0))
    term = COST_TERMS.get("far_away")
    radar = np.zeros((3, 2, 6), np.float32)  # H = 3 steps, N = 2 radars
    radar[:, 0, 0] = [50.0, 130.0, 400.0]
    radar[:, 1, :2] = [[0.0, 160.0], [0.0, 0.0], [300.0, 400.0]]
    h = costs.Horizon(jnp.zeros((3, 2, 2)), jnp.asarray(radar), jnp.zeros((3, 1, 1, 6)), None)
    want = 2.0 * np.array([0.0 + 60.0, 30.0 + 0.0, 300.0 + 400.0])  # closed form
    np.testing.assert_allclose(np.asarray(term(h, None, None)), want, rtol=1e-6)

    mjx_radar.register_cost_term("Far_Away", lambda h, task, params: h.radar[..., 0])
    with pytest.raises(PluginError, match=r"returned shape \[3, 2\]; expected \[3\]"):
        COST_TERMS.get("far_away")(h, None, None)
