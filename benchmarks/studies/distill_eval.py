"""A distilled policy against DDR-SFIM MPPI: accuracy, keep-out and cost per control call.

    python benchmarks/studies/distill_eval.py --policy DIR --scenarios paper_3r4t,paper_6r3t \
        [--trials 500] [--work runs/distill/eval] [--json F] [--result-id ID] [--label TEXT]
        [--deploy-shield]

For each scenario, ``keepout_stats`` (``simulate`` with common random numbers: trial i is
the same world for both planners) of ``mppi`` and ``policy:DIR``: the median over trials
of each trial's time-mean position RMSE and the fraction of (step, radar, drone) triples
closer than R2T (true positions, 3-D); then the median wall time of one control call of
each (``bench_env.bench_planner``, vmapped over ``--trials`` observations: a study's
batch). Every figure is saved under ``--work`` as it comes and skipped when present, so a
command cut short resumes. ``--json`` writes the table as a ``benchmarks/results`` file
(``--result-id``, default its name).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

COLUMNS = [
    "scenario",
    "planner",
    "median RMSE [m]",
    "vs MPPI",
    "radar-drone pairs inside R2T",
    "closest approach (median) [m]",
    "ms per control call",
    "MPPI / policy per call",
]


def _cached(path: Path, fn):
    if path.is_file():
        return json.loads(path.read_text())
    value = fn()
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(value, indent=1) + "\n")
    print(json.dumps(value), flush=True)
    return value


TITLES = {
    "mppi": "DDR-SFIM MPPI",
    "policy": "distilled policy",
    "shielded": "distilled policy, shield at deployment",
}


def evaluate(
    policy: str,
    scenarios: list[str],
    trials: int,
    work: Path,
    repeats: int = 5,
    deploy_shield: bool = False,
):
    """The table's rows (``COLUMNS``), each figure cached in ``work``; with
    ``deploy_shield`` also ``shielded-policy:DIR`` (the keep-out shield on the policy's
    controls at evaluation only)."""
    from bench_env import bench_planner
    from keepout_stats import keepout_stats

    planners = [("mppi", "mppi"), ("policy", f"policy:{policy}")]
    if deploy_shield:
        planners.append(("shielded", f"shielded-policy:{policy}"))
    rows = []
    for sc in scenarios:
        stats, calls = {}, {}
        for label, planner in planners:
            stats[label] = _cached(
                work / f"{sc}_{label}_keepout_{trials}.json",
                lambda sc=sc, p=planner: keepout_stats(sc, p, trials),
            )
            calls[label] = _cached(
                work / f"{sc}_{label}_call_{trials}.json",
                lambda sc=sc, p=planner: bench_planner(sc, p, trials, repeats),
            )
        ref = stats["mppi"]["median_rmse"]
        for label, _ in planners:
            title = TITLES[label]
            s, ms = stats[label], calls[label]["ms_per_call"]
            ratio = calls["mppi"]["ms_per_call"] / ms
            rows.append(
                [
                    sc,
                    title,
                    round(s["median_rmse"], 3),
                    "–" if label == "mppi" else f"{100 * (s['median_rmse'] / ref - 1):+.1f} %",
                    f"{100 * s['r2t_pair_fraction']:.2f} %",
                    round(s["median_min_r2t_m"], 1),
                    round(ms, 3),
                    "–" if label == "mppi" else f"{ratio:.0f}x",
                ]
            )
    return rows


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--policy", required=True, help="the policy directory (policy:DIR)")
    p.add_argument("--scenarios", default="paper_3r4t,paper_6r3t")
    p.add_argument("--trials", type=int, default=500)
    p.add_argument("--repeats", type=int, default=5, help="timed control calls")
    p.add_argument("--work", default="runs/distill/eval", help="cached figures (resume)")
    p.add_argument("--json", default=None, help="write a benchmarks/results file here")
    p.add_argument("--result-id", default=None, help="its id (default: the file's name)")
    p.add_argument("--label", default="", help="a note on the training, for the result")
    p.add_argument("--command", default=None, help="the command to record in the result")
    p.add_argument(
        "--deploy-shield",
        action="store_true",
        help="also evaluate shielded-policy:DIR (the shield at evaluation only)",
    )
    args = p.parse_args(argv)
    if args.trials < 1:
        print(f"error: --trials = {args.trials}: must be >= 1", file=sys.stderr)
        return 2
    from mjx_radar.io.checks import ScenarioError

    try:
        rows = evaluate(
            args.policy,
            args.scenarios.split(","),
            args.trials,
            Path(args.work),
            args.repeats,
            args.deploy_shield,
        )
    except ScenarioError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    for row in rows:
        print(" | ".join(str(v) for v in row))
    if args.json:
        import jax
        from results import write_result

        path = Path(args.json)
        ident = args.result_id or path.stem
        write_result(
            ident,
            f"A distilled set policy against DDR-SFIM MPPI, {args.trials} trials with common "
            "random numbers",
            args.command or " ".join(sys.argv),
            jax.devices()[0].device_kind,
            COLUMNS,
            rows,
            notes=args.label or None,
            root=path.parent,
        )
        print(f"wrote {path.parent / (ident + '.json')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
