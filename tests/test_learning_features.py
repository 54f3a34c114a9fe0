"""What a learned policy sees, does and is paid (issue 34), without the rl extra:
features against numpy, the action map, the keep-out penalty against closed forms,
planner names with an argument (``policy:DIR``) and their cache-key digests."""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_radar.env import Observation, make
from mjx_radar.learning import features as F
from mjx_radar.registry import Registry
from mjx_radar.study.chunks import file_label


@pytest.fixture(scope="module")
def env(tiny):
    return make(tiny, "ddr-sfim")


# The library functions run jitted: eagerly, each of their small ops compiles on its own.


def _obs(env, rng, radar_xy=None):
    n, m = env.n_radars, env.n_targets
    a = rng.normal(size=(6 * m, 6 * m))
    cov = a @ a.T + 6 * m * np.eye(6 * m)
    rs = np.zeros((n, 6))
    rs[:, :2] = rng.uniform(-300, 300, (n, 2)) if radar_xy is None else radar_xy
    rs[:, 3:] = rng.uniform(-1, 1, (n, 3))
    return Observation(
        radar_state=jnp.asarray(rs, jnp.float32),
        mean=jnp.asarray(rng.normal(scale=100.0, size=6 * m), jnp.float32),
        cov=jnp.asarray(cov, jnp.float32),
        target_weight=jnp.ones(m),
        detections=jnp.asarray(rng.uniform(size=(n, m)) < 0.5),
        time=jnp.float32(0.0),
        period=jnp.int32(0),
    )


def test_features_against_numpy(env):
    """Each block of the features, recomputed in float64 numpy from the observation."""
    rng = np.random.default_rng(3)
    obs = _obs(env, rng)
    f = np.asarray(jax.jit(lambda o: F.features(env, o))(obs), np.float64)
    n, m = env.n_radars, env.n_targets
    assert f.shape == (F.feature_size(n, m),) and np.all(np.isfinite(f))
    lim, big_l = env.task.fleet.limits, float(env.params.placement_half_width)
    rs, mean, cov = (np.asarray(x, np.float64) for x in (obs.radar_state, obs.mean, obs.cov))
    i = 0
    radar = f[i : i + 7 * n].reshape(n, 7)
    i += 7 * n
    np.testing.assert_allclose(radar[:, :3], rs[:, :3] / big_l, atol=1e-6)
    np.testing.assert_allclose(radar[:, 3], np.cos(rs[:, 3]), atol=1e-6)
    np.testing.assert_allclose(radar[:, 6], rs[:, 5] / lim.omega, atol=1e-6)
    est = f[i : i + 6 * m].reshape(m, 6)
    i += 6 * m
    np.testing.assert_allclose(est[:, 3:], mean.reshape(m, 6)[:, 3:] / lim.speed, atol=1e-6)
    pairs = f[i : i + 3 * n * m].reshape(n, m, 3)
    i += 3 * n * m
    d = mean.reshape(m, 6)[None, :, :2] - rs[:, None, :2]
    np.testing.assert_allclose(pairs[..., 0], np.hypot(d[..., 0], d[..., 1]) / big_l, rtol=1e-5)
    beta = np.arctan2(d[..., 1], d[..., 0]) - rs[:, None, 3]
    np.testing.assert_allclose(pairs[..., 2], np.sin(beta), atol=1e-5)
    cf = f[i : i + 21 * m].reshape(m, 21)
    i += 21 * m
    for t in range(m):
        blk = cov[6 * t : 6 * t + 6, 6 * t : 6 * t + 6]
        sig = np.sqrt(np.diag(blk))
        np.testing.assert_allclose(cf[t, :6], np.log10(sig), atol=1e-5)
        corr = blk / np.outer(sig, sig)
        np.testing.assert_allclose(cf[t, 6:], corr[np.triu_indices(6, 1)], atol=1e-5)
    np.testing.assert_array_equal(f[i + m :], np.asarray(obs.detections, float).ravel())


def test_action_map_hits_the_limits_and_inverts(env):
    lower, upper = (np.asarray(b) for b in env.action_bounds)
    n = env.n_radars
    to_control = jax.jit(lambda a: F.action_to_control(env, a))
    to_action = jax.jit(lambda c: F.control_to_action(env, c))
    np.testing.assert_allclose(to_control(-np.ones(2 * n)), lower, rtol=1e-6)
    np.testing.assert_allclose(to_control(np.ones(2 * n)), upper, rtol=1e-6)
    np.testing.assert_allclose(to_control(5 * np.ones(2 * n)), upper, rtol=1e-6)
    a = np.linspace(-0.9, 0.9, 2 * n)
    np.testing.assert_allclose(to_action(to_control(a)), a, atol=1e-6)


def test_penalty_counts_close_radars(tiny):
    """Two radars 1 m apart (< R2R) and far from the drones: the penalty is α1 (one pair
    inside the keep-out); 600 m apart it is zero (smoke has no obstacles, no effort)."""
    env = make(dataclasses.replace(tiny, mpc=dataclasses.replace(tiny.mpc, alpha_effort=0.0)))
    rng = np.random.default_rng(0)
    u = np.zeros((env.n_radars, 2), np.float32)
    far_t = _obs(env, rng, radar_xy=np.array([[-300.0, 0.0], [300.0, 0.0]]))
    far_t = far_t._replace(mean=jnp.asarray(np.tile([0, 2000.0, 50, 0, 0, 0], env.n_targets)))
    penalty = jax.jit(lambda a, b, u: F.penalty(env, a, b, u))
    assert float(penalty(far_t, far_t, u)) == 0.0
    rs = np.asarray(far_t.radar_state).copy()
    rs[1, :2] = [-299.0, 0.0]
    close = far_t._replace(radar_state=jnp.asarray(rs))
    np.testing.assert_allclose(float(penalty(close, close, u)), float(env.params.alpha_r2r))


def test_keepout_depth_by_hand(env):
    """The graded keep-out: α_r2t Σ w_m (1 - d/R2T)_+ over radar-target pairs (3-D)."""
    rng = np.random.default_rng(1)
    r2t, alpha = float(env.params.r2t), float(env.params.alpha_r2t)
    keepout_depth = jax.jit(lambda o: F.keepout_depth(env, o))
    o = _obs(env, rng, radar_xy=np.array([[0.0, 0.0], [5000.0, 0.0]]))
    mean = np.tile([0.0, 3000.0, 50.0, 0, 0, 0], env.n_targets)  # all far ...
    mean[:3] = [0.3 * r2t, 0.0, 0.4 * r2t]  # ... but target 0: d = 0.5 R2T from radar 0
    o = o._replace(mean=jnp.asarray(mean, jnp.float32))
    np.testing.assert_allclose(float(keepout_depth(o)), alpha * 0.5, rtol=1e-6)
    w = np.ones(env.n_targets)
    w[0] = 0.25  # its presence weight scales it
    o = o._replace(target_weight=jnp.asarray(w))
    np.testing.assert_allclose(float(keepout_depth(o)), alpha * 0.125, rtol=1e-6)
    o = o._replace(mean=jnp.asarray(np.tile([0.0, 3000.0, 50.0, 0, 0, 0], env.n_targets)))
    assert float(keepout_depth(o)) == 0.0  # all outside: nothing


def test_registry_arguments_and_digests(tmp_path):
    """``name:ARGUMENT`` reaches an entry that takes one; its digest enters the key."""
    reg = Registry("planner", {"plain": "builtins:dict"})

    class Takes:
        takes_argument = True

        def __init__(self, env, argument):
            self.argument = argument

        def init(self):  # the planner contract (checked at registration)
            return ()

        def plan(self, carry, obs, key):
            return None, carry

        @staticmethod
        def argument_digest(argument):
            return (tmp_path / argument).read_text()

    reg.register("takes", Takes)
    (tmp_path / "a").write_text("v1")
    assert reg.get("takes:a")(None).argument == "a" and "takes:a" in reg
    key1 = reg.key(("takes:a",))
    (tmp_path / "a").write_text("v2")
    assert reg.key(("takes:a",)) != key1
    with pytest.raises(ValueError, match="'plain' takes no ':ARGUMENT'"):
        reg.get("plain:x")
    with pytest.raises(ValueError, match="give takes:ARGUMENT"):
        reg.get("takes:")


def test_policy_planner_bad_dir_is_one_line(tmp_path, env):
    from mjx_radar.io.checks import ScenarioError
    from mjx_radar.planners import PLANNERS

    with pytest.raises(ScenarioError, match="no policy.json"):
        PLANNERS.get(f"policy:{tmp_path}")(env)


def test_study_file_labels():
    assert file_label("ddr-sfim+ps") == "ddr-sfim+ps"
    a, b = file_label("ddr-sfim+policy:runs/a"), file_label("ddr-sfim+policy:runs_a")
    assert "/" not in a and ":" not in a and a != b


def test_run_and_study_refuse_a_missing_policy_before_compiling(tmp_path):
    from mjx_radar.api.run_case import request
    from mjx_radar.errors import InputError
    from mjx_radar.io.checks import ScenarioError
    from mjx_radar.study.driver import load_scenarios

    with pytest.raises(ScenarioError, match="no policy.json"):
        request("smoke", planner=f"policy:{tmp_path}")
    with pytest.raises(InputError, match="no policy.json"):
        load_scenarios(["smoke"], [f"ddr-sfim+policy:{tmp_path}"], 2, None, 0, 2, None)
    with pytest.raises(ScenarioError, match="'mppi' takes no ':ARGUMENT'"):
        request("smoke", planner="mppi:x")


def test_keepout_stats_by_hand():
    """benchmarks/studies/keepout_stats.py's statistics on a hand-made two-trial case."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parent.parent / "benchmarks" / "studies" / "keepout_stats.py"
    spec = importlib.util.spec_from_file_location("keepout_stats_script", path)
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    # T = 2 trials, K = 2 steps, N = 2 radars, M = 1 drone at (0, 0, 100)
    truth = np.zeros((2, 2, 1, 3))
    truth[..., 2] = 100.0
    radar = np.zeros((2, 2, 2, 3))
    radar[:, :, 1, 0] = 300.0  # radar 1 always far (300 m horizontal)
    radar[0, 0, 0, 0] = 50.0  # trial 0 step 0: 3-D 111.8 m < 125, horizontal 50 m
    radar[0, 1, 0, 0] = 80.0  # 3-D 128.1 m: outside
    radar[1, :, 0, 0] = 200.0  # trial 1: 223.6 m, and the radars 100 m apart
    radar[1, 1, 1, 0] = 205.0  # trial 1 step 1: radars 5 m apart < r2r = 10
    out = script.keepout_of(radar, truth, [1.0, 3.0], r2t=125.0, r2r=10.0)
    assert out["trials"] == 2 and out["median_rmse"] == 2.0 and out["mean_rmse"] == 2.0
    assert out["r2t_pair_fraction"] == 1 / 8  # one of 2 x 2 x 2 x 1 triples
    assert out["r2t_step_fraction"] == 1 / 4
    # closest approach per trial: 111.8 m / 50 m and sqrt(200² + 100²) / 200 m
    np.testing.assert_allclose(
        out["median_min_r2t_m"], (np.hypot(50, 100) + np.hypot(200, 100)) / 2
    )
    np.testing.assert_allclose(out["median_min_horizontal_m"], 125.0)
    assert out["r2r_step_fraction"] == 1 / 4


def test_shield_by_hand(env):
    """The keep-out shield (learning/shield.py) on hand-made geometry: radar 0 heads +x."""
    from mjx_radar.learning.shield import MARGIN, shield

    rng = np.random.default_rng(2)
    r2t = float(env.params.r2t)
    amax = float(env.action_bounds[1][0, 0])
    dt = float(env.task.timing.dt_control)
    far = [0.0, 5000.0, 0.0, 0.0, 0.0, 0.0]
    shielded = jax.jit(lambda o, u: shield(env, o, u))

    def case(v, drone, weight=1.0, a=0.5):
        o = _obs(env, rng, radar_xy=np.array([[0.0, 0.0], [3000.0, 3000.0]]))
        rs = np.asarray(o.radar_state).copy()
        rs[0, 3:] = [0.0, v, 0.0]  # θ = 0, speed v, ω = 0
        rs[1, 3:] = 0.0
        mean = np.array(list(drone) + far * (env.n_targets - 1), np.float32)
        w = np.ones(env.n_targets)
        w[0] = weight
        o = o._replace(
            radar_state=jnp.asarray(rs), mean=jnp.asarray(mean), target_weight=jnp.asarray(w)
        )
        u = jnp.asarray([[a * amax, 0.3], [0.2 * amax, -0.1]], jnp.float32)
        return np.asarray(shielded(o, u))

    # ahead and closing: the drone sits 2 m inside R2T of where the radar would stop
    v = 20.0
    v1 = min(v + 0.5 * amax * dt, float(env.task.fleet.limits.speed))
    stop = 0.5 * (v + v1) * dt + v1 * v1 / (2 * amax)
    ahead = r2t + stop - 2.0
    out = case(v, [ahead, 0.0, 0.0, 0.0, 0.0, 0.0])
    np.testing.assert_allclose(out[0], [-amax, 0.3])  # brakes, keeps its turn
    np.testing.assert_allclose(out[1], [0.2 * amax, -0.1])  # the other radar untouched
    # the same drone absent, or 2 m beyond R2T + margin of the stop: the policy's control
    policy = [0.5 * amax, 0.3]
    np.testing.assert_allclose(case(v, [ahead, 0, 0, 0, 0, 0], weight=0.0)[0], policy)
    beyond = r2t + MARGIN + stop + 2.0
    np.testing.assert_allclose(case(v, [beyond, 0, 0, 0, 0, 0])[0], policy, rtol=1e-6)
    # a drone behind flying at the radar at rest: it speeds away forward
    out = case(0.0, [-(r2t + 1.0), 0.0, 0.0, 20.0, 0.0, 0.0], a=0.0)
    np.testing.assert_allclose(out[0], [amax, 0.3])
    # inside but leaving (radar backs away from a drone ahead): not closing, untouched
    out = case(-10.0, [r2t - 20.0, 0.0, 0.0, 0.0, 0.0, 0.0], a=-0.5)
    np.testing.assert_allclose(out[0], [-0.5 * amax, 0.3])


def test_shield_at_deployment_only(env, tmp_path):
    """``shielded-policy:DIR`` runs an unshielded set policy (a hand-written checkpoint)
    with the keep-out shield on its controls: its control is ``shield(policy's)`` and
    brakes radar 0, which closes on a drone just beyond R2T, at the limit;
    ``policy:DIR`` of the same folder leaves the policy's control alone."""
    import json

    import pytest

    pytest.importorskip("flax")
    from mjx_radar.io.checks import ScenarioError
    from mjx_radar.learning.distill_ckpt import _save_leaves
    from mjx_radar.learning.set_net import init_params
    from mjx_radar.learning.shield import shield
    from mjx_radar.registry import PLANNERS

    (tmp_path / "checkpoints/000001").mkdir(parents=True)
    _save_leaves(tmp_path / "checkpoints/000001/params.npz", init_params(8, jax.random.PRNGKey(3)))
    meta = {
        "network": "set",
        "algo": "bc",
        "scenarios": ["tiny"],
        "checkpoint": "checkpoints/000001",
    }
    meta["config"] = {"hidden": 8, "features": "v1", "shield": False}
    (tmp_path / "policy.json").write_text(json.dumps(meta))
    plain = PLANNERS.get(f"policy:{tmp_path}")(env)
    safe = PLANNERS.get(f"shielded-policy:{tmp_path}")(env)
    assert (plain.shielded, safe.shielded) == (False, True)
    with pytest.raises(ScenarioError, match=r"^planner shielded-policy:/nope: no such folder"):
        PLANNERS.get("shielded-policy:/nope")(env)
    o = _obs(env, np.random.default_rng(4), radar_xy=np.array([[0.0, 0.0], [3000.0, 3000.0]]))
    rs = np.asarray(o.radar_state).copy()
    rs[:, 3:] = [[0.0, 20.0, 0.0], [0.0, 0.0, 0.0]]  # radar 0 heads +x at 20 m/s
    mean = np.zeros((env.n_targets, 6), np.float32)
    mean[:, 1] = 5000.0
    mean[0] = [float(env.params.r2t) + 1.0, 0.0, 0.0, 0.0, 0.0, 0.0]  # just beyond R2T
    o = o._replace(radar_state=jnp.asarray(rs), mean=jnp.asarray(mean.reshape(-1)))
    u_plain = np.asarray(jax.jit(lambda o: plain.plan(None, o, None)[0])(o))
    u_safe = np.asarray(jax.jit(lambda o: safe.plan(None, o, None)[0])(o))
    want = np.asarray(jax.jit(lambda o, u: shield(env, o, u))(o, jnp.asarray(u_plain)))
    np.testing.assert_array_equal(u_safe, want)
    amax = float(env.action_bounds[1][0, 0])
    assert abs(u_plain[0, 0] + amax) > 1e-3 * amax  # the policy alone would not brake so
    np.testing.assert_allclose(u_safe[0], [-amax, u_plain[0, 1]], rtol=1e-6)


def test_ppo_config_bad_input_is_one_scenario_error():
    """Python callers get the CLI's one-line ScenarioError, never a TypeError."""
    from mjx_radar.io.checks import ScenarioError
    from mjx_radar.learning.config import PPOConfig, check_config

    check_config(PPOConfig(), 10)  # the defaults pass
    cases = [
        ({"penalty_scale": "a"}, "penalty_scale = 'a': must be a finite number >= 0"),
        ({"penalty_scale": float("nan")}, "penalty_scale = nan"),
        ({"keepout_grade": -1.0}, "keepout_grade = -1.0: must be a finite number >= 0"),
        ({"init_noise_std": 0.0}, "init_noise_std = 0.0: must be a finite number > 0"),
        ({"shield": "yes"}, "shield = 'yes': must be True or False"),
        ({"evaluate": 1}, "evaluate = 1: must be True or False"),
    ]
    for kw, message in cases:
        with pytest.raises(ScenarioError) as e:
            check_config(PPOConfig(**kw), 10)
        assert message in str(e.value) and "\n" not in str(e.value)
