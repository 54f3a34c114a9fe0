"""brax PPO's settings for :func:`mjx_radar.learning.train.train_policy`, the policy
and value networks they describe, and their checks (docs/learning.md, "Training").

:class:`PPOConfig` is saved in a policy directory's ``policy.json`` (``config``) and
read back by :func:`config_of` (older directories get the defaults of settings added
since); :func:`network_factory` builds the same networks for training and for the
planner ``policy:DIR``.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
from pathlib import Path

from mjx_radar.io.checks import ScenarioError

FORMAT = 1  # policy.json's format


@dataclasses.dataclass(frozen=True)
class PPOConfig:
    """brax PPO's settings (``ppo.train`` keywords) and the network's sizes."""

    num_envs: int = 256
    unroll_length: int = 10
    batch_size: int = 256
    num_minibatches: int = 8
    num_updates_per_batch: int = 4
    learning_rate: float = 3e-4
    entropy_cost: float = 1e-3
    discounting: float = 0.97
    gae_lambda: float = 0.95
    clipping_epsilon: float = 0.2
    reward_scaling: float = 0.1
    max_grad_norm: float = 1.0
    penalty_scale: float = 1.0  # reward = information - penalty_scale * penalty (training)
    init_noise_std: float = 1.0  # the policy's initial action noise (brax's scalar std)
    keepout_grade: float = 0.0  # reward -= keepout_grade * features.keepout_depth
    shield: bool = False  # the keep-out shield on the control (learning.shield), kept for eval
    num_eval_envs: int = 128
    evaluate: bool = True  # False: no evaluation episodes (the curve's eval columns NaN)
    eval_every: int = 200_000  # env steps between evaluations (and checkpoints)
    policy_hidden: tuple[int, ...] = (128, 128)
    value_hidden: tuple[int, ...] = (256, 256)
    seed: int = 0
    network: str = "mlp"  # "set": the set network (learning.set_ppo), from a distilled policy
    hidden: int = 64  # the set network's width (network = "set")

    def steps_per_update(self) -> int:
        """Env steps of one PPO update: ``batch_size · unroll_length · num_minibatches``."""
        return self.batch_size * self.unroll_length * self.num_minibatches


def network_factory(config: PPOConfig):
    """brax's ``make_ppo_networks`` with the configured layer sizes."""
    import functools

    from brax.training.agents.ppo import networks

    return functools.partial(
        networks.make_ppo_networks,
        policy_hidden_layer_sizes=tuple(config.policy_hidden),
        value_hidden_layer_sizes=tuple(config.value_hidden),
        init_noise_std=config.init_noise_std,
    )


def config_of(state: dict) -> PPOConfig:
    """The :class:`PPOConfig` saved in a ``policy.json``."""
    saved = state["config"]
    return PPOConfig(**{**saved, **{k: tuple(saved[k]) for k in ("policy_hidden", "value_hidden")}})


#: the largest ``steps`` a training accepts (10^12 env steps: weeks on a GPU)
MAX_STEPS = 10**12
_INF = math.inf
#: ``(low, high, low_open)`` of each number of :class:`PPOConfig`
RANGES = {
    "num_envs": (1, 2**20, False),
    "unroll_length": (1, 10**6, False),
    "batch_size": (1, 2**20, False),
    "num_minibatches": (1, 2**20, False),
    "num_updates_per_batch": (1, 10**4, False),
    "num_eval_envs": (1, 2**20, False),
    "eval_every": (1, MAX_STEPS, False),
    "seed": (0, 2**31 - 1, False),
    "learning_rate": (0.0, 1.0, True),
    "entropy_cost": (0.0, _INF, False),
    "discounting": (0.0, 1.0, True),
    "gae_lambda": (0.0, 1.0, False),
    "clipping_epsilon": (0.0, 1.0, True),
    "reward_scaling": (0.0, _INF, True),
    "max_grad_norm": (0.0, _INF, True),
    "penalty_scale": (0.0, _INF, False),
    "keepout_grade": (0.0, _INF, False),
    "init_noise_std": (0.0, _INF, True),
    "hidden": (1, 4096, False),
}


def in_range(name: str, value, lo, hi, lo_open: bool) -> None:
    integer = isinstance(lo, int) and isinstance(hi, int)
    kinds = int if integer else int | float
    ok = isinstance(value, kinds) and not isinstance(value, bool)
    ok = ok and math.isfinite(value) and lo <= value <= hi and not (lo_open and value == lo)
    if not ok:
        what = "an integer" if integer else "a finite number"
        low = f"{'>' if lo_open else '>='} {_fmt(lo)}"
        if hi == _INF or (ok_number(value) and value < hi):  # below the range: its floor
            raise ScenarioError(f"{name} = {value!r}: must be {what} {low}")
        left = "(" if lo_open else "["
        raise ScenarioError(f"{name} = {value!r}: must be {what} in {left}{_fmt(lo)}, {_fmt(hi)}]")


def check_setting(name: str, value) -> None:
    """One setting of :data:`RANGES` checked (a one-line :class:`ScenarioError`)."""
    in_range(name, value, *RANGES[name])


def _fmt(bound) -> str:
    return f"{bound:g}" if isinstance(bound, float) else str(bound)


def ok_number(value) -> bool:
    """A finite int or float (not a bool)."""
    number = isinstance(value, int | float) and not isinstance(value, bool)
    return number and math.isfinite(value)


def check_config(config: PPOConfig, steps: int) -> None:
    """Raises :class:`ScenarioError` naming the first setting out of range."""
    if not isinstance(config, PPOConfig):
        raise ScenarioError(f"config = {config!r:.40}: must be a PPOConfig")
    in_range("steps", steps, 1, MAX_STEPS, False)
    for name, (lo, hi, lo_open) in RANGES.items():
        in_range(name, getattr(config, name), lo, hi, lo_open)
    for name in ("policy_hidden", "value_hidden"):
        sizes = getattr(config, name)
        if not (
            isinstance(sizes, tuple)
            and sizes
            and all(isinstance(n, int) and not isinstance(n, bool) and n >= 1 for n in sizes)
        ):
            raise ScenarioError(f"{name} = {sizes!r}: must be a tuple of layer sizes >= 1")
    if (config.batch_size * config.num_minibatches) % config.num_envs:
        raise ScenarioError(
            f"num_envs = {config.num_envs}: must divide batch_size * num_minibatches = "
            f"{config.batch_size * config.num_minibatches}"
        )
    if config.network not in ("mlp", "set"):
        raise ScenarioError(f"network = {config.network!r}: must be mlp or set")
    for name in ("shield", "evaluate"):
        if not isinstance(getattr(config, name), bool):
            raise ScenarioError(f"{name} = {getattr(config, name)!r}: must be True or False")


def read_policy_json(path, where: str) -> dict:
    """The JSON object of a ``policy.json`` at ``path``; a :class:`ScenarioError` naming
    ``where`` (the option or field) when the file is unreadable or not a JSON object."""
    try:
        state = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
        raise ScenarioError(f"{where}: {path} is not a policy file ({err})") from None
    if not isinstance(state, dict):
        raise ScenarioError(f"{where}: {path} is not a policy file (not a JSON object)")
    return state


def out_folder(out) -> Path:
    """A training's ``out`` argument as an absolute folder path (orbax writes to absolute
    paths only), checked by :func:`check_out` (one line otherwise; nothing is made)."""
    if not isinstance(out, str | os.PathLike) or not str(out):
        raise ScenarioError(f"out = {out!r}: must be a folder path")
    out = Path(out).expanduser().resolve()
    check_out(out)
    return out


def check_method_and_budget(method: str, max_seconds) -> None:
    """A training's method name and time budget ``max_seconds`` (> 0, or None)."""
    from mjx_radar.task.method import parse_method

    try:
        parse_method(method)
    except ValueError as err:
        raise ScenarioError(str(err)) from None
    if max_seconds is not None and not (
        isinstance(max_seconds, int | float) and 0 < max_seconds < math.inf
    ):
        raise ScenarioError(f"max_seconds = {max_seconds!r}: must be a number > 0 (or None)")


def check_out(out: Path) -> None:
    """``out`` is a folder or can be made one (one line otherwise; nothing is made)."""
    if out.exists() and not out.is_dir():
        raise ScenarioError(f"out = {str(out)!r}: a file, not a folder")
    parent = next((p for p in out.parents if p.exists()), None)
    if not out.exists() and (parent is None or not parent.is_dir()):
        raise ScenarioError(f"out = {str(out)!r}: {parent} is not a folder")
    target = out if out.exists() else parent
    if not os.access(target, os.W_OK | os.X_OK):
        raise ScenarioError(f"out = {str(out)!r}: {target} is not writable")


def new_ppo_state(sc, method: str, env, config) -> dict:
    """``policy.json`` of a training that starts now."""
    return {
        "format": FORMAT,
        "scenario": sc.name,
        "method": method,
        "n_radars": sc.n_radars,
        "n_targets": sc.n_targets,
        "observation_size": env.observation_size,
        "action_size": env.action_size,
        "episode_length": env.episode_length,
        "config": dataclasses.asdict(config),
        "steps_done": 0,
        "wall_s": 0.0,
        "chunks": 0,
        "checkpoint": None,
    }


def penalty_step(state: dict, scale: float) -> None:
    """Records a curriculum step of the keep-out penalty's scale on a resume."""
    first_scale = state["config"].get("penalty_scale", 1.0)  # older policy.json: 1
    schedule = state.setdefault("penalty_schedule", [[0, first_scale]])
    if schedule[-1][1] != scale:
        schedule.append([state["steps_done"], scale])
        state["config"]["penalty_scale"] = scale
