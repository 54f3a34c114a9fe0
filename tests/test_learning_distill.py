"""Distillation of MPPI into a set policy and the set network (docs/learning.md,
"Distillation"): the network's permutation equivariance and size independence, the
replay ring, cloning that reaches the teacher's controls, a resumed run equal to an
uninterrupted one, PPO fine-tuning from the clone and ``policy:DIR`` on other fleets."""

from __future__ import annotations

import dataclasses
import functools
import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

pytest.importorskip("flax")
pytest.importorskip("optax")

from mjx_radar.io.checks import ScenarioError  # noqa: E402
from mjx_radar.learning import replay  # noqa: E402
from mjx_radar.learning.distill_config import DistillConfig  # noqa: E402
from mjx_radar.learning.set_features import SetObs, flatten, pad, unflatten  # noqa: E402
from mjx_radar.learning.set_net import SetNet, init_params  # noqa: E402

#: the CI clone: 4 trials x 5 periods a rollout, a 32-wide network
CLONE = DistillConfig(num_envs=4, buffer_size=400, batch_size=64, updates=150, hidden=32)


@functools.partial(jax.jit, static_argnums=(1, 2))  # jitted here and below: eagerly, each
def _random_obs(key, n, m) -> SetObs:  # small op compiles on its own (hundreds)
    k = jax.random.split(key, 3)
    return SetObs(
        jax.random.normal(k[0], (n, 7)),
        jax.random.normal(k[1], (m, 28)),
        jax.random.normal(k[2], (n, m, 6)),
        jnp.ones(n),
        jnp.ones(m),
    )


def test_set_net_is_permutation_equivariant():
    """Permuting the radars permutes the actions alike, permuting the targets changes
    nothing, the value is invariant to both (float32 round-off: pooled sums reorder)."""
    params = init_params(16, jax.random.PRNGKey(1))
    vparams = init_params(16, jax.random.PRNGKey(2), value=True)
    x = _random_obs(jax.random.PRNGKey(3), 3, 4)
    pr, pt = np.array([2, 0, 1]), np.array([3, 1, 0, 2])
    xp = SetObs(x.radar[pr], x.target[pt], x.pair[pr][:, pt], x.radar_mask, x.target_mask)
    apply, apply_v = jax.jit(SetNet(16).apply), jax.jit(SetNet(16, True).apply)
    out, outp = apply(params, x), apply(params, xp)
    assert out.shape == (3, 2)
    np.testing.assert_allclose(np.asarray(outp), np.asarray(out)[pr], rtol=1e-5, atol=1e-6)
    v, vp = apply_v(vparams, x), apply_v(vparams, xp)
    np.testing.assert_allclose(float(vp), float(v), rtol=1e-5, atol=1e-6)


def test_set_net_any_fleet_and_padding():
    """One set of parameters runs 2, 3 and 6 radars; rows padded with mask 0 change
    no real row's output; flatten / unflatten are inverse."""
    params = init_params(16, jax.random.PRNGKey(1))
    apply = jax.jit(SetNet(16).apply)
    for n, m in ((2, 2), (3, 4), (6, 3)):
        assert apply(params, _random_obs(jax.random.PRNGKey(n), n, m)).shape == (n, 2)
    x = _random_obs(jax.random.PRNGKey(5), 3, 4)
    padded = pad(x, 5, 6)
    np.testing.assert_allclose(
        np.asarray(apply(params, padded))[:3], np.asarray(apply(params, x)), atol=1e-6
    )
    back = unflatten(flatten(x), 3, 4)
    for a, b in zip(back, x, strict=True):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))


def test_replay_ring_keeps_the_newest():
    buf = replay.empty({"a": jnp.zeros(2)}, 5)
    buf = replay.add(buf, {"a": jnp.arange(8.0)[:, None] * jnp.ones(2)})
    assert int(buf.size) == 5 and int(buf.ptr) == 0
    assert sorted(np.asarray(buf.data["a"][:, 0]).tolist()) == [3, 4, 5, 6, 7]
    buf = replay.add(buf, {"a": jnp.full((2, 2), 9.0)})
    assert sorted(np.asarray(buf.data["a"][:, 0]).tolist()) == [5, 6, 7, 9, 9]
    assert replay.sample(buf, jax.random.PRNGKey(0), 7)["a"].shape == (7, 2)


@pytest.fixture(scope="module")
def short(tiny):
    """tiny with 5-period episodes (20 filter steps)."""
    return dataclasses.replace(tiny, timing=dataclasses.replace(tiny.timing, steps=20))


def test_clone_reaches_the_teachers_controls(short, tmp_path):
    """Behaviour cloning on tiny (2 radars, 2 drones, 5 periods; the CI clone, < 1 min on
    2 cores): on the states it was trained on, the policy's actions are within 0.2 of
    MPPI's in [-1, 1] action units (RMS: a tenth of the range), and its mean squared
    error is under 15 % of the teacher actions' variance (what predicting their mean
    would score: 100 %). Not zero: this MPPI (32 samples, 1 iteration) is itself noisy,
    its control a random-weighted mean of 32 draws; measured 0.15 and 8 %."""
    import time

    from mjx_radar.learning.distill_train import distill_policy
    from mjx_radar.learning.set_net import policy_action

    t0 = time.perf_counter()
    state = distill_policy(short, 80, tmp_path / "bc", config=CLONE, log=lambda _: None)
    wall = time.perf_counter() - t0
    assert state["steps_done"] == 80 and state["iterations"] == 4
    out = tmp_path / "bc"
    from mjx_radar.learning.distill_ckpt import load_leaves

    params = load_leaves(
        out / state["checkpoint"] / "params.npz", init_params(32, jax.random.PRNGKey(0))
    )
    z = np.load(out / state["checkpoint"] / "state.npz")
    leaves = [z[f"arr_{i}"] for i in range(len(z.files))]
    # the buffer's leaves are the last 7: SetObs (5), the action, then ptr and size
    radar, target, pair, rmask, tmask, action, _, size = leaves[-8:]
    x = SetObs(*(jnp.asarray(a[: int(size)]) for a in (radar, target, pair, rmask, tmask)))
    teacher = np.asarray(action[: int(size)])
    pred = np.asarray(jax.jit(policy_action, static_argnums=2)(params, x, 32))
    mse = float(np.mean((pred - teacher) ** 2))
    var = float(np.mean(np.var(teacher, axis=0)))
    print(f"clone: rms {mse**0.5:.3f}, mse / var {mse / var:.3f}, {wall:.1f} s")
    assert mse**0.5 < 0.2
    assert mse < 0.15 * var


def _arrays(out):
    state = json.loads((out / "policy.json").read_text())
    z = np.load(out / state["checkpoint"] / "state.npz")
    return state, [z[f"arr_{i}"] for i in range(len(z.files))]


@pytest.mark.slow  # three distillations, each compiling MPPI's rollout: ~2-3 min on 2 cores
def test_resumed_distillation_equals_an_uninterrupted_one(short, tmp_path):
    """bc to 40 steps in one call == bc to 20, then a second call to 40: the same
    parameters, Adam state and replay buffer, bit for bit; and the steps, iterations
    and schedule of policy.json alike."""
    from mjx_radar.learning.distill_train import distill_policy

    cfg = dataclasses.replace(CLONE, updates=20)
    quiet = {"config": cfg, "log": lambda _: None}
    distill_policy(short, 40, tmp_path / "whole", **quiet)
    first = distill_policy(short, 20, tmp_path / "parts", **quiet)
    assert first["iterations"] == 1
    distill_policy(short, 40, tmp_path / "parts", **quiet)
    (sa, a), (sb, b) = _arrays(tmp_path / "whole"), _arrays(tmp_path / "parts")
    assert (sa["steps_done"], sa["iterations"], sa["schedule"]) == (
        sb["steps_done"],
        sb["iterations"],
        sb["schedule"],
    )
    assert sb["chunks"] == 2 and len(a) == len(b)
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x, y)


@pytest.mark.slow  # compile-bound: distillation, brax PPO and two closed loops
def test_bc_dagger_ppo_then_policy_on_any_fleet(short, tmp_path):
    """bc, then dagger on two fleet sizes at once (2 and 3 radars), then PPO fine-tuning
    (brax, from the clone, on the 2-radar one) resume one DIR; the planner policy:DIR runs
    the result on 2 radars and on 4 (never seen); a PPO folder refuses to resume as bc."""
    import mjx_radar
    from mjx_radar.learning.distill_train import distill_policy
    from mjx_radar.learning.train import PPOConfig, train_policy

    out = tmp_path / "p"
    quiet = {"config": dataclasses.replace(CLONE, updates=20), "log": lambda _: None}
    both = [short, dataclasses.replace(short, name="tiny3", n_radars=3)]
    distill_policy(both, 40, out, **quiet)
    state = distill_policy(both, 80, out, algo="dagger", **quiet)
    assert state["schedule"] == [[0, "bc"], [40, "dagger"]]
    assert state["scenarios"] == ["tiny", "tiny3"] and state["iterations"] == 2
    run = mjx_radar.simulate(short, planner=f"policy:{out}", trials=1)
    assert np.isfinite(run.summary()["rmse_pos"])
    ppo = PPOConfig(
        num_envs=4,
        unroll_length=5,
        batch_size=4,
        num_minibatches=2,
        num_updates_per_batch=1,
        num_eval_envs=2,
        eval_every=40,
        evaluate=False,
        init_noise_std=0.3,
    )
    state = train_policy(short, 120, out, config=ppo, log=lambda _: None)
    assert state["algo"] == "ppo" and state["steps_done"] >= 120
    assert state["config"]["network"] == "set" and state["schedule"][-1] == [80, "ppo"]
    four = dataclasses.replace(short, n_radars=4)
    for sc in (short, four):
        run = mjx_radar.simulate(sc, planner=f"policy:{out}", trials=1)
        assert np.isfinite(run.summary()["rmse_pos"])
    with pytest.raises(ScenarioError, match="not a distillation"):
        distill_policy(both, 200, out, **quiet)


def test_algo_bad_input_is_one_line_exit_2(tmp_path, capsys):
    """--algo bc|dagger: settings, scenarios and folders refused in one line naming the
    flag, before anything compiles."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parent.parent / "scripts" / "train_policy.py"
    spec = importlib.util.spec_from_file_location("train_policy_script", path)
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    out = str(tmp_path / "p")
    base = ["smoke", "--steps", "9", "--out", out, "--algo"]
    cases = [
        (base + ["bc", "--beta", "2"], "--beta = 2.0: must be a finite number in [0, 1]"),
        (base + ["dagger", "--hidden", "0"], "--hidden = 0: must be an integer >= 1"),
        (base + ["bc", "--buffer-size", "0"], "--buffer-size = 0"),
        (base + ["bc", "--lr", "0"], "--lr = 0.0"),
        (base + ["bc", "--keepout-weight", "-1"], "--keepout-weight = -1.0"),
        (["smoke,nope", "--steps", "9", "--out", out, "--algo", "bc"], "nope"),
    ]
    for argv, message in cases:
        assert script.main(argv) == 2
        err = capsys.readouterr().err.strip()
        assert message in err and "\n" not in err and "Traceback" not in err
    with pytest.raises(SystemExit) as exit_:
        script.main(base + ["bc", "--features", "v3"])
    err = capsys.readouterr().err.strip()
    assert exit_.value.code == 2 and "--features: invalid choice: 'v3'" in err and "\n" not in err
    (tmp_path / "p").mkdir()
    (tmp_path / "p" / "policy.json").write_text(json.dumps({"scenario": "smoke", "config": {}}))
    assert script.main(base + ["bc"]) == 2
    assert "holds a ppo policy, not a distillation" in capsys.readouterr().err
