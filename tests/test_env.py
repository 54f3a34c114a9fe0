"""The closed loop as an environment (issue 32): reset / step / transition, the planner
contract, registered planners, and the runner as a planner-driven scan of the env."""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import mjx_radar
from mjx_radar.engine import runner
from mjx_radar.engine.run_spec import run_spec
from mjx_radar.env import Observation, RadarEnv, make
from mjx_radar.env.streams import streams_of
from mjx_radar.loop import closed_loop
from mjx_radar.planners import PLANNERS, Planner, register_planner, unregister_planner
from mjx_radar.task.method import parse_method
from mjx_radar.task.params import shape_key, task_params
from mjx_radar.task.task import make_task


def flat(tree):
    return np.concatenate([np.ravel(np.asarray(x, float)) for x in jax.tree.leaves(tree)])


def test_reset_vmaps_over_keys_and_step_scans(tiny):
    """``jit(vmap(reset))`` over 8 keys equals 8 single resets; a ``lax.scan`` of
    ``env.step`` runs 40 control periods, ``done`` from the episode's last one on."""
    env = make(tiny, "ddr-sfim")
    # jitted, and host indexing below: eagerly, every small op compiles on its own
    keys = np.asarray(jax.jit(jax.vmap(lambda t: env.trial_key(7, t)))(jnp.arange(8)))
    states = jax.jit(jax.vmap(env.reset))(keys)
    assert states.obs.radar_state.shape == (8, tiny.n_radars, 6)
    assert states.obs.cov.shape == (8, 6 * tiny.n_targets, 6 * tiny.n_targets)
    one = jax.jit(env.reset)(keys[3])
    np.testing.assert_array_equal(flat(jax.tree.map(lambda x: np.asarray(x)[3], states)), flat(one))
    assert len({float(x) for x in np.asarray(states.obs.radar_state)[:, 0, 0]}) == 8  # 8 placements

    # the radars accelerate straight ahead: speed grows by accel*dt per period until v_max
    a_max = tiny.limits.accel
    action = np.tile(np.array([a_max, 0.0], np.float32), (tiny.n_radars, 1))

    def body(s, _):
        s = env.step(s, action)
        return s, (s.reward, s.done, s.obs.radar_state[:, 4], s.metrics["rmse_pos"])

    final, (reward, done, speed, rmse) = jax.jit(lambda s: jax.lax.scan(body, s, None, length=40))(
        one
    )
    assert int(final.info["period"]) == 40 and env.episode_length == 20
    np.testing.assert_array_equal(np.asarray(done), np.arange(1, 41) >= 20)
    assert np.all(np.isfinite(reward)) and np.all(np.isfinite(rmse))
    v = np.asarray(speed)  # [40, N]
    assert np.all(np.diff(v, axis=0) >= -1e-5) and np.all(v <= tiny.limits.speed + 1e-4)
    assert np.all(v[-1] > v[0])


def test_observation_holds_no_truth_and_reward_is_minus_log_det(tiny):
    """The observation's fields; the reward against numpy's slogdet in float64 (the
    PSD-safe Cholesky log det agrees to round-off there)."""
    from mjx_radar.estimation.filters import ckf_sqrt
    from mjx_radar.physics import plant

    with jax.enable_x64(True):
        env = make(tiny, "ddr-sfim")
        state = jax.jit(env.step)(jax.jit(env.reset)(env.trial_key(7, 0)), jnp.zeros((2, 2)))
        # jitted (eagerly, each of their small ops compiles on its own)
        truth = jax.jit(lambda d: plant.target_state(env.task.truth, d))(state.loop.data)
        obs_vector = jax.jit(env.observation_vector)(state.obs)
    assert set(Observation._fields) == {
        "radar_state", "mean", "cov", "target_weight", "detections", "time", "period",
        "nonfinite_action",
    }  # fmt: skip
    # the planner sees the tracker's estimate (mpc.aligned), never the truth
    np.testing.assert_array_equal(state.obs.mean, state.loop.mean)
    truth = np.asarray(truth).reshape(-1)
    assert not np.allclose(state.obs.mean, truth, atol=1e-3)
    # reward: -sum_m log det P_m,pos of the posterior (numpy's slogdet)

    cov = np.asarray(ckf_sqrt.form_ops(tiny.filter.form).cov(state.loop.cov), np.float64)
    want = -sum(np.linalg.slogdet(cov[6 * i : 6 * i + 3, 6 * i : 6 * i + 3])[1] for i in range(2))
    np.testing.assert_allclose(float(state.reward), want, rtol=1e-10)
    assert obs_vector.shape == (env.observation_size,)
    assert float(state.obs.time) == pytest.approx(tiny.timing.dt_control)


def test_planner_driven_env_equals_simulate(tiny):
    """A host loop of the MPPI planner and ``env.transition``, each jitted on its own, gives
    ``simulate``'s trial (the runner's ``lax.scan`` of ``planner.plan`` + ``env.transition``)
    to float64 round-off (a mis-indexed planner key or a stale observation differ at O(1)).
    (A user's scan of ``env.step`` is the first test's; ``step`` is ``transition``'s state.)"""
    periods = 3
    with jax.enable_x64(True):
        task = make_task(shape_key(tiny), "sfim")
        params = task_params(tiny, parse_method("ddr-sfim"))
        env = RadarEnv(task, params)
        planner = PLANNERS.get("mppi")(env)
        trial = 1
        want = jax.jit(lambda: closed_loop.simulate(task, params, trial, periods * env.every))()
        key = env.trial_key(params.seed, trial)
        state, pc = jax.jit(env.reset)(key), planner.init()
        plan, transition = jax.jit(planner.plan), jax.jit(env.transition)
        srecs = []
        for j in range(periods):
            k = jax.random.fold_in(streams_of(key).planner, j)
            action, pc = plan(pc, state.obs, k)
            state, srec = transition(state, action)
            srecs.append(srec)
    cat = jax.tree.map(lambda *x: np.concatenate(x), *srecs)
    np.testing.assert_allclose(flat(cat), flat(want.steps), rtol=1e-9, atol=1e-9)
    np.testing.assert_array_equal(np.asarray(state.loop.mean), cat.mean[-1])
    assert not np.allclose(cat.radar[-1], cat.radar[0])  # the radars moved


class FullThrottle(Planner):
    """Asks for 1000 times the acceleration limit, turning left: the env must clip it."""

    def plan(self, carry, obs, key):
        n = obs.radar_state.shape[0]
        return jnp.tile(jnp.array([1e3, 1e3]), (n, 1)) * self.env.action_bounds[1], carry + 1

    def init(self):
        return jnp.int32(0)


def test_registered_planner_runs_in_the_runner_with_clipped_actions(tiny):
    register_planner("full-throttle", FullThrottle)
    try:
        res = runner.run_trials(run_spec(tiny), "ddr-sfim+full-throttle", 0, np.arange(2), 8)
    finally:
        unregister_planner("full-throttle")
    lim = tiny.limits
    np.testing.assert_allclose(res["control"], np.broadcast_to([lim.accel, lim.alpha],
                                                               res["control"].shape))  # fmt: skip
    v = res["radar"][..., 4]  # [T, K, N] speed: grows at most accel * dt_filter a step
    dv = np.diff(v, axis=1)
    assert np.all(dv <= lim.accel * tiny.timing.dt_filter + 1e-4) and np.all(dv > 0)


def test_planner_registry_contract():
    with pytest.raises(ValueError, match="planner: 'nope' is not one of mppi, hold"):
        PLANNERS.get("nope")
    with pytest.raises(ValueError, match="built-in planner"):
        register_planner("mppi", FullThrottle)
    with pytest.raises(ValueError, match="radars never move"):
        parse_method("stationary", "full-throttle")
    assert parse_method("ddr-pfim+x").planner == "x" and parse_method("ddr-pfim+x").info == "pfim"
    assert parse_method("ddr-sfim", "mppi") is mjx_radar.parse_method("ddr-sfim")
    # a registered planner's code is part of the program cache key
    register_planner("k1", FullThrottle)
    before = PLANNERS.key(("k1",))

    class Other(FullThrottle):
        def init(self):
            return jnp.int32(1)

    register_planner("k1", Other)
    try:
        assert PLANNERS.key(("k1",)) != before and PLANNERS.key(("mppi",)) == ()
    finally:
        unregister_planner("k1")


def test_study_keeps_planner_method_names(tmp_path):
    """A study's consolidated table keeps "METHOD+PLANNER" names (study --planners) after
    the paper's methods, in order of appearance (they were NaN categories before)."""
    import pandas as pd

    from mjx_radar.study.consolidate import read_chunks

    paths = []
    for i, m in enumerate(["ddr-sfim+ps", "stationary", "ddr-sfim", "ddr-sfim+cem"]):
        p = tmp_path / f"c{i}.parquet"
        pd.DataFrame({"scenario": ["s"], "method": [m], "trial": [0], "step": [1]}).to_parquet(p)
        paths.append(p)
    frame = read_chunks(paths, ["s"])
    assert list(frame["method"].cat.categories) == [
        "stationary", "ddr-sfim", "ddr-sfim+ps", "ddr-sfim+cem"
    ]  # fmt: skip
    assert frame["method"].notna().all()


def test_registered_sensor_and_tracker_are_selected_by_the_scenario(tiny):
    """``[measurement] model`` accepts a registered sensor and ``[filter] tracker`` a
    registered tracker (one-line refusal for unknown names); the task and the environment
    use them."""
    import mjx_radar
    from mjx_radar.env import filter_ops
    from mjx_radar.estimation.sensor.measurement import RangeModel
    from mjx_radar.scenario.reader import ScenarioError

    with pytest.raises(ScenarioError, match=r"measurement\.model = 'twin': must be one of range"):
        tiny.replace(measurement={"model": "twin"})
    with pytest.raises(ScenarioError, match=r"filter\.tracker = 'mine': must be one of auto"):
        tiny.replace(filter={"tracker": "mine"})
    calls = []

    def mine(task, params):
        calls.append(task.measurement.name)
        return filter_ops.ckf_bank(task, params)

    @dataclasses.dataclass(frozen=True)
    class Twin(RangeModel):
        name: str = "twin"

    mjx_radar.register_sensor("twin", Twin)
    mjx_radar.register_tracker("mine", mine)
    try:
        s = tiny.replace(measurement={"model": "twin"}, filter={"tracker": "mine"})
        env = make(s, "ddr-sfim")
        assert isinstance(env.task.measurement, Twin) and calls == ["twin"]
        with pytest.raises(TypeError, match="MeasurementModel subclass"):
            mjx_radar.register_sensor("bad", object)
    finally:
        mjx_radar.unregister_sensor("twin")
        mjx_radar.unregister_tracker("mine")
