"""The planner zoo (issue 33): predictive sampling, CEM, gradient MPC and the hybrid.

Each optimiser reaches the known optimum of a convex toy objective, keeps its sequences
inside the box, and the gradient of the radar objective through the rollouts matches
central finite differences.
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_radar.control import gradient, sampling
from mjx_radar.engine import runner
from mjx_radar.engine.run_spec import run_spec

H, D = 4, 2
LOWER, UPPER = jnp.array([-2.0, -1.0]), jnp.array([2.0, 1.0])
WEIGHT = jnp.array([1.0, 4.0])


def _quadratic(target):
    def cost(u):
        return jnp.sum(WEIGHT * (u - target) ** 2), {"u": u}

    return cost


@pytest.fixture(scope="module")
def inside():
    return jnp.array([[0.5, -0.3], [1.0, 0.2], [-1.5, 0.7], [0.0, -0.9]])


def test_predictive_sampling_reaches_a_convex_optimum(inside):
    res = jax.jit(lambda k: sampling.predictive_sampling(
        _quadratic(inside), jnp.zeros((H, D)), k, 256, 60, jnp.array([0.3, 0.15]), LOWER, UPPER
    ))(jax.random.PRNGKey(0))  # fmt: skip
    # 2.44 at the start, 0 at the optimum; a fixed-scale search (std 0.3 / 0.15 in 8
    # dimensions) refines to a few hundredths in 60 rounds of 256
    assert float(res.best_cost) < 0.1
    # every coordinate within sqrt(cost / weight) <= sqrt(0.1) of the optimum
    np.testing.assert_allclose(res.mean, inside, atol=0.32)
    assert float(_quadratic(inside)(res.mean)[0]) == pytest.approx(float(res.best_cost))


def test_cross_entropy_reaches_a_convex_optimum(inside):
    res = jax.jit(lambda k: sampling.cross_entropy(
        _quadratic(inside), jnp.zeros((H, D)), k, 256, 30, jnp.array([1.0, 0.5]), LOWER, UPPER,
        elite=25, std_min=1e-4,
    ))(jax.random.PRNGKey(1))  # fmt: skip
    np.testing.assert_allclose(res.mean, inside, atol=0.02)
    assert np.all(np.asarray(res.samples) >= LOWER - 1e-6)
    assert np.all(np.asarray(res.samples) <= UPPER + 1e-6)


def test_gradient_descent_reaches_the_optimum_and_the_box(inside):
    outside = inside.at[1, 0].set(5.0).at[2, 1].set(-3.0)  # beyond the box: on its face
    for target in (inside, outside):
        res = jax.jit(lambda t=target: gradient.descend(
            _quadratic(t), jnp.zeros((H, D)), 400, LOWER, UPPER, 0.05))()  # fmt: skip
        np.testing.assert_allclose(res.mean, jnp.clip(target, LOWER, UPPER), atol=2e-3)
    assert float(res.mean[1, 0]) == pytest.approx(2.0) and float(res.mean[2, 1]) == -1.0


def test_cross_entropy_refuses_a_bad_elite():
    with pytest.raises(ValueError, match="elite = 0"):
        sampling.cross_entropy(_quadratic(0.0), jnp.zeros((H, D)), jax.random.PRNGKey(0), 8, 1,
                               jnp.ones(D), LOWER, UPPER, elite=0)  # fmt: skip


def _added(u, i, h):
    """A copy of ``u`` with ``h`` added to entry ``i``."""
    out = u.copy()
    out[i] += h
    return out


@pytest.mark.parametrize(
    "rollout",
    ["analytic", pytest.param("mjx", marks=pytest.mark.slow)],  # suite time
)
def test_objective_gradient_matches_finite_differences(rollout):
    """d cost / d u through the rollouts and the information objective (float64) against
    central differences (h = 1e-4 m/s^2; truncation O(h^2) ~ 1e-8 relative)."""
    from mjx_radar.env import make
    from mjx_radar.scenario.reader import load_scenario

    with jax.enable_x64(True):
        s = load_scenario("paper_3r4t")
        s = dataclasses.replace(s, mpc=dataclasses.replace(s.mpc, horizon=4, rollout=rollout))
        env = make(s, "ddr-sfim")
        state = jax.jit(env.reset)(env.trial_key(0, 0))
        # the objective's planning context is traced inside each jitted function (eagerly,
        # each of its many small ops compiles on its own)
        cost = lambda x: env.objective(state.obs)(x)[0]  # noqa: E731
        # host float64 arithmetic below: the same IEEE operations as jnp's, no compilations
        u = 0.3 * np.asarray(jax.random.normal(jax.random.PRNGKey(2), (4, 2 * env.n_radars)))
        u = u * np.asarray(env.action_bounds[1]).reshape(-1)
        g = np.asarray(jax.jit(jax.grad(cost))(u))
        f = jax.jit(cost)
        idx = [(0, 0), (0, 1), (1, 2), (2, 5), (3, 3)]
        fd = [(float(f(_added(u, i, 1e-4))) - float(f(_added(u, i, -1e-4)))) / 2e-4 for i in idx]
    np.testing.assert_allclose([g[i] for i in idx], fd, rtol=1e-5, atol=1e-9)
    assert np.any(np.abs(np.asarray(g)) > 1e-6)


@pytest.mark.parametrize(
    "planner",
    [
        pytest.param("ps", marks=pytest.mark.slow),  # CI: test_env, test_runner run it
        "grad",
        pytest.param("cem", marks=pytest.mark.slow),
        "cmaes",
        pytest.param("cem", marks=pytest.mark.slow),
        pytest.param("hybrid", marks=pytest.mark.slow),
        pytest.param("sep-cmaes", marks=pytest.mark.slow),
    ],  # suite time: CI runs two
)
def test_every_planner_runs_inside_the_limits(tiny, planner):
    res = runner.run_trials(run_spec(tiny), f"ddr-sfim+{planner}", 0, np.arange(2), 8)
    lim = np.array([tiny.limits.accel, tiny.limits.alpha])
    assert np.all(np.abs(res["control"]) <= lim + 1e-5)
    assert np.all(np.isfinite(res["rmse_pos"])) and np.any(res["control"] != 0)


@pytest.mark.parametrize("algorithm", ["cma_es", "sep_cma_es"])
def test_evolution_strategy_reaches_a_convex_optimum_and_the_box(inside, algorithm):
    from mjx_radar.control import evolution

    outside = inside.at[1, 0].set(5.0).at[2, 1].set(-3.0)  # beyond the box: on its face
    for target in (inside, outside):
        res = jax.jit(lambda k, t=target: evolution.evolve(
            _quadratic(t), jnp.zeros((H, D)), k, 32, 120, jnp.array([0.5, 0.25]), LOWER, UPPER,
            algorithm,
        ))(jax.random.PRNGKey(2))  # fmt: skip
        # 8 dimensions, 120 generations of 32: CMA-ES converges geometrically on a
        # quadratic (cost 2.44 -> < 1e-6); 1e-3 per coordinate is cost < 1e-5
        np.testing.assert_allclose(res.mean, jnp.clip(target, LOWER, UPPER), atol=1e-3)
        assert np.all(np.asarray(res.samples) >= LOWER - 1e-6)
        assert np.all(np.asarray(res.samples) <= UPPER + 1e-6)
        assert float(res.best_cost) == pytest.approx(
            float(_quadratic(target)(res.mean)[0]), rel=1e-5, abs=1e-7
        )


def test_lbfgs_reaches_the_optimum_and_the_box(inside):
    outside = inside.at[1, 0].set(5.0).at[2, 1].set(-3.0)
    for target in (inside, outside):
        res = jax.jit(lambda t=target: gradient.descend(
            _quadratic(t), jnp.zeros((H, D)), 30, LOWER, UPPER, optimizer="lbfgs"))()  # fmt: skip
        # a quadratic: L-BFGS with a line search needs a handful of steps inside the box;
        # at the face the projection stops it there
        np.testing.assert_allclose(res.mean, jnp.clip(target, LOWER, UPPER), atol=1e-4)


def test_planner_table_sets_the_gradient_steps(tiny):
    """``[planner] gradient_steps`` reaches the grad planner: the plan changes with it
    (on ``tiny``: analytic rollouts, whose gradient compiles far faster than MJX's)."""
    from mjx_radar.env import make
    from mjx_radar.planners import base

    actions = []
    for steps in (1, 12):
        env = make(tiny.replace(planner={"gradient_steps": steps}), "ddr-sfim")
        planner = base.make("grad", env)
        assert planner.settings.gradient_steps == steps
        state = jax.jit(env.reset)(env.trial_key(0, 0))  # one program, not op by op
        action, _ = jax.jit(planner.plan)(planner.init(), state.obs, jax.random.PRNGKey(0))
        actions.append(np.asarray(action))
        assert np.all(np.isfinite(actions[-1]))
    assert np.abs(actions[1] - actions[0]).max() > 1e-6


def test_missing_optional_dependency_is_one_line():
    from mjx_radar.registry import Registry

    reg = Registry("planner", {"es": "mjx_radar_no_such_module:Planner"})
    with pytest.raises(ValueError, match=r"^planner 'es': No module named"):
        reg.get("es")
