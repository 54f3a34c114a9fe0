"""Evolution-strategy planners through evosax: CMA-ES and separable CMA-ES.

Plug-ins of the planner contract like :mod:`mjx_radar.planners.zoo` (warm start, box,
record): each control call runs ``mppi.iterations`` generations of ``mppi.samples``
candidates (the common budget, rollouts per call) of
:func:`mjx_radar.control.evolution.evolve` from the shifted previous plan, the initial
step ``[planner] es_std_init`` proposal standard deviations. evosax is optional
(``pip install -e ".[es]"``); selecting these planners without it fails in one line.
"""

from __future__ import annotations

from mjx_radar.control import evolution
from mjx_radar.planners.zoo import PlanCarry, SequencePlanner


class CMAESPlanner(SequencePlanner):
    """CMA-ES (evosax ``CMA_ES``): a full covariance over the ``H x 2N`` controls."""

    name = "cmaes"
    algorithm = "cma_es"

    def plan(self, carry: PlanCarry, obs, key):
        cost = self.env.objective(obs)
        res = evolution.evolve(
            cost,
            carry.u_plan,
            key,
            max(4, self.samples),
            self.iterations,
            self.std,
            self.lower,
            self.upper,
            self.algorithm,
            self.settings.es_std_init,
        )
        return self._carry(cost, res.mean, res.samples, res.costs, res.weights, res.aux)


class SepCMAESPlanner(CMAESPlanner):
    """Separable CMA-ES (evosax ``Sep_CMA_ES``): a diagonal covariance."""

    name = "sep-cmaes"
    algorithm = "sep_cma_es"
