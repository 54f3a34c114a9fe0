"""Learned placement policies (issue 34) with the rl extra: the brax adapter against the
environment it wraps, the gymnasium wrappers under gymnasium's own checker, and the
pipeline train (brax PPO, a few hundred steps on smoke) -> checkpoint -> resume ->
``simulate(..., planner="policy:DIR")``. Pipeline only: no claim on the policy's quality."""

from __future__ import annotations

import dataclasses
import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

pytest.importorskip("brax")
gymnasium = pytest.importorskip("gymnasium")

from mjx_radar.env import make  # noqa: E402
from mjx_radar.learning import brax_env, features  # noqa: E402

#: PPO settings of the pipeline tests: a few env steps per update, tiny networks
TINY_PPO = {
    "num_envs": 4,
    "unroll_length": 5,
    "batch_size": 4,
    "num_minibatches": 2,
    "num_updates_per_batch": 1,
    "num_eval_envs": 2,
    "eval_every": 80,
    "policy_hidden": (8,),
    "value_hidden": (8,),
}


@pytest.fixture(scope="module")
def short(tiny):
    """tiny with 5-period episodes (20 filter steps)."""
    return dataclasses.replace(tiny, timing=dataclasses.replace(tiny.timing, steps=20))


@pytest.mark.slow  # compile-bound: ~30-70 s on the 2-core machine
def test_brax_step_is_the_env_step(short):
    """One adapter step = one RadarEnv.step of the mapped action, with reward =
    -Σ log det P_pos - c · penalty - g · keepout_depth (c = 0.25, g = 0.5); the metrics
    keep the unscaled parts and the keys of reset."""
    # every radar inside R2T of every drone, 4 pairs x α_r2t = 400 below the 1000 clip
    near = dataclasses.replace(
        short, mpc=dataclasses.replace(short.mpc, r2t=5000.0, alpha_r2t=100.0)
    )
    benv, env = brax_env.make(near, penalty_scale=0.25, keepout_grade=0.5), make(near)
    key = env.trial_key(3, 1)
    a = jnp.linspace(-1.0, 1.0, env.action_size)
    s0 = jax.jit(benv.reset)(key)
    s1 = jax.jit(benv.step)(s0, a)
    ref = jax.jit(env.step)(jax.jit(env.reset)(key), features.action_to_control(env, a))
    np.testing.assert_allclose(
        np.asarray(s1.pipeline_state.obs.radar_state), np.asarray(ref.obs.radar_state), rtol=1e-6
    )
    pen = features.penalty(env, s0.pipeline_state.obs, ref.obs, features.action_to_control(env, a))
    assert 0 < float(pen) < 1000  # c and g matter, and no clip
    graded = 0.5 * float(features.keepout_depth(env, ref.obs))
    assert graded > 0
    expect = float(ref.reward) - 0.25 * float(pen) - graded
    np.testing.assert_allclose(float(s1.reward), expect, rtol=1e-5)
    np.testing.assert_allclose(float(s1.metrics["penalty"]), float(pen), rtol=1e-6)
    np.testing.assert_allclose(float(s1.metrics["information"]), float(ref.reward), rtol=1e-6)
    assert set(s1.metrics) == set(s0.metrics) and float(s1.done) == 0.0
    assert s1.obs.shape == (benv.observation_size,)


@pytest.mark.slow  # compile-bound: ~30-70 s on the 2-core machine
def test_training_wrapper_draws_a_new_trial_each_episode(short):
    """After the episode's last period the slot restarts from a *new* placement."""
    benv = brax_env.make(short)
    w = brax_env.wrap_for_training(benv)
    s = jax.jit(w.reset)(jax.random.split(jax.random.PRNGKey(0), 2))
    first = np.asarray(s.pipeline_state.obs.radar_state[:, :, :2])
    step = jax.jit(w.step)
    for _ in range(benv.episode_length):
        s = step(s, jnp.zeros((2, benv.action_size)))
    assert np.all(np.asarray(s.done) == 1.0)
    again = np.asarray(s.pipeline_state.obs.radar_state[:, :, :2])
    assert np.all(np.asarray(s.pipeline_state.info["period"]) == 0)
    assert not np.allclose(again, first)  # a new draw, not the cached first state


def test_gymnasium_env_passes_the_checker(short):
    from gymnasium.utils.env_checker import check_env

    from mjx_radar.learning.gym_env import RadarGymEnv

    env = RadarGymEnv(short)
    check_env(env, skip_render_check=True)
    obs, _ = env.reset(seed=5)
    for t in range(env.episode_length):
        obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
        assert np.isfinite(reward) and not terminated and truncated == (t == 4)
    assert env.observation_space.contains(obs) and "rmse_pos" in info


@pytest.mark.slow  # compile-bound: ~30-70 s on the 2-core machine
def test_gymnasium_vector_env_autoresets_next_step(short):
    from mjx_radar.learning.gym_env import RadarVectorEnv

    venv = RadarVectorEnv(short, num_envs=3)
    obs, _ = venv.reset(seed=1)
    assert obs.shape == (3, venv.single_observation_space.shape[0])
    for _ in range(venv.episode_length):
        obs, reward, term, trunc, info = venv.step(venv.action_space.sample())
    assert trunc.all() and not term.any() and reward.shape == (3,)
    obs, reward, term, trunc, _ = venv.step(venv.action_space.sample())  # the resets
    assert np.all(reward == 0.0) and not trunc.any()
    assert venv.observation_space.contains(obs)


def test_ppo_trains_and_checkpoints(short, tmp_path):
    """CI's PPO pipeline check (no quality claim): brax PPO for 2 x 80 env steps on a
    5-period smoke without evaluation episodes (the evaluator is the costliest compile),
    a checkpoint after each iteration, the policy's parameters moved by the updates, the
    curve and policy.json as documented. ~70 s on the loaded 2-core machine."""
    from brax.training.agents.ppo import checkpoint as ppo_ckpt

    from mjx_radar.learning.train import PPOConfig, train_policy

    cfg = PPOConfig(**TINY_PPO, evaluate=False, shield=True)
    out = tmp_path / "pol"
    state = train_policy(short, 160, out, config=cfg, log=lambda line: None, cache_dir=None)
    assert state["steps_done"] == 160 and state["chunks"] == 1
    assert state["penalty_schedule"] == [[0, 1.0]] and state["config"]["shield"] is True
    ckpts = sorted(p.name for p in (out / "checkpoints").iterdir())
    assert ckpts == ["000000000080", "000000000160"] and state["checkpoint"].endswith("160")
    rows = [r.split(",") for r in (out / "curve.csv").read_text().splitlines()]
    assert rows[0][:2] == ["steps", "wall_s"] and [r[0] for r in rows[1:]] == ["80", "160"]
    assert all(r[2] == "nan" for r in rows[1:])  # no evaluation: no episode reward
    first, last = (ppo_ckpt.load(out / "checkpoints" / c) for c in ckpts)
    moved = jax.tree.map(
        lambda a, b: float(np.max(np.abs(np.asarray(a) - np.asarray(b)))), first[1], last[1]
    )
    leaves = jax.tree.leaves(moved)
    assert all(np.isfinite(x) for x in leaves) and max(leaves) > 0  # the policy was updated


@pytest.mark.slow  # 100-400 s on 2 cores, nearly all compiling: kept out of the CI tier
def test_train_resume_and_evaluate_as_planner(short, tmp_path):
    """PPO for 2 x 80 env steps on smoke (a chunk, then a resumed one), then the policy
    drives ``simulate`` through the planner name; its controls are the policy's."""
    import mjx_radar
    from mjx_radar.learning.train import PPOConfig, train_policy

    cfg = PPOConfig(**TINY_PPO)
    out = tmp_path / "pol"
    kw = {"config": cfg, "log": lambda line: None, "cache_dir": tmp_path / "xla"}
    first = train_policy(short, 80, out, **kw)
    assert first["steps_done"] == 80 and (out / first["checkpoint"]).is_dir()
    assert first["penalty_schedule"] == [[0, 1.0]]
    # resumed with a curriculum step (the penalty's weight from 80 steps on)
    state = train_policy(short, 160, out, penalty_scale=0.25, **kw)
    assert state["steps_done"] == 160 and state["chunks"] == 2
    assert state["penalty_schedule"] == [[0, 1.0], [80, 0.25]]
    assert state["config"]["penalty_scale"] == 0.25
    rows = (out / "curve.csv").read_text().splitlines()
    assert rows[0].startswith("steps,") and [r.split(",")[0] for r in rows[1:]] == ["80", "160"]
    assert json.loads((out / "policy.json").read_text())["checkpoint"].endswith("160")

    run = mjx_radar.simulate(short, planner=f"policy:{out}", trials=1, cache=False)
    assert run.summary()["method"] == f"ddr-sfim+policy:{out}"
    assert np.isfinite(run.summary()["rmse_pos"])
    # the first control of the run is the checkpoint's policy on the reset observation
    from mjx_radar.learning.policy import load_policy

    env = make(short)
    obs = jax.jit(env.reset)(env.trial_key(short.seed, 0)).obs
    policy = load_policy(out / state["checkpoint"], state)
    a, _ = policy(features.features(env, obs), jax.random.PRNGKey(0))
    u0 = np.asarray(run.trajectories.control.isel(trial=0))[0]
    np.testing.assert_allclose(u0, np.asarray(features.action_to_control(env, a)), rtol=1e-4)


def test_train_script_bad_input_is_one_line_exit_2(tmp_path, capsys):
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parent.parent / "scripts" / "train_policy.py"
    spec = importlib.util.spec_from_file_location("train_policy_script", path)
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    out = str(tmp_path / "p")
    cases = [
        (["smoke", "--steps", "0", "--out", out], "steps = 0: must be an integer >= 1"),
        (["smoke", "--steps", "9", "--out", out, "--num-envs", "3"], "--num-envs = 3: must divide"),
        (["nope", "--steps", "9", "--out", out], "nope"),
        (["smoke", "--steps", "9", "--out", out, "--policy-hidden", "a"], "--policy-hidden"),
        (["smoke", "--steps", "9", "--out", out, "--penalty-scale", "-1"], "penalty-scale = -1.0"),
        (["smoke", "--steps", "9", "--out", out, "--init-noise-std", "0"], "init-noise-std = 0.0"),
        (["smoke", "--steps", "9", "--out", out, "--keepout-grade", "-2"], "keepout-grade = -2.0"),
    ]
    for argv, message in cases:
        assert script.main(argv) == 2
        err = capsys.readouterr().err.strip()
        assert message in err and "\n" not in err and "Traceback" not in err
    (tmp_path / "p").mkdir()
    (tmp_path / "p" / "policy.json").write_text(json.dumps({"scenario": "x", "method": "ddr-sfim"}))
    assert script.main(["smoke", "--steps", "9", "--out", out]) == 2
    assert "trained on x / ddr-sfim, not smoke / ddr-sfim" in capsys.readouterr().err
