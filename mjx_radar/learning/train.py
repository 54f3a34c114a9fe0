"""PPO training of a placement policy with brax (``brax.training.agents.ppo.train``).

:func:`train_policy` trains on :class:`~mjx_radar.learning.brax_env.BraxRadarEnv`
(wrapped by :func:`~mjx_radar.learning.brax_env.wrap_for_training`) and writes a
*policy directory* ``DIR``: ``policy.json`` (scenario, method, N, M, feature and action
sizes, the PPO and network configuration, steps done, the latest checkpoint),
``checkpoints/<steps:012d>/`` (brax's orbax checkpoint of ``(normaliser, policy,
value)`` and ``ppo_network_config.json``, after every evaluation) and ``curve.csv`` (one
row per evaluation: env steps, wall time, episode reward, information, penalty, mean
position RMSE, lost tracks).

Training is resumable in chunks (one GPU command here is limited to 10 minutes): a call
with ``max_seconds`` stops after the first evaluation that would not leave time for
another, and a later call with the same ``DIR`` continues from the latest checkpoint up
to ``steps`` env steps (control periods) in all. A resumed chunk restarts the optimiser
(Adam's moments) from zero; parameters and the observation normaliser carry over.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import time
from pathlib import Path

from mjx_radar.io.atomic import atomic_write_text
from mjx_radar.io.checks import ScenarioError
from mjx_radar.learning import finetune
from mjx_radar.learning.config import (
    PPOConfig,
    check_config,
    check_method_and_budget,
    config_of,
    network_factory,
    new_ppo_state,
    out_folder,
    penalty_step,
    read_policy_json,
)

CURVE = ("steps", "wall_s", "reward", "information", "penalty", "rmse_pos", "lost")


class _OutOfTime(Exception):
    """Raised from brax's progress callback to end a chunk after a checkpoint."""


#: what a resumed ``policy.json`` must hold
STATE_KEYS = ("scenario", "method", "config", "steps_done", "wall_s", "chunks", "checkpoint")


def read_state(out, scenario: str | None = None, method: str | None = None) -> dict | None:
    """``DIR/policy.json`` as a dict (None when absent), checked for a resume: one line
    naming the file for an unreadable or incomplete one, one trained on another
    ``scenario`` / ``method`` (if given), or a missing checkpoint."""
    path = Path(out) / "policy.json"
    if not path.exists():
        return None
    state = read_policy_json(path, "out")
    if scenario is not None and (state.get("scenario"), state.get("method")) != (
        scenario,
        method,
    ):
        raise ScenarioError(
            f"out = {str(out)!r}: trained on {state.get('scenario')} / {state.get('method')}, "
            f"not {scenario} / {method}"
        )
    missing = [k for k in STATE_KEYS if k not in state]
    if missing:
        raise ScenarioError(f"out: {path} lacks {', '.join(missing)} (damaged or edited)")
    try:
        config_of(state)
    except (TypeError, KeyError, ValueError) as err:
        raise ScenarioError(f"out: {path}: its config is not a PPO configuration ({err})") from None
    if state["checkpoint"] and not (Path(out) / str(state["checkpoint"])).is_dir():
        raise ScenarioError(
            f"out: {path} names checkpoint {state['checkpoint']!r}, which is missing "
            "(restore it, or train into a new folder)"
        )
    return state


def train_policy(
    scenario,
    steps: int,
    out,
    *,
    method: str = "ddr-sfim",
    config: PPOConfig | None = None,
    penalty_scale: float | None = None,
    max_seconds: float | None = None,
    cache_dir=None,
    log=print,
) -> dict:
    """Trains (or goes on training) a policy into ``out`` up to ``steps`` env steps.

    Args:
        scenario: a scenario (name, path or :class:`~mjx_radar.Scenario`).
        steps: total env steps (control periods, over all parallel envs) to train.
        out: the policy directory (module docstring); an existing one is resumed.
        method: the method whose noise model the tracker uses (``ddr-sfim``).
        config: PPO settings (a resumed directory keeps its own).
        penalty_scale: the penalty's weight in the reward from this chunk on (default:
            the configuration's). On a resume this is a curriculum step: e.g. learn to
            track with cheap keep-outs (0.02), then go on at the MPC's weights (1).
            ``policy.json``'s ``penalty_schedule`` lists ``[steps_done, scale]`` pairs.
        max_seconds: stop after the evaluation past which another would not fit.
        cache_dir: JAX's persistent compilation cache (default the package's, as the
            command line: a resumed chunk then reuses the first chunk's programs).
        log: a function of one line of progress (``print``).

    Returns:
        ``DIR/policy.json``'s content (``steps_done``, ``checkpoint``, ...).
    """
    from mjx_radar.engine import compile_cache
    from mjx_radar.env.inputs import check_scenario
    from mjx_radar.learning import compat

    out = out_folder(out)
    sc = check_scenario(scenario)
    check_method_and_budget(method, max_seconds)
    state = finetune.start_state(out, sc, method, config or PPOConfig())  # PPO from BC
    if state is None:
        state = read_state(out, sc.name, method)
    if state is not None:
        config = config_of(state)
    config = config or PPOConfig()
    if penalty_scale is not None:  # checked with the rest of the configuration
        config = dataclasses.replace(config, penalty_scale=penalty_scale)
    check_config(config, steps)
    compat.ensure()
    ours = not compile_cache.enabled() and compile_cache.enable(cache_dir) is not None
    try:
        return _train(sc, steps, out, method, config, state, max_seconds, log)
    finally:
        if ours:  # the process's cache setting as it was
            compile_cache.disable()


def _train(sc, steps, out, method, config, state, max_seconds, log) -> dict:
    from brax.training.agents.ppo import checkpoint as ppo_ckpt
    from brax.training.agents.ppo import train as ppo

    from mjx_radar.learning import brax_env

    t0 = time.perf_counter()
    env = training_env(sc, method, config, state)
    factory, restore_params = network_factory(config), None
    normalize = config.network != "set"  # set features are O(1) by construction
    if config.network == "set":
        factory, restore_params = finetune.set_start(out, state, config, sc)
    state = new_ppo_state(sc, method, env, config) if state is None else state
    penalty_step(state, config.penalty_scale)
    _make_folder(out)
    remaining = steps - state["steps_done"]
    if remaining <= 0:
        log(f"train: {out} already holds {state['steps_done']} >= {steps} steps")
        return state
    per_update = config.steps_per_update()
    n_iters = max(1, math.ceil(remaining / max(config.eval_every, per_update)))
    base, wall0 = state["steps_done"], state["wall_s"]
    box = {"params": None, "last": time.perf_counter(), "longest": 0.0}
    ckpt_config = ppo_ckpt.network_config(
        observation_size=env.observation_size,
        action_size=env.action_size,
        normalize_observations=normalize,
        network_factory=factory,
    )

    def keep_params(step, make_policy, params):
        box["params"] = params

    def progress(step, metrics):
        if step == 0:
            return
        now = time.perf_counter()
        box["longest"] = max(box["longest"], now - box["last"])
        box["last"] = now
        done = base + int(step)
        ppo_ckpt.save(out / "checkpoints", done, box["params"], ckpt_config)
        state.update(
            steps_done=done, wall_s=wall0 + now - t0, checkpoint=f"checkpoints/{done:012d}"
        )
        _append_curve(out, state, metrics, env.episode_length)
        _write_state(out, state)
        log(
            f"train: {done} steps, reward {metrics.get('eval/episode_reward', float('nan')):.4g}"
            f", {now - t0:.0f} s"
        )
        if max_seconds is not None and (now - t0) + box["longest"] > max_seconds:
            raise _OutOfTime

    state["chunks"] += 1
    restore = out / state["checkpoint"] if state["checkpoint"] else None
    if restore_params is not None:  # the distilled policy: its parameters, not brax's
        restore = None
    try:
        ppo.train(
            environment=env,
            num_timesteps=remaining,
            wrap_env_fn=brax_env.wrap_for_training,
            episode_length=env.episode_length,
            **ppo_settings(config),
            normalize_observations=normalize,
            num_evals=n_iters + 1,
            deterministic_eval=True,
            run_evals=config.evaluate,
            network_factory=factory,
            seed=config.seed + 7919 * (state["chunks"] - 1),
            progress_fn=progress,
            policy_params_fn=keep_params,
            restore_checkpoint_path=None if restore is None else str(restore),
            restore_params=restore_params,
            restore_value_fn=restore_params is None,
        )
    except _OutOfTime:
        log(f"train: stopped at {state['steps_done']} of {steps} steps (time budget)")
    _write_state(out, state)
    return state


#: the PPOConfig fields passed to brax PPO's train under their own names
PPO_SETTINGS = (
    "num_envs unroll_length batch_size num_minibatches num_updates_per_batch learning_rate"
    " entropy_cost discounting gae_lambda clipping_epsilon reward_scaling max_grad_norm"
    " num_eval_envs"
).split()


def ppo_settings(config) -> dict:
    """brax PPO's keyword arguments of :data:`PPO_SETTINGS` from the :class:`PPOConfig`."""
    return {name: getattr(config, name) for name in PPO_SETTINGS}


def training_env(sc, method, config, state: dict | None = None):
    """The brax environment PPO trains on: the config's reward shaping, shield and
    observation (set features, of the distilled policy's version in ``state``, for the
    set network, else the flat vector)."""
    from mjx_radar.learning import brax_env

    return brax_env.make(
        sc,
        method,
        penalty_scale=config.penalty_scale,
        keepout_grade=config.keepout_grade,
        shield=config.shield,
        observation=finetune.observation_of(config, state),
    )


def _make_folder(out: Path) -> None:
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise ScenarioError(f"out = {str(out)!r}: cannot be made ({err.strerror})") from None


def _write_state(out: Path, state: dict) -> None:
    atomic_write_text(out / "policy.json", json.dumps(state, indent=1) + "\n")


def _append_curve(out: Path, state: dict, metrics: dict, length: int) -> None:
    path = out / "curve.csv"
    new = not path.is_file()

    def per_step(key):
        return float(metrics.get(f"eval/episode_{key}", float("nan"))) / length

    row = [
        state["steps_done"],
        round(state["wall_s"], 3),
        float(metrics.get("eval/episode_reward", float("nan"))),
        per_step("information") * length,
        per_step("penalty") * length,
        per_step("rmse_pos"),
        per_step("lost"),
    ]
    with path.open("a", newline="") as f:
        w = csv.writer(f)
        if new:
            w.writerow(CURVE)
        w.writerow(row)
