"""The closed loop of paper Algorithm 1 as a pure environment (brax / mujoco_playground style).

One ``env.step`` is one control period (``env.dt = dt_control``): the radars apply the
action for ``control_every`` filter steps, each::

    tracker predict                       (x_k|k-1, P_k|k-1)
    MJX plant step: drones fly (white acceleration w_k), radars actuate the action
    measure all N*M pairs with the true (DDR) noise; detections, clutter, line of sight
    tracker update (DDR or CCR noise model, per method); errors, NEES, PCRLB, lost track

then the observation for the next plan is formed. ``reset``, ``step`` and
``transition`` are pure functions of arrays: jit them, vmap them over keys, scan them
over time. A planner (:mod:`mjx_radar.planners`) closes the loop
(:func:`mjx_radar.env.driver.rollout`); the simulator's runner is that scan.

Random numbers (common random numbers, SPEC §9): every stream of a trial derives from
the key given to ``reset`` (:func:`trial_key`: ``fold_in(PRNGKey(seed), trial)``), so
every method and planner sees the same placement, truth and noise draws.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from mjx_radar import precision
from mjx_radar.env import inputs, placement, presence, track_health, trackers
from mjx_radar.env.period import make_filter_step
from mjx_radar.env.state import LoopState, Observation, State
from mjx_radar.env.streams import streams_of, trial_key
from mjx_radar.estimation import linalg
from mjx_radar.estimation.filters import ckf_sqrt
from mjx_radar.io.checks import ScenarioError
from mjx_radar.physics import plant as physics
from mjx_radar.task import objective
from mjx_radar.task.planner import control_box

#: the per-period metrics of ``State.metrics`` (the last filter step's values)
METRICS = (
    "rmse_pos",
    "rmse_state",
    "nees",
    "crlb_pos",
    "lost",
    "diverged",
    "visible_pairs",
    "detections",
    "false_alarms",
    "targets_present",
)


class RadarEnv:
    """Radars tracking drones, one control period a step.

    Args:
        task: the scenario's :class:`~mjx_radar.task.task.RadarTask` (static).
        params: its :class:`~mjx_radar.task.params.TaskParams` (arrays; may be traced).
        steps: filter steps of an episode (default the scenario's).

    Attributes:
        dt: the control period [s]; ``episode_length``: control periods per episode;
        action_size: ``2N`` (``[a, α]`` per radar); observation_size: length of
        :meth:`observation_vector`; action_bounds: ``(lower, upper)`` each ``[N, 2]``.
    """

    def __init__(self, task, params, steps: int | None = None):
        self.task, self.params, t = task, params, task.timing
        self.every = t.control_every
        steps = t.steps if steps is None else steps
        if steps % self.every:
            raise ValueError(f"steps: {steps} must be a multiple of {self.every}")
        self.episode_length = steps // self.every
        self.dt = t.dt_control
        self.n_radars, self.n_targets = task.fleet.n_radars, task.n_targets
        self.action_size = 2 * self.n_radars
        self._form = ckf_sqrt.form_ops(task.filter.form)
        self._tracker = trackers.make(task, params)
        self._table = self._tracker.tracks  # None: the joint estimate, indexed like the truth
        #: tracks the planner sees: M (the joint estimate) or the table's K slots
        self.n_tracks = self.n_targets if self._table is None else task.tracker.max_tracks
        m, n = self.n_tracks, self.n_radars
        self.observation_size = 6 * n + 6 * m + 21 * m + m + n * m
        lower, upper = control_box(task.fleet)
        self.action_bounds = (lower.reshape(n, 2), upper.reshape(n, 2))
        self._layout = placement.layout_of(task)  # N, M, the ground, fixed starts

    @staticmethod
    def trial_key(seed, trial) -> jax.Array:
        """The key of trial ``trial`` of base seed ``seed`` (what the runner resets with)."""
        return trial_key(seed, trial)

    # -- the contract -------------------------------------------------------------------

    def reset(self, key) -> State:
        """The state at t = 0 of the trial whose key is ``key`` (radars placed, tracks started)."""
        inputs.check_key(key)
        return precision.pinned(self._reset)(key)

    def step(self, state: State, action) -> State:
        """Applies ``action`` (``[N, 2]`` or ``[2N]``, clipped to the limits) for one period.

        The reward is ``-Σ_m log det P_m,pos`` over the targets present at the period's end
        (``P_m,pos`` the 3x3 position block of target m's posterior covariance [m²]): the
        information the radars hold about where the drones are. A wrongly shaped action
        (or, outside ``jit``, a non-finite one) is refused in one line (:mod:`.inputs`);
        inside ``jit`` each NaN or inf control is applied as 0 and the next observation's
        ``nonfinite_action`` is True.
        """
        inputs.check_state(state, State)
        return self.transition(state, action)[0]

    def transition(self, state: State, action, keep_nonfinite: bool = False):
        """:meth:`step` and the period's per-filter-step records (``StepRecord``, leading
        size ``control_every``): what the simulator's runner writes. ``keep_nonfinite``
        (the runner's loop) applies a planner's NaN as given (flagged too), so the trial
        diverges and the run names the planner instead of going on with zeros."""
        return precision.pinned(self._transition)(state, action, keep_nonfinite)

    # -- helpers for planners -----------------------------------------------------------

    def planning_params(self, obs: Observation):
        """The runtime parameters a planner scores with at ``obs``'s instant (the
        presence weights, the moving obstacles' time; a track table's own weights)."""
        params = presence.plan_params(self.params, obs.time)
        if self._table is not None:  # the planner plans for the table's tracks
            params = params._replace(target_weight=obs.target_weight)
        return params

    def objective(self, obs: Observation):
        """``cost(u [H, 2N]) -> (cost [], Plan)``: the method's objective (information
        and keep-out terms, discounted) of a control sequence from ``obs``. Vmap it over
        candidate sequences."""
        ctx = objective.plan_context(self.task, obs.radar_state, obs.mean, obs.cov)
        fn, params = objective.make_objective(self.task), self.planning_params(obs)
        return lambda u: fn(u.reshape(self.task.mpc.horizon, -1), ctx, params)

    def observation_vector(self, obs: Observation) -> jax.Array:
        """``[observation_size]`` flat features: radar states, track means, the upper
        triangles of the targets' 6x6 covariance blocks, presence, detections."""
        m = obs.mean.shape[0] // 6
        blocks = jnp.stack([obs.cov[6 * i : 6 * i + 6, 6 * i : 6 * i + 6] for i in range(m)])
        iu = np.triu_indices(6)  # static indices
        return jnp.concatenate(
            [
                obs.radar_state.reshape(-1),
                obs.mean,
                blocks[:, iu[0], iu[1]].reshape(-1),
                obs.target_weight,
                obs.detections.reshape(-1).astype(obs.mean.dtype),
            ]
        )

    # -- internals ----------------------------------------------------------------------

    def _reset(self, key) -> State:
        params, m = self.params, self.n_targets
        init = placement.initial_conditions(self._layout, params, streams_of(key))
        loop = LoopState(
            data=physics.init_data(self.task.truth, init.radar_state, init.target_state),
            mean=init.mean,
            cov=self._form.carry(init.cov),
            pfim=jnp.broadcast_to(jnp.eye(6) / params.p0, (m, 6, 6)),
            health=track_health.init_health(m),
            modes=self._tracker.init(init.mean, init.cov),
        )
        none_seen = jnp.zeros((self.n_radars, self.n_tracks), bool)
        period = jnp.int32(0)
        zero = jnp.zeros((), init.mean.dtype)
        metrics = {k: zero for k in METRICS}
        return State(
            loop=loop,
            obs=self._observe(loop, period, none_seen, jnp.asarray(False)),
            reward=self._reward(loop, period),
            done=jnp.asarray(False),
            metrics=metrics,
            info={"key": key, "period": period, "placement_ok": init.ok},
        )

    def clip_action(self, action) -> jax.Array:
        """``action`` (``[N, 2]`` or ``[2N]``) as ``[N, 2]`` within ``action_bounds``."""
        lower, upper = self.action_bounds
        return jnp.clip(inputs.check_action(action, self.n_radars), lower, upper)

    def _transition(self, state: State, action, keep_nonfinite: bool = False):
        a = inputs.check_action(action, self.n_radars)
        a_safe, bad = inputs.finite_controls(a)
        u = jnp.clip(a if keep_nonfinite else a_safe, *self.action_bounds)
        j = state.info["period"]
        key = state.info["key"]
        filter_step = make_filter_step(self.task, self.params, key, self._tracker)
        ks = j * self.every + 1 + jnp.arange(self.every)
        loop, (srec, seen) = jax.lax.scan(lambda c, k: filter_step(c, k, u), state.loop, ks)
        j1 = j + 1
        metrics = {k: getattr(srec, k)[-1].astype(state.reward.dtype) for k in METRICS}
        new = state._replace(
            loop=loop,
            obs=self._observe(loop, j1, seen[-1], bad),
            reward=self._reward(loop, j1),
            done=j1 >= self.episode_length,
            metrics=metrics,
            info={**state.info, "period": j1},
        )
        return new, srec

    def _observe(self, loop: LoopState, j, seen, bad) -> Observation:
        """What the planner of control period ``j`` knows (the loop after ``j`` periods;
        ``bad``: the last action held NaN or inf)."""
        t = j * self.every * self.task.timing.dt_filter
        if self._table is not None:
            return self._observe_table(loop, j, t, bad)
        pm, pc, modes = loop.mean, loop.cov, loop.modes
        if not self.task.mpc.aligned:  # the paper code's one-filter-step lead of the targets
            pm, pc, modes = self._tracker.predict(loop.mean, loop.cov, loop.modes)
        if self._tracker.plan_view is not None:  # e.g. the MHT's mixture (the metrics: pm)
            pm, pc = self._tracker.plan_view(pm, pc, modes)
        weight = presence.plan_params(self.params, t).target_weight
        if weight is None:
            weight = jnp.ones(self.n_targets, pm.dtype)
        return Observation(
            radar_state=physics.radar_state(self.task.truth, loop.data),
            mean=pm,
            cov=self._form.cov(pc),  # P (S Sᵀ for the square-root form)
            target_weight=weight,
            detections=seen,
            time=jnp.asarray(t, pm.dtype),
            period=j,
            nonfinite_action=bad,
        )

    def _observe_table(self, loop: LoopState, j, t, bad) -> Observation:
        """What the planner knows with a track table: its K slots (never the truth)."""
        modes = loop.modes
        if not self.task.mpc.aligned:
            modes = self._tracker.predict(loop.mean, loop.cov, modes)[2]
        v = self._table(modes)
        k = v.mean.shape[0]
        return Observation(
            radar_state=physics.radar_state(self.task.truth, loop.data),
            mean=v.mean.reshape(-1),
            cov=jax.scipy.linalg.block_diag(*[v.cov[i] for i in range(k)]),
            target_weight=v.weight,
            detections=v.seen,
            time=jnp.asarray(t, v.mean.dtype),
            period=j,
            nonfinite_action=bad,
        )

    def _reward(self, loop: LoopState, j):
        """``-Σ_m log det P_m,pos`` over the targets present after ``j`` periods (a
        track table: over its tracks, with the planner's weights)."""
        if self._table is not None:
            v = self._table(loop.modes)
            return -jnp.sum(v.weight * jax.vmap(linalg.logdet_psd)(v.cov[:, :3, :3]))
        cov = self._form.cov(loop.cov)
        m = self.n_targets
        pos = jnp.stack([cov[6 * i : 6 * i + 3, 6 * i : 6 * i + 3] for i in range(m)])
        logdet = jax.vmap(linalg.logdet_psd)(pos)  # [M]
        t = j * self.every * self.task.timing.dt_filter
        weight = presence.plan_params(self.params, t).target_weight
        weight = jnp.ones(m, logdet.dtype) if weight is None else weight
        return -jnp.sum(weight * logdet)


def make(scenario, method="ddr-sfim", seed: int | None = None, steps: int | None = None):
    """The environment of a scenario and method (``mjx_radar.env.make``).

    Args:
        scenario: a validated :class:`~mjx_radar.config.Scenario` (or a bundled name /
            file path, read with :func:`mjx_radar.load_scenario`).
        method: a method name (``"ddr-sfim"``, ...) or :class:`~mjx_radar.task.method.Method`:
            the tracker's noise model and the information of ``env.objective``.
        seed: base seed of :meth:`RadarEnv.trial_key` (default the scenario's).
        steps: filter steps of an episode (default the scenario's).

    Example:
        >>> env = make("smoke")
        >>> state = jax.jit(env.reset)(env.trial_key(env.params.seed, 0))
        >>> state = jax.jit(env.step)(state, jnp.zeros((env.n_radars, 2)))
    """
    from mjx_radar.task.method import parse_method
    from mjx_radar.task.params import shape_key, task_params
    from mjx_radar.task.task import make_task

    scenario = inputs.check_scenario(scenario)
    try:
        method = parse_method(method)
    except ValueError as err:
        raise ScenarioError(str(err)) from None
    seed = inputs.check_seed(seed)
    steps = inputs.check_steps(steps, scenario.timing.control_every)
    task = make_task(shape_key(scenario), method.kind)
    return RadarEnv(task, task_params(scenario, method, seed), steps)
