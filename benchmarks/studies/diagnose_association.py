"""Why the close drones of ``clutter_3r4t`` are lost with unlabelled returns (issue 35).

Three numbers, on the CPU in a few minutes (docs/tracking.md, "Diagnosis"):

1. ``when``: a closed-loop run with the scenario's association (``--association``): per
   trial the first filter step at which the joint NEES (6M degrees of freedom) exceeds
   its χ² 99.9 % quantile (the filter inconsistent), the step at which the trial is
   flagged lost, and the mean NEES over the first 20 steps (consistent: ~6M).
2. ``oracle``: along the same trials' true and radar trajectories, every *fixed*
   association (track m takes drone ``τ_n``'s return at radar n at every scan: 4^3
   triples per track, each a CKF of its own from the track's initial estimate, true
   Swerling detections, no clutter) scored by its measurement log-likelihood, and the
   joint hypotheses (a permutation of the drones per radar) ranked. This is the best any
   tracker could do with these measurements and the initial estimates: which hypothesis
   wins at step k, its largest track error, and the posterior probability of the true one.
3. ``labels``: the labelling the initial estimates imply. The filter starts from
   ``x̂_m = x_m + e_m``, ``e_m ~ N(0, p0 I)``; with unlabelled returns the data identify
   the drones' trajectories but not which track is which drone, so the best labelling
   is the permutation π minimising ``Σ_m |x̂_m − x_π(m)|²``. Monte Carlo over e: how
   often it is not the identity (the fraction of trials any tracker mislabels).

    python benchmarks/studies/diagnose_association.py [--scenario clutter_3r4t] [--trials 4]
        [--steps 200] [--association jpda] [--method ddr-sfim]
"""

from __future__ import annotations

import argparse
import itertools
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))  # association_bound


def labels(scenario, samples: int = 200_000, seed: int = 0) -> dict:
    """Monte Carlo of the prior's labelling: P(best permutation is not the identity)."""
    from mjx_radar.physics.target_motion import initial_states

    x0 = initial_states(scenario.target_init, scenario.target_motion, scenario.timing.dt_filter)
    x = np.asarray(x0, float).reshape(scenario.n_targets, 6)
    m = x.shape[0]
    e = np.random.default_rng(seed).standard_normal((samples, m, x.shape[1]))
    xh = x[None] + np.sqrt(scenario.p0) * e
    perms = list(itertools.permutations(range(m)))
    cost = np.stack([((xh - x[list(p)][None]) ** 2).sum((1, 2)) for p in perms], 1)
    best = cost.argmin(1)
    out = {"p_mislabelled": float((best != 0).mean())}
    for k in np.argsort(-np.bincount(best, minlength=len(perms)))[:4]:
        if k:
            out[str(perms[k])] = float((best == k).mean())
    return out


def oracle(task, params, truth, radars, x0, seed: int, steps=(20, 80, -1)):
    """Fixed-association hypotheses of one trial: ``[(k, error, p)]`` per step k (clamped to
    the run), the winner's largest track error [m] and the posterior probability of the
    true association (the filters and hypotheses of ``benchmarks/studies/association_bound.py``)."""
    from association_bound import fixed_association_filters, joint_hypotheses

    out = fixed_association_filters(task, params, truth, radars, x0, seed)
    ll, pos = np.asarray(out[0]), np.asarray(out[1])
    m, n = truth.shape[1], radars.shape[1]
    col = joint_hypotheses(m, n)  # [H, M]; row 0 the true association
    res = []
    n_k = ll.shape[0]
    for k in dict.fromkeys(min(k, n_k - 1) if k >= 0 else k % n_k for k in steps):
        tot = ll[k][np.arange(m)[None], col].sum(1)
        p = np.exp(tot - tot.max())
        p /= p.sum()
        h = int(np.argmax(tot))
        err = np.linalg.norm(pos[k][np.arange(m), col[h]] - truth[k, :, :3], axis=-1).max()
        res.append((k + 1, float(err), float(p[0])))
    return res


def main(argv=None) -> int:
    from scipy.stats import chi2

    import mjx_radar
    from mjx_radar.task.task import build

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scenario", default="clutter_3r4t")
    p.add_argument("--trials", type=int, default=4)
    p.add_argument("--steps", type=int, default=200)
    p.add_argument("--association", default="jpda")
    p.add_argument("--method", default="ddr-sfim")
    args = p.parse_args(argv)
    sc = mjx_radar.load_scenario(args.scenario)
    print("labels:", labels(sc), flush=True)
    run = mjx_radar.simulate(
        sc, args.method, trials=args.trials, steps=args.steps,
        association=args.association, progress=False,
    )  # fmt: skip
    ds, met = run.trajectories, run.metrics
    truth = ds.truth.values
    radars = ds.radar_states.values[..., :3]
    task, params = build(sc, args.method)
    rng = np.random.default_rng(0)
    for t in range(args.trials):
        g = met[met["trial"] == t].sort_values("step")
        lost = np.flatnonzero(g["lost"].to_numpy() > 0)
        first = np.flatnonzero(g["nees"].to_numpy() > chi2.ppf(0.999, 6 * sc.n_targets))
        x0 = truth[t, 0] + np.sqrt(sc.p0) * rng.standard_normal(truth[t, 0].shape)
        orc = oracle(task, params, truth[t], radars[t], x0, seed=t)
        print(
            f"trial {t}: {args.association} NEES > 99.9 % at step "
            f"{int(first[0]) + 1 if first.size else None}, lost at "
            f"{int(lost[0]) + 1 if lost.size else None}, mean NEES(1-20) "
            f"{g['nees'].iloc[:20].mean():.0f}; oracle (winner's max error m, p(true)) at "
            "steps " + " ".join(f"{k}: ({e:.1f}, {q:.2f})" for k, e, q in orc),
            flush=True,
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
