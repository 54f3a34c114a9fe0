"""Distillation of MPPI into a set policy, resumable in chunks: behaviour cloning, then
DAgger (``train_policy.py --algo bc|dagger``; docs/learning.md, "Distillation").

:func:`distill_policy` writes a policy directory ``DIR`` that the planner ``policy:DIR``
runs on any fleet size: ``policy.json`` (``network: "set"``, the scenarios, method,
:class:`~mjx_radar.learning.distill_config.DistillConfig`, ``steps_done``,
``iterations``, the ``schedule`` of algorithms, the latest ``checkpoint``),
``checkpoints/<iteration:06d>/`` (:mod:`~mjx_radar.learning.distill_ckpt`) and
``curve.csv`` (one row per iteration: steps, wall time, algorithm, loss, the rollouts'
RMSE, keep-out fraction and policy-teacher gap).

One iteration rolls ``num_envs`` fresh trials of every scenario for ``periods`` control
periods (teacher labels on every visited state, :mod:`~mjx_radar.learning.distill`),
adds them to the scenario's replay buffer, then takes ``updates`` Adam steps. Its trials
and minibatches are keyed by the iteration's number, and the checkpoint holds the
parameters, Adam's state and the buffers, so a run stopped after any iteration and
resumed equals an uninterrupted one. A checkpoint without ``state.npz`` (e.g. copied
without its large buffers) resumes from the parameters alone, Adam and the buffers
afresh. ``steps`` counts labelled env steps (control
periods over all trials and scenarios), across algorithms: ``--algo bc --steps 2e5``
then ``--algo dagger --steps 6e5`` goes on from the cloned policy to 6e5 in all.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import time
from pathlib import Path

import jax
import jax.numpy as jnp

from mjx_radar.io.atomic import atomic_write_text
from mjx_radar.io.checks import ScenarioError
from mjx_radar.learning import distill, distill_ckpt, replay
from mjx_radar.learning.config import check_method_and_budget, out_folder
from mjx_radar.learning.distill_config import DistillConfig, check_distill, distill_config_of
from mjx_radar.learning.set_net import init_params

CURVE = ("steps", "wall_s", "algo", "loss", "rmse_pos", "inside_r2t", "gap")


def scenario_list(scenarios) -> list:
    """Scenarios of ``"a,b"``, one scenario, or a list of them, checked."""
    from mjx_radar.env.inputs import check_scenario

    if isinstance(scenarios, str):
        scenarios = [s for s in scenarios.split(",") if s]
    elif not isinstance(scenarios, list | tuple):
        scenarios = [scenarios]
    if not scenarios:
        raise ScenarioError("scenario: give at least one")
    return [check_scenario(s) for s in scenarios]


def read_distill_state(out: Path, names: list[str], method: str) -> dict | None:
    """``DIR/policy.json`` of a distillation to resume (None when absent), checked."""
    from mjx_radar.learning.config import read_policy_json

    path = out / "policy.json"
    if not path.exists():
        return None
    state = read_policy_json(path, "out")
    if state.get("network") != "set" or state.get("algo") not in ("bc", "dagger"):
        raise ScenarioError(
            f"out = {str(out)!r}: holds a {state.get('algo', 'ppo')} policy, not a distillation"
        )
    if (state.get("scenarios"), state.get("method")) != (names, method):
        raise ScenarioError(
            f"out = {str(out)!r}: distilled on {state.get('scenarios')} / {state.get('method')},"
            f" not {names} / {method}"
        )
    if state.get("checkpoint") and not (out / state["checkpoint"]).is_dir():
        raise ScenarioError(
            f"out: {path} names checkpoint {state['checkpoint']!r}, which is missing"
        )
    distill_config_of(state)
    return state


def distill_policy(
    scenarios,
    steps: int,
    out,
    *,
    algo: str = "bc",
    method: str = "ddr-sfim",
    config: DistillConfig | None = None,
    max_seconds: float | None = None,
    log=print,
) -> dict:
    """Distils MPPI into ``out`` (module docstring) up to ``steps`` labelled env steps.

    Args:
        scenarios: one scenario (name, path, :class:`~mjx_radar.Scenario`), several in a
            list, or names joined by commas: one network learns every fleet size.
        steps: labelled env steps in all (over chunks and algorithms).
        out: the policy directory; an existing one is resumed (its configuration wins).
        algo: ``"bc"`` (the teacher drives) or ``"dagger"`` (the policy drives with
            probability 1 - β, the teacher labels).
        method: the tracker's method and the teacher's objective (``ddr-sfim``).
        config: :class:`DistillConfig` (a resumed directory keeps its own).
        max_seconds: stop after the iteration past which another would not fit (the
            longest iteration but the chunk's first, which also compiled).
        log: a function of one progress line.

    Returns:
        ``DIR/policy.json``'s content.
    """
    out = out_folder(out)
    scs = scenario_list(scenarios)
    check_method_and_budget(method, max_seconds)
    names = [s.name for s in scs]
    state = read_distill_state(out, names, method)
    config = distill_config_of(state) if state else (config or DistillConfig())
    check_distill(config, steps, algo)
    out.mkdir(parents=True, exist_ok=True)
    from mjx_radar.engine import compile_cache

    ours = not compile_cache.enabled() and compile_cache.enable(None) is not None
    try:  # JAX's persistent compilation cache, as train_policy: a resumed chunk reuses it
        return _run(scs, steps, out, algo, method, config, state, max_seconds, log)
    finally:
        if ours:
            compile_cache.disable()


def _run(scs, steps, out, algo, method, config, state, max_seconds, log) -> dict:
    from mjx_radar.env import make as make_env
    from mjx_radar.learning.set_features import set_features
    from mjx_radar.planners.base import make as make_planner

    t0 = time.perf_counter()
    state = _new_state(scs, algo, method, config) if state is None else state
    if not state["schedule"] or state["schedule"][-1][1] != algo:
        state["schedule"].append([state["steps_done"], algo])
    state["algo"] = algo
    if state["steps_done"] >= steps:
        log(f"distill: {out} already holds {state['steps_done']} >= {steps} steps")
        return state
    envs = [make_env(sc, method) for sc in scs]
    teachers = [make_planner("mppi", e) for e in envs]
    periods = [config.periods or e.episode_length for e in envs]
    tx = distill.optimizer(config.learning_rate, config.max_grad_norm)
    params = init_params(config.hidden, jax.random.PRNGKey(config.seed), False, config.features)
    buffers = []
    for e in envs:
        example = jax.eval_shape(
            lambda e=e: set_features(e, e.reset(jax.random.PRNGKey(0)).obs, config.features)
        )
        act = jax.ShapeDtypeStruct((e.n_radars, 2), jnp.float32)
        buffers.append(replay.empty(distill.Sample(example, act), config.buffer_size))
    full = (params, tx.init(params), buffers)
    ckpt = out / str(state["checkpoint"])
    if state["checkpoint"] and (ckpt / "state.npz").is_file():
        full = distill_ckpt.load_leaves(ckpt / "state.npz", full)
    elif state["checkpoint"]:  # the parameters alone (state.npz not kept): not bit-equal
        params = distill_ckpt.load_leaves(ckpt / "params.npz", params)
        full = (params, tx.init(params), buffers)
        log(f"distill: {ckpt} has no state.npz: Adam and the buffers start afresh")
    collects = [
        jax.jit(distill.make_collect(e, t, config.hidden, p, config.shield, config.features))
        for e, t, p in zip(envs, teachers, periods, strict=True)
    ]
    update = _update_program(envs, tx, config)
    beta = jnp.float32(1.0 if algo == "bc" else config.beta)
    base = jax.random.PRNGKey(config.seed)
    per_iter = config.num_envs * sum(periods)
    state["chunks"] += 1
    wall0, longest, last, first = state["wall_s"], 0.0, t0, state["iterations"]
    while state["steps_done"] < steps:
        it = state["iterations"]
        params, opt_state, buffers = full
        key = jax.random.fold_in(base, it + 1)
        stats = _collect_all(collects, params, buffers, base, it * config.num_envs, config, beta)
        params, opt_state, losses = update(params, opt_state, buffers, key)
        full = (params, opt_state, buffers)
        state["iterations"] = it + 1
        state["steps_done"] += per_iter
        state["checkpoint"] = distill_ckpt.save(out, it + 1, params, full)
        now = time.perf_counter()
        if it > first:  # the chunk's first iteration also compiled: not a measure
            longest = max(longest, now - last)
        last = now
        state["wall_s"] = wall0 + now - t0
        row = _curve_row(state, algo, losses, stats)
        _append_curve(out, row)
        atomic_write_text(out / "policy.json", json.dumps(state, indent=1) + "\n")
        distill_ckpt.prune(out, state["checkpoint"])
        log(
            f"distill[{algo}]: {state['steps_done']} steps, loss {row[3]:.4g}, "
            f"rmse {row[4]:.3g} m, gap {row[6]:.3g}, {now - t0:.0f} s"
        )
        if max_seconds is not None and (now - t0) + longest > max_seconds:
            log(f"distill: stopped at {state['steps_done']} of {steps} steps (time budget)")
            break
    return state


def _update_program(envs, tx, config):
    """The jitted gradient steps of one iteration (:func:`distill.make_update`)."""
    scales = tuple(distill.scales_of(e) for e in envs)
    return jax.jit(
        distill.make_update(
            config.hidden, tx, config.batch_size, config.updates, scales, config.keepout_weight
        )
    )


def _new_state(scs, algo, method, config) -> dict:
    """``policy.json`` of a distillation that starts now."""
    return {
        "format": 1,
        "network": "set",
        "algo": algo,
        "scenarios": [s.name for s in scs],
        "scenario": scs[0].name,
        "method": method,
        "config": dataclasses.asdict(config),
        "steps_done": 0,
        "iterations": 0,
        "wall_s": 0.0,
        "chunks": 0,
        "checkpoint": None,
        "schedule": [],
    }


#: the replay buffer's write as one compiled program (eager, each of its ops compiles
#: on its own the first time)
_ADD = jax.jit(replay.add)


def _collect_all(collects, params, buffers, base, trial0, config, beta) -> list:
    """One iteration's rollouts of every scenario (trials ``trial0 ...``), each scenario's
    samples added to its buffer in place; returns their statistics."""
    stats = []
    for i, collect in enumerate(collects):
        k = jax.random.fold_in(jax.random.fold_in(base, 0x5EED), i)
        keys = jax.vmap(lambda j, k=k: jax.random.fold_in(k, j))(
            trial0 + jnp.arange(config.num_envs)
        )
        samples, st = collect(params, keys, beta)
        buffers[i] = _ADD(buffers[i], samples)
        stats.append(st)
    return stats


def _curve_row(state, algo, losses, stats) -> list:
    def mean(field):
        return float(jnp.mean(jnp.stack([jnp.mean(getattr(s, field)) for s in stats])))

    return [
        state["steps_done"],
        round(state["wall_s"], 3),
        algo,
        float(losses[-1]),
        mean("rmse_pos"),
        mean("inside"),
        mean("gap"),
    ]


def _append_curve(out: Path, row: list) -> None:
    path = out / "curve.csv"
    new = not path.is_file()
    with path.open("a", newline="") as f:
        w = csv.writer(f)
        if new:
            w.writerow(CURVE)
        w.writerow(row)
