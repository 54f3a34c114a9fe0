"""Trains a placement policy: brax PPO, or distillation of MPPI (docs/learning.md).

    python scripts/train_policy.py SCENARIO --steps N --out DIR [--max-minutes 8.5]
        [--algo ppo|bc|dagger] [--method ddr-sfim] [--num-envs 256] [--lr 3e-4] ...

``--algo bc`` clones MPPI's controls into a set policy (any fleet size; SCENARIO may
list several, ``paper_3r4t,paper_4r4t``), ``--algo dagger`` goes on with the policy
driving and MPPI labelling, ``--algo ppo`` on such a DIR fine-tunes it with brax PPO
(on the first SCENARIO); each resumes the DIR the previous one left.

Writes DIR/policy.json, DIR/checkpoints/<steps>/ (parameters, normaliser, network
config) and DIR/curve.csv (the learning curve). Run it again with the same DIR to go
on from the latest checkpoint up to N env steps in all (``--max-minutes`` ends a chunk
in time for a 10-minute command). Evaluate the policy like any planner:
``mjx-radar run SCENARIO --planner policy:DIR`` or ``simulate(..., planner="policy:DIR")``.
Needs the rl extra (``pip install -e ".[rl]"``). Exit 2 with one line on bad input.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys


class _Parser(argparse.ArgumentParser):
    def error(self, message: str):  # one line, exit 2 (argparse prints its usage otherwise)
        print(f"error: {self.prog}: {message}", file=sys.stderr)
        raise SystemExit(2)


def _count(text: str) -> int:
    """An integer, also written ``2e5`` or ``200_000`` (a whole number)."""
    try:
        return int(text)
    except ValueError:
        pass
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if not value.is_integer():
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number")
    return int(value)


def _parser() -> argparse.ArgumentParser:
    from mjx_radar.learning.distill_config import ALGOS
    from mjx_radar.learning.train import PPOConfig

    d = PPOConfig()
    p = _Parser(description=__doc__.splitlines()[0])
    p.add_argument("--algo", choices=ALGOS, default="ppo", help="ppo, or distil MPPI: bc, dagger")
    p.add_argument(
        "scenario",
        metavar="SCENARIO",
        help="a bundled scenario name or TOML file (bc, dagger: several, joined by commas)",
    )
    p.add_argument("--steps", type=_count, required=True, help="env steps (control periods) in all")
    p.add_argument("--out", required=True, help="policy directory (resumed when it exists)")
    p.add_argument("--method", default="ddr-sfim", help="the tracker's method (noise model)")
    p.add_argument("--max-minutes", type=float, default=None, help="end this chunk in time")
    for name, flag in (
        ("num_envs", "--num-envs"),
        ("unroll_length", "--unroll-length"),
        ("batch_size", "--batch-size"),
        ("num_minibatches", "--num-minibatches"),
        ("num_updates_per_batch", "--updates-per-batch"),
        ("num_eval_envs", "--eval-envs"),
        ("eval_every", "--eval-every"),
        ("seed", "--seed"),
        ("periods", "--periods"),  # distillation's (DistillConfig) from here on
        ("buffer_size", "--buffer-size"),
        ("updates", "--updates"),
        ("hidden", "--hidden"),
    ):
        p.add_argument(flag, dest=name, type=_count, default=None)  # the algorithm's default
    p.add_argument("--beta", type=float, default=None, help="DAgger: P(the teacher drives)")
    for name, flag in (
        ("learning_rate", "--lr"),
        ("entropy_cost", "--entropy-cost"),
        ("discounting", "--discounting"),
        ("reward_scaling", "--reward-scaling"),
        ("init_noise_std", "--init-noise-std"),
        ("keepout_grade", "--keepout-grade"),
        ("keepout_weight", "--keepout-weight"),  # distillation's: the loss's keep-out hinge
    ):
        p.add_argument(flag, dest=name, type=float, default=None)  # the algorithm's default
    p.add_argument(
        "--penalty-scale",
        type=float,
        default=None,
        help=f"the penalty's weight in the reward (default {d.penalty_scale}); on a resume, "
        "a curriculum step from this chunk on",
    )
    p.add_argument(
        "--no-eval",
        dest="evaluate",
        action="store_false",
        help="no evaluation episodes (faster; the curve's reward and RMSE columns are NaN)",
    )
    p.add_argument(
        "--shield",
        action="store_true",
        help="pass the policy's control through the keep-out shield (training and evaluation)",
    )
    p.add_argument(
        "--features",
        choices=("v1", "v2"),
        default=None,
        help="bc, dagger: the set features (v2: keep-out and ground / line of sight; default v1)",
    )
    p.add_argument("--policy-hidden", default="128,128", help="policy MLP layer sizes")
    p.add_argument("--value-hidden", default="256,256", help="value MLP layer sizes")
    return p


def _sizes(text: str, flag: str) -> tuple[int, ...]:
    try:
        sizes = tuple(int(x) for x in text.split(","))
    except ValueError:
        sizes = ()
    if not sizes or min(sizes) < 1:
        raise ValueError(f"{flag} = {text!r}: comma-separated layer sizes >= 1")
    return sizes


def _flag_names(message: str) -> str:
    """A message naming a setting (``num_updates_per_batch = 0``) named as its flag."""
    flags = {"num_updates_per_batch": "updates-per-batch", "num_eval_envs": "eval-envs"}
    flags |= {"learning_rate": "lr", "max_seconds": "max-minutes"}
    name, eq, rest = message.partition(" = ")
    if eq and name.isidentifier():
        return f"--{flags.get(name, name.replace('_', '-'))} = {rest}"
    return message


def _distill(args) -> dict:
    """``--algo bc|dagger``: :func:`~mjx_radar.learning.distill_train.distill_policy`."""
    from mjx_radar.learning.distill_config import DistillConfig
    from mjx_radar.learning.distill_train import distill_policy

    names = {f.name for f in dataclasses.fields(DistillConfig)}
    kw = {k: v for k, v in vars(args).items() if k in names and v is not None}
    return distill_policy(
        args.scenario,
        args.steps,
        args.out,
        algo=args.algo,
        method=args.method,
        config=DistillConfig(**kw),
        max_seconds=None if args.max_minutes is None else 60.0 * args.max_minutes,
    )


def _ppo(args) -> dict:
    """``--algo ppo``: :func:`~mjx_radar.learning.train.train_policy` (from a distilled
    DIR: fine-tuning its set policy)."""
    from mjx_radar.learning.train import PPOConfig, train_policy

    names = {f.name for f in dataclasses.fields(PPOConfig)} - {"penalty_scale"}
    kw = {k: v for k, v in vars(args).items() if k in names and v is not None}
    kw["policy_hidden"] = _sizes(args.policy_hidden, "--policy-hidden")
    kw["value_hidden"] = _sizes(args.value_hidden, "--value-hidden")
    return train_policy(
        args.scenario,
        args.steps,
        args.out,
        method=args.method,
        config=PPOConfig(**kw),
        penalty_scale=args.penalty_scale,
        max_seconds=None if args.max_minutes is None else 60.0 * args.max_minutes,
    )


def main(argv=None) -> int:
    from mjx_radar.io.checks import ScenarioError

    args = _parser().parse_args(argv)
    try:
        if args.max_minutes is not None and not 0 < args.max_minutes < math.inf:
            raise ScenarioError(f"--max-minutes = {args.max_minutes:g}: must be a number > 0")
        state = _ppo(args) if args.algo == "ppo" else _distill(args)
    except (ScenarioError, ValueError) as err:  # the settings' names, as the flags say
        print(f"error: {_flag_names(str(err))}", file=sys.stderr)
        return 2
    print(
        f"policy: {args.out} ({state['steps_done']} of {args.steps} steps, {state['wall_s']:.0f} s)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
