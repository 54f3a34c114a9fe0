"""Where the managed table's missed drones and false tracks come from (docs/track_management.md).

Runs ``raid_4r8t`` managed (the scenario of ``run_raid_managed.py``, same options) for a
few trials with the full records, keeps them (``OUT/records.npz``: truth, presence and
the confirmed tracks per step, so the analysis reruns without the simulation), and
splits GOSPA's cardinality errors by cause, per trial and over time.

A confirmed track is a run of ``track_exist`` in one slot (a slot's next track is
tentative, hence absent, for at least one scan). At each step the GOSPA assignment
(c, p = 2, α = 2: Hungarian on ``min(d, c)²``, pairs with ``d < c``) matches tracks
to the present drones. A **missed** drone is one without a match:

* ``birth``: no track has matched it since it appeared (the latency of its first track);
* ``deleted``: the last track that matched it no longer exists (a real track deleted);
* ``strayed``: that track still exists but is not matched to it (drifted or taken over).

A **false** track is a confirmed track without a match:

* ``duplicate``: within c of a present drone (matched to another track);
* ``ghost``: never matched to a drone since it was confirmed (born on no drone);
* ``drifted``: matched before, its drone still present, now farther than c from all;
* ``left``: matched before, its last drone has left.

Missed drones below ``−c/2`` (under the radars' plane) are counted apart, with those
whose mirror image ``(x, y, −z)`` has a track (what range-only radars on the ground
see of them). Ghosts are split further by ``near_xy`` (within c of a present drone horizontally: the
height of a trilateration, e.g. the radars' mirror) and their lifetimes are listed::

    python benchmarks/studies/diagnose_raid_tracks.py --out /tmp/d --trials 2 --steps 1600 \
        --method ddr-sfim --birth-scans 2 [--tracker association=gnn] [--reuse]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from scipy.optimize import linear_sum_assignment

from mjx_radar.engine import determinism

sys.path.insert(0, str(Path(__file__).resolve().parent))  # run_raid_managed

MISSED = ("birth", "deleted", "strayed")
FALSE = ("duplicate", "ghost", "drifted", "left")


def record(args) -> dict:
    """The run's truth and confirmed tracks ``{truth [T,K,M,3], present, pos [T,K,J,3], exist}``."""
    from run_raid_managed import scenario_for

    from mjx_radar.engine.run_spec import run_spec
    from mjx_radar.engine.runner import run_trials

    sc = scenario_for("managed", args.max_tracks, args.steps, args.tracker, args.birth_scans)
    trials = np.arange(args.first, args.first + args.trials)
    res = run_trials(run_spec(sc), args.method, args.seed, trials, args.steps, full=True)
    return {
        "truth": np.asarray(res["target"][..., :3]),
        "present": np.asarray(res["present"]),
        "pos": np.asarray(res["track_pos"]),
        "exist": np.asarray(res["track_exist"]),
    }


def matches(truth, present, pos, exist, c):
    """``[J]`` the drone matched to each slot at one step (−1: none)."""
    out = np.full(pos.shape[0], -1)
    drones, slots = np.flatnonzero(present), np.flatnonzero(exist)
    if drones.size and slots.size:
        d = np.linalg.norm(truth[drones, None] - pos[None, slots], axis=-1)
        r, s = linear_sum_assignment(np.minimum(d, c) ** 2)
        ok = d[r, s] < c
        out[slots[s[ok]]] = drones[r[ok]]
    return out


def classify(truth, present, pos, exist, c):
    """One trial's causes: ``missed [K, len(MISSED)]``, ``false [K, len(FALSE)]`` counts per
    step and ``ghosts``: ``[(start, length, near_xy)]`` of the tracks never matched."""
    steps, m = present.shape
    j = exist.shape[1]
    missed, false = np.zeros((steps, len(MISSED))), np.zeros((steps, len(FALSE)))
    last_track = np.full(m, -1)  # (slot * steps + start) of the drone's last matching track
    track_drone = {}  # track id -> last drone it matched
    start = np.full(j, -1)
    ghosts = {}
    for k in range(steps):
        start = np.where(exist[k], np.where(start < 0, k, start), -1)
        ids = np.arange(j) * steps + start
        got = matches(truth[k], present[k], pos[k], exist[k], c)
        for s in np.flatnonzero(got >= 0):
            last_track[got[s]] = ids[s]
            track_drone[ids[s]] = got[s]
        live_ids = set(ids[exist[k]].tolist())
        for d in np.flatnonzero(present[k] & ~np.isin(np.arange(m), got)):
            t = last_track[d]
            cause = 0 if t < 0 else (2 if t in live_ids else 1)
            missed[k, cause] += 1
        dist = np.linalg.norm(truth[k][:, None] - pos[k][None], axis=-1)  # [M, J]
        dxy = np.linalg.norm(truth[k][:, None, :2] - pos[k][None, :, :2], axis=-1)
        for s in np.flatnonzero(exist[k] & (got < 0)):
            near = present[k] & (dist[:, s] < c)
            t = ids[s]
            if near.any():
                cause = 0
            elif t not in track_drone:
                cause = 1
                g = ghosts.setdefault(t, [start[s], 0, False])
                g[1] += 1
                g[2] |= bool(np.any(present[k] & (dxy[:, s] < c)))
            else:
                cause = 2 if present[k, track_drone[t]] else 3
            false[k, cause] += 1
    return missed, false, [tuple(g) for g in ghosts.values()]


def offsets(truth, present, pos, exist, c):
    """``[(dxy, dz, z_track, z_drone)]`` of every unmatched confirmed track-step to the
    present drone nearest horizontally (how far off in the plane and in height)."""
    out = []
    for k in range(present.shape[0]):
        got = matches(truth[k], present[k], pos[k], exist[k], c)
        drones = np.flatnonzero(present[k])
        if not drones.size:
            continue
        for s in np.flatnonzero(exist[k] & (got < 0)):
            dxy = np.linalg.norm(truth[k][drones, :2] - pos[k][s, :2], axis=-1)
            i = drones[np.argmin(dxy)]
            out.append((dxy.min(), pos[k][s, 2] - truth[k][i, 2], pos[k][s, 2], truth[k][i, 2]))
    return np.asarray(out).reshape(-1, 4)


def report_offsets(rec: dict, c: float) -> None:
    """Prints where the unmatched tracks sit against the nearest drone (plane, height)."""
    keys = ("truth", "present", "pos", "exist")
    trials = range(rec["present"].shape[0])
    o = np.concatenate([offsets(*(rec[k][t] for k in keys), c) for t in trials])
    if not len(o):
        return
    dxy, dz = o[:, 0], o[:, 1]
    near = dxy < c
    print(
        f"unmatched track-steps {len(o)}: horizontal offset < 20 m {np.mean(dxy < 20):.2f}, "
        f"< {c:.0f} m {np.mean(near):.2f}"
    )
    if near.any():
        q = np.percentile(dz[near], [10, 50, 90]).round(1)
        print(f"  of those < {c:.0f} m: height offset quantiles 10/50/90 % {q}")
    print(f"  track height quantiles 10/50/90 % {np.percentile(o[:, 2], [10, 50, 90]).round(1)}")


def report_mirror(rec: dict, c: float) -> None:
    """Prints the missed drones flying below ``−c/2`` (under the radars' plane), and those
    with a confirmed track within c of their mirror image ``(x, y, −z)``: range-only
    radars on the ground cannot tell the two apart (the ground prior keeps the upper)."""
    t_n, steps, m = rec["present"].shape
    under = mirror = 0
    for t in range(t_n):
        tr, pr, pos, ex = (rec[k][t] for k in ("truth", "present", "pos", "exist"))
        for k in range(steps):
            got = matches(tr[k], pr[k], pos[k], ex[k], c)
            low = pr[k] & ~np.isin(np.arange(m), got) & (tr[k][:, 2] < -c / 2)
            under += low.sum()
            image = tr[k][low] * np.array([1.0, 1.0, -1.0])
            d = np.linalg.norm(image[:, None] - pos[k][ex[k]][None], axis=-1)
            mirror += int(np.sum(np.any(d < c, axis=1))) if d.size else 0
    n = t_n * steps
    print(
        f"missed drones below -{c / 2:.0f} m: {under / n:.3f} a step, with a track at "
        f"their mirror image: {mirror / n:.3f}"
    )


def report_gospa(rec: dict, c: float) -> None:
    """Prints the run's mean GOSPA and its parts (``run_raid_managed.gospa``: α = 2, p = 2)."""
    from run_raid_managed import gospa

    keys = ("truth", "present", "pos", "exist")
    t_n, steps = rec["present"].shape[:2]
    g = np.array(
        [gospa(*(rec[k][t, i] for k in keys), c) for t in range(t_n) for i in range(steps)]
    ).reshape(t_n, steps, 4)
    matched = rec["present"].sum(-1) - g[..., 2]
    loc = np.sqrt(g[..., 1].sum() / max(matched.sum(), 1))
    print(f"GOSPA per trial {g[..., 0].mean(1).round(2)}")
    print(
        f"GOSPA {g[..., 0].mean():.2f} m, loc. RMS {loc:.2f} m, missed/step "
        f"{g[..., 2].mean():.3f}, false/step {g[..., 3].mean():.3f}"
    )


def _line(names, values) -> str:
    return ", ".join(f"{n} {v:.3f}" for n, v in zip(names, values, strict=True))


def report(rec: dict, c: float, dt: float) -> None:
    """Prints the causes per trial, per 5 s and the ghosts' lifetimes."""
    t_n, steps = rec["present"].shape[:2]
    per = int(round(5.0 / dt))
    tot_m, tot_f = np.zeros(len(MISSED)), np.zeros(len(FALSE))
    for t in range(t_n):
        mi, fa, gh = classify(rec["truth"][t], rec["present"][t], rec["pos"][t], rec["exist"][t], c)
        tot_m += mi.sum(0)
        tot_f += fa.sum(0)
        print(f"trial {t}: missed/step {mi.sum() / steps:.3f}, false/step {fa.sum() / steps:.3f}")
        print("  missed/step " + _line(MISSED, mi.sum(0) / steps))
        print("  false/step  " + _line(FALSE, fa.sum(0) / steps))
        print("  per 5 s: missed " + " ".join(f"{x:.2f}" for x in _bins(mi.sum(1), per)))
        print("           false  " + " ".join(f"{x:.2f}" for x in _bins(fa.sum(1), per)))
        for name, col in zip(MISSED + FALSE, list(mi.T) + list(fa.T), strict=True):
            if col.sum():
                print(f"    {name:9s} " + " ".join(f"{x:.2f}" for x in _bins(col, per)))
        for s0, n, xy in sorted(gh):
            print(f"  ghost born {s0 * dt:6.2f} s, lived {n * dt:6.2f} s, near a drone in xy: {xy}")
    n = t_n * steps
    print("ALL missed/step " + _line(MISSED, tot_m / n))
    print("ALL false/step  " + _line(FALSE, tot_f / n))


def _bins(x, per):
    k = len(x) // per * per
    return x[:k].reshape(-1, per).mean(1)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--trials", type=int, default=2)
    ap.add_argument("--first", type=int, default=0)
    ap.add_argument("--steps", type=int, default=1600)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--method", default="ddr-sfim")
    ap.add_argument("--max-tracks", type=int, default=16)
    ap.add_argument("--birth-scans", type=int, default=2)
    ap.add_argument("--cutoff", type=float, default=50.0)
    ap.add_argument("--tracker", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--reuse", action="store_true", help="analyse OUT/records.npz again")
    a = ap.parse_args(argv)
    f = a.out / "records.npz"
    if a.reuse and f.exists():
        rec = dict(np.load(f))
    else:
        determinism.apply()  # XLA's deterministic GPU kernels, as run_raid_managed.py
        rec = record(a)
        a.out.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(f, **rec)
    report(rec, a.cutoff, 0.025)
    report_offsets(rec, a.cutoff)
    report_mirror(rec, a.cutoff)
    report_gospa(rec, a.cutoff)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
