"""More planners on the contract: predictive sampling, CEM, gradient MPC and a hybrid.

Each plans the radars' flattened controls ``[H, 2N]`` on the method's objective
(``env.objective(obs)``: information plus keep-out terms, the rollouts MJX or closed
form), warm-started from its previous plan shifted by one control step, inside
``env.action_bounds``. The compute budget is the scenario's MPPI budget,
``mppi.samples x mppi.iterations`` rollouts per control call, for the sampling planners;
the gradient planner takes ``GradientPlanner.steps`` gradient steps (one step costs about
three rollouts: forward and reverse mode). Their settings are the scenario's
``[planner]`` table (:class:`~mjx_radar.scenario.schema_planner.PlannerConfig`,
docs/planners.md).
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp

from mjx_radar.control import gradient, mppi, sampling
from mjx_radar.env.records import ControlRecord
from mjx_radar.planners.base import Planner
from mjx_radar.planners.records import idle_record, plan_record
from mjx_radar.task.planner import proposal_std


class PlanCarry(NamedTuple):
    u_plan: jax.Array  # [H, 2N] warm start of the next call
    record: ControlRecord  # the last call's record


class SequencePlanner(Planner):
    """Shared: warm start, bounds, the objective of an observation, the record."""

    def __init__(self, env):
        super().__init__(env)
        task = env.task
        self.horizon, self.n = task.mpc.horizon, env.n_radars
        self.lower = env.action_bounds[0].reshape(-1)
        self.upper = env.action_bounds[1].reshape(-1)
        self.std = proposal_std(task.mppi, self.upper)
        self.samples, self.iterations = task.mppi.samples, task.mppi.iterations
        self.settings = task.planner  # the [planner] table

    def init(self) -> PlanCarry:
        zeros = jnp.zeros((self.n, 2))
        return PlanCarry(
            jnp.zeros((self.horizon, 2 * self.n)), idle_record(zeros, *self.record_shape)
        )

    def _carry(self, cost_fn, mean, samples=None, costs=None, weights=None, aux=None):
        """The applied control, and the carry holding the next warm start and the record."""
        plan = cost_fn(mean)[1]
        s = self.record_shape[1]
        if samples is None:  # no population: the plan itself
            xy = jnp.broadcast_to(plan.radar_xy, (s, *plan.radar_xy.shape))
            weights, costs = jnp.full(s, 1.0 / s), jnp.zeros(s)
        else:
            xy, weights, costs = aux.radar_xy[:s], weights[:s], costs[:s]
        control = mean[0].reshape(self.n, 2)
        rec = plan_record(control, plan.radar_xy, xy, weights, costs)
        return control, PlanCarry(mppi.shift(mean), rec)

    def record(self, carry: PlanCarry, action) -> ControlRecord:
        return carry.record


class PredictiveSamplingPlanner(SequencePlanner):
    """Predictive sampling (hydrax / MJPC's baseline): the best of ``samples`` Gaussian
    perturbations of the incumbent, ``iterations`` times."""

    name = "ps"

    def plan(self, carry: PlanCarry, obs, key):
        cost = self.env.objective(obs)
        res = sampling.predictive_sampling(
            cost, carry.u_plan, key, self.samples, self.iterations, self.std, self.lower, self.upper
        )
        return self._carry(cost, res.mean, res.samples, res.costs, res.weights, res.aux)


class CEMPlanner(SequencePlanner):
    """The cross-entropy method: refit a diagonal Gaussian to the ``elite_fraction`` best."""

    name = "cem"

    def plan(self, carry: PlanCarry, obs, key):
        cost = self.env.objective(obs)
        elite = max(1, int(round(self.settings.elite_fraction * self.samples)))
        res = sampling.cross_entropy(
            cost,
            carry.u_plan,
            key,
            self.samples,
            self.iterations,
            self.std,
            self.lower,
            self.upper,
            elite,
            self.settings.std_floor * self.std,  # the search never collapses
        )
        return self._carry(cost, res.mean, res.samples, res.costs, res.weights, res.aux)


class GradientPlanner(SequencePlanner):
    """Gradient MPC: ``[planner] gradient_steps`` projected optax steps (Adam by default)
    through the rollouts and the information objective, from the shifted previous plan."""

    name = "grad"

    def plan(self, carry: PlanCarry, obs, key):
        cost = self.env.objective(obs)
        st = self.settings
        res = gradient.descend(
            cost,
            carry.u_plan,
            st.gradient_steps,
            self.lower,
            self.upper,
            st.learning_rate,
            st.optimizer,
        )
        return self._carry(cost, res.mean)


class HybridPlanner(SequencePlanner):
    """Predictive sampling (half the iterations), then gradient polish of the best."""

    name = "hybrid"

    def plan(self, carry: PlanCarry, obs, key):
        cost = self.env.objective(obs)
        res = sampling.predictive_sampling(
            cost,
            carry.u_plan,
            key,
            self.samples,
            max(1, self.iterations // 2),
            self.std,
            self.lower,
            self.upper,
        )
        st = self.settings
        pol = gradient.descend(
            cost,
            res.mean,
            st.polish_steps,
            self.lower,
            self.upper,
            st.polish_learning_rate,
            st.optimizer,
        )
        mean = jnp.where(pol.best_cost < res.best_cost, pol.mean, res.mean)
        return self._carry(cost, mean, res.samples, res.costs, res.weights, res.aux)
