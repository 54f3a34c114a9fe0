"""Trains a placement policy with brax PPO (issue 34; docs/learning.md).

    python scripts/train_policy.py SCENARIO --steps N --out DIR [--max-minutes 8.5]
        [--method ddr-sfim] [--num-envs 256] [--eval-every 200000] [--lr 3e-4] ...

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
import sys


def _parser() -> argparse.ArgumentParser:
    from mjx_radar.learning.train import PPOConfig

    d = PPOConfig()
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("scenario", metavar="SCENARIO", help="a bundled scenario name or TOML file")
    p.add_argument("--steps", type=int, required=True, help="env steps (control periods) in all")
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
    ):
        p.add_argument(flag, dest=name, type=int, default=getattr(d, name))
    for name, flag in (
        ("learning_rate", "--lr"),
        ("entropy_cost", "--entropy-cost"),
        ("discounting", "--discounting"),
        ("reward_scaling", "--reward-scaling"),
        ("init_noise_std", "--init-noise-std"),
        ("keepout_grade", "--keepout-grade"),
    ):
        p.add_argument(flag, dest=name, type=float, default=getattr(d, name))
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


def main(argv=None) -> int:
    from mjx_radar.io.checks import ScenarioError
    from mjx_radar.learning.train import PPOConfig, train_policy

    args = _parser().parse_args(argv)
    try:
        names = {f.name for f in dataclasses.fields(PPOConfig)}
        kw = {k: v for k, v in vars(args).items() if k in names}
        for k in ("num_envs", "unroll_length", "batch_size", "num_minibatches", "eval_every"):
            if kw[k] < 1:
                raise ValueError(f"--{k.replace('_', '-')} = {kw[k]}: must be >= 1")
        kw["policy_hidden"] = _sizes(args.policy_hidden, "--policy-hidden")
        kw["value_hidden"] = _sizes(args.value_hidden, "--value-hidden")
        budget = None if args.max_minutes is None else 60.0 * args.max_minutes
        state = train_policy(
            args.scenario,
            args.steps,
            args.out,
            method=args.method,
            config=PPOConfig(**{k: v for k, v in kw.items() if k != "penalty_scale"}),
            penalty_scale=args.penalty_scale,
            max_seconds=budget,
        )
    except (ScenarioError, ValueError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    print(
        f"policy: {args.out} ({state['steps_done']} of {args.steps} steps, {state['wall_s']:.0f} s)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
