"""Which association tracks the close drones in clutter: pda, jpda (exact, JPDA*, LBP), gnn.

For each scenario (default ``clutter_3r4t``) and tracker variant, one resumable study
(``mjx_radar.run_study``, common random numbers: the same trials, truth and detections
for every variant) of the given methods. The variants are the scenario with
``[tracker]`` changed::

    known      detection.clutter_density = 0: the same detections, labelled (the
               per-target bank's masked update: known association, docs/detection.md)
    pda        association = "pda" (today's default)
    jpda       association = "jpda", exact marginals (G = tracker.candidates)
    jpda-star  jpda with jpda_star = true (Blom & Bloem's JPDA*)
    jpda-lbp   jpda with marginals = "lbp" (loopy belief propagation)
    jpda-ms    jpda with marginals = "multisensor" (radar tuples, all radars jointly)
    gnn        association = "gnn"
    mht        association = "mht" (K = tracker.hypotheses = 16 association histories)
    mht-64     mht with K = 64
    mht-256    mht with K = 256 (merge_screen = 2)
    mht-1024   mht with K = 1024 (no merging: merge_screen = 1)
    mht-16-labels, mht-64-labels   mht with K = 16, 64 and label-free merging
    mht-jpda   mht with K = 64 (merge_screen = 2) branching over the first scan only
               (branch_scans = 1), then JPDA within each hypothesis
    mht-jpda-16, mht-jpda-256, mht-jpda-512, mht-jpda-1024   mht-jpda with K = 16
               (merge_screen = 4), K = 256, K = 512, K = 1024
    mht-jpda-1024-b2   mht-jpda-1024 branching over the first 2 scans
    mht-jpda-256-labels, mht-jpda-1024-labels   mht-jpda-256 and -1024 merging label
               permutations of each other in the branching scan (merge_labels = true)
    jpda-p0, mht-jpda-p0, jpda-star-p0, gnn-p0, mht-p0   from a good start (p0 = 1 m^2, not the
               scenario's): what the tracking after the start loses
    mht-jpda-b4   mht-jpda branching over the first 4 scans (branch_scans = 4)
    NAME-settleStoK   variant NAME (an mht with branch_scans) with only the K heaviest
               hypotheses going on after S scans (settle_scans = S, settled_hypotheses = K;
               e.g. mht-jpda-1024-settle40to64)
    NAME-missQ    variant NAME (an mht with branch_scans) with miss_noise = Q m^2 (e.g.
               mht-jpda-1024-settle100to64-miss0.5-gate4-assoc10)
    NAME-gateN    variant NAME with the validation gate's probability 1 - 10^-N
               ([detection] gate_probability; e.g. mht-jpda-gate6: 0.999999)
    NAME-assocA   variant NAME with the planner's association term weighted A
               ([mpc] alpha_assoc = A; e.g. mht-jpda-assoc10)
    NAME-ground   variant NAME with [filter] ground_prior = true (estimates reflected to
               z >= 0; an MHT reflects every hypothesis's)
    NAME-consensusS   variant NAME (an mht) reporting the consensus hypothesis
               (estimate = "consensus", consensus_scale = S m; e.g.
               mht-jpda-1024-settle100to64-gate4-assoc10-ground-consensus5)
    NAME-altH     variant NAME (an mht) with the altitude prior: every hypothesis's heights
               held near birth_height (60 m) with std H m, the hypotheses weighed by it
               (height_std = H); NAME-altHforS: over the first S scans only
               (height_scans = S)
    mht-jpda-mix  mht-jpda with the planner planning for the moment-matched mixture of
               the hypotheses (plan_on = "mixture"; the metrics score the heaviest's)

Prints one line per variant and method as each study finishes, and rewrites
``DIR/trackers.csv`` (trials, lost trials, unmatched trials, the median over trials of the
final-step and of the time-mean position RMSE, of the time-mean GOSPA (``[metrics]``: c = 50 m,
p = 1), the summary's median RMSE, and the ratio of
the median time-mean RMSE to the known-association run's). *Unmatched* is the label-free
counterpart of lost: trials in which at some step a drone has no track within the GOSPA
cutoff (50 m) under the best assignment of tracks to drones (``gospa_missed > 0``), so a
trial whose tracks are good but swap labels is lost and not unmatched. A study already complete in
``DIR/SCENARIO/VARIANT`` is read back, so an interrupted run resumes::

    python benchmarks/studies/compare_trackers.py --out DIR [--scenarios clutter_3r4t]
        [--variants known,pda,jpda,jpda-star,jpda-lbp,jpda-ms,gnn,mht,mht-64,...]
        [--methods ddr-sfim,stationary] [--trials 200] [--steps 600] [--chunk 200] [--result ID]

``--result ID`` also writes ``benchmarks/results/ID.json`` (benchmarks/README.md) with the
table, the command and the device's name.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd

VARIANTS = {
    "known": {"detection": {"clutter_density": 0.0}},
    "pda": {"tracker": {"association": "pda"}},
    "jpda": {"tracker": {"association": "jpda"}},
    "jpda-star": {"tracker": {"association": "jpda", "jpda_star": True}},
    "jpda-lbp": {"tracker": {"association": "jpda", "marginals": "lbp"}},
    "jpda-ms": {"tracker": {"association": "jpda", "marginals": "multisensor"}},
    "gnn": {"tracker": {"association": "gnn"}},
    "mht": {"tracker": {"association": "mht"}},
    "mht-64": {"tracker": {"association": "mht", "hypotheses": 64}},
    "mht-256": {"tracker": {"association": "mht", "hypotheses": 256, "merge_screen": 2}},
    "mht-1024": {"tracker": {"association": "mht", "hypotheses": 1024, "merge_screen": 1}},
    "mht-16-labels": {"tracker": {"association": "mht", "merge_labels": True}},
    "mht-64-labels": {"tracker": {"association": "mht", "hypotheses": 64, "merge_labels": True}},
    "mht-jpda": {
        "tracker": {"association": "mht", "hypotheses": 64, "merge_screen": 2, "branch_scans": 1}
    },
    "mht-jpda-16": {"tracker": {"association": "mht", "branch_scans": 1}},
    "mht-jpda-b4": {
        "tracker": {"association": "mht", "hypotheses": 64, "merge_screen": 2, "branch_scans": 4}
    },
    "mht-jpda-mix": {
        "tracker": {
            "association": "mht",
            "hypotheses": 64,
            "merge_screen": 2,
            "branch_scans": 1,
            "plan_on": "mixture",
        }
    },
    "mht-jpda-256": {
        "tracker": {"association": "mht", "hypotheses": 256, "merge_screen": 2, "branch_scans": 1}
    },
    "mht-jpda-512": {
        "tracker": {"association": "mht", "hypotheses": 512, "merge_screen": 2, "branch_scans": 1}
    },
    "mht-jpda-1024": {
        "tracker": {"association": "mht", "hypotheses": 1024, "merge_screen": 2, "branch_scans": 1}
    },
    "mht-jpda-256-labels": {
        "tracker": {
            "association": "mht",
            "hypotheses": 256,
            "merge_screen": 2,
            "branch_scans": 1,
            "merge_labels": True,
        }
    },
    "mht-jpda-1024-labels": {
        "tracker": {
            "association": "mht",
            "hypotheses": 1024,
            "merge_screen": 2,
            "branch_scans": 1,
            "merge_labels": True,
        }
    },
    "jpda-p0": {"p0": 1.0, "tracker": {"association": "jpda"}},
    "jpda-star-p0": {"p0": 1.0, "tracker": {"association": "jpda", "jpda_star": True}},
    "gnn-p0": {"p0": 1.0, "tracker": {"association": "gnn"}},
    "mht-p0": {"p0": 1.0, "tracker": {"association": "mht"}},
    "mht-jpda-1024-b2": {
        "tracker": {"association": "mht", "hypotheses": 1024, "merge_screen": 2, "branch_scans": 2}
    },
    "mht-jpda-p0": {
        "p0": 1.0,
        "tracker": {"association": "mht", "hypotheses": 64, "merge_screen": 2, "branch_scans": 1},
    },
}


def _parts(name: str):
    """``NAME[-settleStoK][-missQ][-gateN][-assocA][-ground][-consensusS][-altH]`` ->
    ``(NAME, settle, Q, N, A, ground, S, H)``: each suffix's text (``ground`` a bool), or
    None where it is absent."""
    rest, sep_h, alt = name.partition("-alt")
    rest, sep_c, scale = rest.partition("-consensus")
    rest, sep_gr, tail = rest.partition("-ground")
    rest += tail  # "-ground" is a flag: text after it is malformed unless empty
    rest, sep_a, weight = rest.partition("-assoc")
    rest, sep_g, gate = rest.partition("-gate")
    rest, sep_m, miss = rest.partition("-miss")
    base, sep_s, settle = rest.partition("-settle")
    return (
        base,
        settle if sep_s else None,
        miss if sep_m else None,
        gate if sep_g else None,
        weight if sep_a else None,
        bool(sep_gr) and not tail,
        scale if sep_c else None,
        alt if sep_h else None,
    )


def _number(text: str | None) -> bool:
    """Whether ``text`` is a non-negative decimal (``10``, ``0.5``)."""
    return text is not None and text.replace(".", "", 1).isdigit()


def _settle(text: str | None) -> tuple[int, int] | None:
    """``"StoK"`` -> ``(S, K)`` (positive integers), else None."""
    s, sep, k = (text or "").partition("to")
    return (int(s), int(k)) if sep and s.isdigit() and k.isdigit() and int(k) > 0 else None


def variant(scenario, name: str):
    """``scenario`` with the tracker variant ``name`` (:data:`VARIANTS`); ``NAME-settleStoK``:
    variant NAME with ``settle_scans = S``, ``settled_hypotheses = K``; ``NAME-missQ``: with
    ``miss_noise = Q``; ``NAME-gateN``:
    variant NAME with the validation gate's probability ``1 − 10^−N``
    (``[detection] gate_probability``); ``NAME-assocA``: with the planner's association term
    weighted A (``[mpc] alpha_assoc``); ``NAME-ground``: with ``[filter] ground_prior``;
    ``NAME-consensusS``: with ``estimate = "consensus"``, ``consensus_scale = S``;
    ``NAME-altH``: with the altitude prior ``height_std = H`` (at ``birth_height``, 60 m),
    ``NAME-altHforS`` over the first S scans only (``height_scans = S``);
    any of them may be given, in that order."""
    base, settle, miss, gate, weight, ground, scale, alt = _parts(name)
    edits = dict(VARIANTS[base])
    tracker = dict(edits.get("tracker", {}))
    if settle is not None:
        tracker["settle_scans"], tracker["settled_hypotheses"] = _settle(settle)
    if miss is not None:
        tracker["miss_noise"] = float(miss)
    if scale is not None:
        tracker["estimate"], tracker["consensus_scale"] = "consensus", float(scale)
    if alt is not None:
        std, _, scans = alt.partition("for")
        tracker["height_std"] = float(std)
        if scans:
            tracker["height_scans"] = int(scans)
    if tracker:
        edits["tracker"] = tracker
    if gate is not None:
        gp = 1 - 10 ** -int(gate)
        edits["detection"] = {**edits.get("detection", {}), "gate_probability": gp}
    if weight is not None:
        edits["mpc"] = {"alpha_assoc": float(weight)}
    if ground:
        edits["filter"] = {**edits.get("filter", {}), "ground_prior": True}
    return scenario.replace(
        name=f"{scenario.name}_{name.replace('-', '_').replace('.', 'p')}", **edits
    )


def known_variant(name: str) -> bool:
    """Whether ``name`` is a variant of :data:`VARIANTS`, with or without ``-settleStoK``
    (positive integers), ``-missQ`` (a decimal), ``-gateN`` (N in 1..6, the gate
    probabilities the scenario accepts), ``-assocA``, ``-ground``, ``-consensusS`` and
    ``-altH`` (positive decimals)."""
    base, settle, miss, gate, weight, ground, scale, alt = _parts(name)
    ok_settle = settle is None or _settle(settle) is not None
    ok_miss = miss is None or _number(miss)
    ok_gate = gate is None or (gate.isdigit() and 1 <= int(gate) <= 6)
    ok_weight = weight is None or _number(weight)
    ok_scale = scale is None or (_number(scale) and float(scale) > 0)
    std, sep_f, scans = (alt or "").partition("for")
    ok_scans = not sep_f or (scans.isdigit() and int(scans) > 0)
    ok_alt = alt is None or (_number(std) and float(std) > 0 and ok_scans)
    ok_ground = ground or "-ground" not in name
    ok = ok_settle and ok_miss and ok_gate and ok_weight and ok_scale and ok_alt and ok_ground
    return base in VARIANTS and ok


def rows(metrics: pd.DataFrame, summary: pd.DataFrame, upto: int | None = None) -> pd.DataFrame:
    """Per method: lost trials, median final-step / time-mean RMSE over trials; with
    ``upto`` the first ``upto`` steps only (a run's prefix is the shorter run: the same
    draws step by step; the summary's median is then NaN)."""
    if upto is not None:
        metrics = metrics[metrics["step"] <= upto]
    last = metrics["step"].max()
    out = []
    for method, g in metrics.groupby("method"):
        trial = g.groupby("trial").agg(
            mean=("rmse_pos", "mean"),
            lost=("lost", "max"),
            far=("gospa_missed", "max"),
            gospa=("gospa", "mean"),
        )
        final = g[g["step"] == last].set_index("trial")["rmse_pos"]
        s = summary[summary["method"] == method].iloc[0]
        out.append(
            {
                "steps": int(last),
                "method": method,
                "trials": len(trial),
                "lost_trials": int(trial["lost"].sum()),
                "unmatched_trials": int((trial["far"] > 0).sum()),
                "median_final_rmse": float(np.median(final)),
                "median_trial_rmse": float(np.median(trial["mean"])),
                "median_trial_gospa": float(np.median(trial["gospa"])),
                "summary_median_rmse": float(s["median_rmse_pos"]) if upto is None else np.nan,
            }
        )
    return pd.DataFrame(out)


def main(argv=None) -> int:
    import mjx_radar

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, required=True)
    p.add_argument("--scenarios", default="clutter_3r4t")
    p.add_argument("--variants", default=",".join(VARIANTS))
    p.add_argument("--methods", default="ddr-sfim,stationary")
    p.add_argument("--trials", type=int, default=200)
    p.add_argument("--steps", type=int, default=None)
    p.add_argument("--chunk", type=int, default=200)
    p.add_argument("--prefix", type=int, default=None, help="also the first N steps' figures")
    p.add_argument("--result", default=None, help="also write benchmarks/results/ID.json")
    args = p.parse_args(argv)
    unknown = {v for v in args.variants.split(",") if not known_variant(v)}
    if unknown:
        p.error(f"--variants: unknown {sorted(unknown)}; one of {', '.join(VARIANTS)}")
    frames = []
    for name in args.scenarios.split(","):
        base = mjx_radar.load_scenario(name)
        for v in args.variants.split(","):
            out = args.out / name / v
            study = mjx_radar.run_study(
                variant(base, v),
                methods=args.methods.split(","),
                trials=args.trials,
                chunk=min(args.chunk, args.trials),
                out=out,
                steps=args.steps,
                resume=(out / "study.json").exists(),
                progress=False,
            )
            parts = [rows(study.metrics, study.summary())]
            if args.prefix:
                parts.insert(0, rows(study.metrics, study.summary(), args.prefix))
            frame = pd.concat(parts, ignore_index=True)
            frame.insert(0, "scenario", name)
            frame.insert(1, "variant", v)
            frames.append(frame)
            table = pd.concat(frames, ignore_index=True)
            keys = ["scenario", "steps", "method"]
            known = table[table["variant"] == "known"].set_index(keys)
            ref = table.set_index(keys).index.map(known["median_trial_rmse"].to_dict())
            table["ratio_to_known"] = table["median_trial_rmse"] / np.asarray(ref, float)
            table.to_csv(args.out / "trackers.csv", index=False)
            print(frame.to_string(index=False, header=len(frames) == 1), flush=True)
    print(table.to_string(index=False), flush=True)
    if args.result:
        write(
            args.result, table, args, sys.argv if argv is None else ["compare_trackers.py", *argv]
        )
    return 0


COLUMNS = {
    "scenario": "scenario",
    "steps": "steps",
    "variant": "variant",
    "method": "method",
    "trials": "trials",
    "lost_trials": "lost trials",
    "unmatched_trials": "unmatched trials",
    "median_trial_gospa": "median per-trial mean GOSPA [m]",
    "median_trial_rmse": "median per-trial mean RMSE [m]",
    "median_final_rmse": "median final RMSE [m]",
}


def write(ident: str, table: pd.DataFrame, args, argv) -> None:
    """``benchmarks/results/ID.json``: the table's main columns, the command, the device."""
    import jax

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from results import write_result

    dev = jax.devices()[0]
    hardware = dev.device_kind if dev.platform == "gpu" else "CPU"
    steps = args.steps if args.steps is not None else "scenario's"
    rows = [[_plain(r[c]) for c in COLUMNS] for _, r in table.iterrows()]
    title = f"Trackers in clutter: {args.trials} trials x {steps} steps, {args.methods}"
    command = "python benchmarks/studies/" + " ".join(
        str(a) for a in [Path(argv[0]).name, *argv[1:]]
    )
    path = write_result(ident, title, command, hardware, list(COLUMNS.values()), rows)
    print(f"wrote {path}", flush=True)


def _plain(v):
    """numpy scalars as Python numbers (JSON), floats to 4 significant digits."""
    if isinstance(v, (np.integer, int)):
        return int(v)
    if isinstance(v, (np.floating, float)):
        return float(f"{float(v):.4g}")
    return str(v)


if __name__ == "__main__":
    sys.exit(main())
