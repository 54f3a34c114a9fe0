"""Settings of distillation from the MPPI planner (behaviour cloning, DAgger) and their
checks (docs/learning.md, "Distillation").

:class:`DistillConfig` is saved in a policy directory's ``policy.json`` (``config``);
a resumed directory keeps its own.
"""

from __future__ import annotations

import dataclasses

from mjx_radar.io.checks import ScenarioError
from mjx_radar.learning.config import MAX_STEPS, in_range

#: the algorithms of ``train_policy.py --algo`` (bc and dagger: this module's settings)
ALGOS = ("bc", "dagger", "ppo")
#: the set features' versions (:data:`mjx_radar.learning.set_features.SIZES`)
FEATURES = ("v1", "v2")


@dataclasses.dataclass(frozen=True)
class DistillConfig:
    """Settings of :func:`mjx_radar.learning.distill_train.distill_policy`.

    Attributes:
        num_envs: trials rolled out per scenario and iteration (vmapped).
        periods: control periods of each rollout (0: the scenario's episode).
        buffer_size: samples kept per scenario (a ring: the oldest are overwritten).
        batch_size: samples per scenario in one gradient step.
        updates: gradient steps (Adam) after each iteration's rollouts.
        learning_rate: Adam's step size.
        max_grad_norm: global gradient-norm clip.
        hidden: the set network's width H (:class:`~mjx_radar.learning.set_net.SetNet`).
        beta: DAgger's probability that a period applies the teacher's control instead
            of the policy's (behaviour cloning: always the teacher's).
        seed: base seed of the trials and of the network's initialisation.
        shield: pass the policy's control through the keep-out shield
            (:mod:`mjx_radar.learning.shield`) where it drives, and in ``policy:DIR``.
        features: the set features' version (:mod:`mjx_radar.learning.set_features`):
            ``"v1"``, or ``"v2"`` with keep-out (closing rate, margin ahead, nearest
            drone) and ground (gradient, grade, line of sight) features.
        keepout_weight: weight of the keep-out hinge on where the policy's own action leads
            (:func:`mjx_radar.learning.distill.keepout_hinge`) in the cloning loss (0: off).
    """

    num_envs: int = 64
    periods: int = 0
    buffer_size: int = 100_000
    batch_size: int = 256
    updates: int = 200
    learning_rate: float = 1e-3
    max_grad_norm: float = 1.0
    hidden: int = 64
    beta: float = 0.0
    seed: int = 0
    shield: bool = False
    features: str = "v1"
    keepout_weight: float = 0.0


RANGES = {
    "num_envs": (1, 2**20, False),
    "periods": (0, 10**6, False),
    "buffer_size": (1, 2**30, False),
    "batch_size": (1, 2**20, False),
    "updates": (1, 10**7, False),
    "hidden": (1, 4096, False),
    "seed": (0, 2**31 - 1, False),
    "learning_rate": (0.0, 1.0, True),
    "max_grad_norm": (0.0, float("inf"), True),
    "beta": (0.0, 1.0, False),
    "keepout_weight": (0.0, 1e6, False),
}


def check_distill(config: DistillConfig, steps: int, algo: str) -> None:
    """Raises :class:`ScenarioError` naming the first setting out of range."""
    if algo not in ALGOS[:2]:
        raise ScenarioError(f"algo = {algo!r}: distillation is one of bc, dagger")
    if not isinstance(config, DistillConfig):
        raise ScenarioError(f"config = {config!r:.40}: must be a DistillConfig")
    in_range("steps", steps, 1, MAX_STEPS, False)
    for name, (lo, hi, lo_open) in RANGES.items():
        in_range(name, getattr(config, name), lo, hi, lo_open)
    if not isinstance(config.shield, bool):
        raise ScenarioError(f"shield = {config.shield!r}: must be True or False")
    if config.features not in FEATURES:
        raise ScenarioError(f"features = {config.features!r}: must be one of {', '.join(FEATURES)}")


def distill_config_of(state: dict) -> DistillConfig:
    """The :class:`DistillConfig` saved in a ``policy.json`` (one line if it is not one)."""
    try:
        return DistillConfig(**state["config"])
    except (TypeError, KeyError) as err:
        raise ScenarioError(
            f"out: policy.json's config is not a distillation one ({err})"
        ) from None
