"""PPO fine-tuning of a distilled set policy (``train_policy.py --algo ppo`` on a
``bc`` / ``dagger`` directory; docs/learning.md, "Distillation").

The first PPO chunk on such a directory turns its ``policy.json`` into a PPO one
(:func:`start_state`: the steps go on, the network and its width are kept, the PPO
settings are the command's, ``schedule`` gains ``[steps, "ppo"]``) and starts brax's
PPO from the distilled parameters (:func:`set_start`: ``ppo.train(restore_params=...)``
with a fresh value head); later chunks resume from brax's own checkpoints.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from mjx_radar.io.checks import ScenarioError
from mjx_radar.learning.config import PPOConfig, read_policy_json


def start_state(out: Path, sc, method: str, config: PPOConfig) -> dict | None:
    """The PPO state of ``out`` if it holds a distilled policy (else None)."""
    path = out / "policy.json"
    distilled = read_policy_json(path, "out") if path.is_file() else {}
    if distilled.get("network") != "set" or distilled.get("algo") not in ("bc", "dagger"):
        return None
    return from_distilled(distilled, sc, method, config)


def from_distilled(distilled: dict, sc, method: str, config: PPOConfig) -> dict:
    """The ``policy.json`` state of PPO fine-tuning that starts from a distilled set
    policy (``--algo ppo`` on a ``bc`` / ``dagger`` directory): its steps go on, its
    network and width are kept, the PPO settings are ``config``'s."""
    if (sc.name not in distilled.get("scenarios", [])) or distilled.get("method") != method:
        raise ScenarioError(
            f"out: distilled on {distilled.get('scenarios')} / {distilled.get('method')}; "
            f"fine-tune on one of them, not {sc.name} / {method}"
        )
    from mjx_radar.learning.set_features import flat_size

    hidden = int(distilled["config"]["hidden"])
    config = dataclasses.replace(config, network="set", hidden=hidden)
    schedule = distilled.get("schedule", []) + [[distilled["steps_done"], "ppo"]]
    return {
        **distilled,
        "algo": "ppo",
        "scenario": sc.name,
        "n_radars": sc.n_radars,
        "n_targets": sc.n_targets,
        "observation_size": flat_size(sc.n_radars, sc.n_targets, features_of(distilled)),
        "action_size": 2 * sc.n_radars,
        "episode_length": sc.timing.steps // sc.timing.control_every,
        "config": dataclasses.asdict(config),
        "distill_config": distilled["config"],
        "schedule": schedule,
    }


def features_of(state: dict | None) -> str:
    """The set features' version of a distilled or fine-tuned set policy's state."""
    state = state or {}
    return state.get("distill_config", state.get("config", {})).get("features", "v1")


def observation_of(config: PPOConfig, state: dict | None) -> str:
    """The brax environment's observation for PPO with ``config`` from ``state``."""
    if config.network != "set":
        return "flat"
    return "set-v2" if features_of(state) == "v2" else "set"


def set_start(out: Path, state: dict | None, config: PPOConfig, sc):
    """brax's network factory of the set network and, on the first PPO chunk after a
    distillation, the distilled parameters to start from (else None: brax's checkpoint)."""
    import jax

    from mjx_radar.learning import set_ppo
    from mjx_radar.learning.distill_ckpt import load_leaves
    from mjx_radar.learning.set_net import init_params

    n, m, version = sc.n_radars, sc.n_targets, features_of(state)
    factory = set_ppo.set_network_factory(n, m, config.hidden, config.init_noise_std, version)
    distilled = out / str((state or {}).get("checkpoint")) / "params.npz"
    if not (state or {}).get("checkpoint") or not distilled.is_file():
        return factory, None
    key = jax.random.PRNGKey(config.seed)
    params = load_leaves(distilled, init_params(config.hidden, key, False, version))
    return factory, set_ppo.distilled_params(
        params, n, m, config.hidden, config.init_noise_std, key, version
    )
