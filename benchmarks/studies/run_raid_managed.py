"""raid_4r8t without telling the filter how many drones exist (issue 35, docs/track_management.md).

Runs ``raid_4r8t`` (two waves of four drones that appear and leave) with the per-target
filter and ``[tracker] management = "managed"`` (and, with ``--management known,managed``,
the known-association bank beside it), for each method, in chunks of trials; each
chunk is saved as it finishes (``OUT/MANAGEMENT/METHOD/trials_A_B.npz``) and skipped
when the script runs again (resumable). Per trial and filter step it keeps: the true
drones present, the confirmed tracks, GOSPA (α = 2, p = 2, cut-off ``--cutoff``) and
its localisation / missed / false parts, from the records' ``track_pos``,
``track_exist``, ``target`` and ``present`` (the known filter's estimates are its M
tracks, existing while their drone is present). Prints each chunk and, at the end, the
summary (``OUT/summary.md``, ``OUT/summary.json``)::

    python benchmarks/studies/run_raid_managed.py --out runs/raid_managed --trials 200 --chunk 50

``--birth-scans 1,3`` adds the managed rows with multi-scan births (``[tracker]
birth_scans = 3``, written to ``OUT/managed_b3/METHOD``; the row ``managed`` is
``birth_scans = 1``). ``--tracker KEY=VALUE`` sets a ``[tracker]`` field of the managed
rows, ``--mpc KEY=VALUE`` an ``[mpc]`` field of every row (e.g. ``alpha_assoc=10``, the
planner against range coincidences).

GOSPA (Rahmathullah, García-Fernández & Svensson 2017) of truth set X (m present
drones) and estimate set Y (n confirmed tracks), α = 2::

    d(X, Y) = ( min_γ Σ_(i,j)∈γ d(x_i, y_j)^p + c^p/2 (m + n − 2|γ|) )^(1/p)

over assignments γ of pairs with ``d < c``; its parts: localisation ``Σ_γ d^p``,
missed ``c^p/2 (m − |γ|)``, false ``c^p/2 (n − |γ|)`` (reported as counts too).

Beside it, ``gospa_mirror``: the same distance to the truth folded into the upper half
space, ``(x, y, |z|)``. The radars stand on the ground (z = 0), where a drone at height
z and its mirror image at −z have the same ranges to every radar; the folded figure is
the error of what range-only radars on the ground can tell, so the gap between the two
is the drones that fly below the radars' plane (``below``).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
from scipy.optimize import linear_sum_assignment

from mjx_radar.engine import determinism
from mjx_radar.engine.run_spec import run_spec
from mjx_radar.errors import ScenarioError


def gospa(truth, present, est, exist, c: float, p: float = 2.0):
    """``(gospa, loc, n_missed, n_false)`` of one step (α = 2; see the module docstring)."""
    x, y = truth[present], est[exist]
    m, n = len(x), len(y)
    if m == 0 or n == 0:
        return (0.5 * c**p * (m + n)) ** (1 / p), 0.0, m, n
    d = np.linalg.norm(x[:, None] - y[None], axis=-1)
    cost = np.minimum(d, c) ** p
    rows, cols = linear_sum_assignment(cost)
    good = d[rows, cols] < c
    k = int(good.sum())
    loc = float(np.sum(d[rows, cols][good] ** p))
    total = loc + 0.5 * c**p * (m + n - 2 * k)
    return total ** (1 / p), loc, m - k, n - k


def mirror_folded(truth):
    """``truth [..., 3]`` folded into the upper half space ``(x, y, |z|)``: a position and
    its mirror image below the radars' plane (z = 0) give the same ranges."""
    return np.concatenate([truth[..., :2], np.abs(truth[..., 2:])], -1)


def label(management: str, birth_scans: int) -> str:
    """The output folder of a row: ``managed_b3`` for ``birth_scans = 3``."""
    return f"managed_b{birth_scans}" if management == "managed" and birth_scans > 1 else management


def _value(v: str):
    """A ``--tracker`` value: int, float or string (``association=gnn``)."""
    for cast in (int, float):
        try:
            return cast(v)
        except ValueError:
            pass
    return v


def _fields(items) -> dict:
    """``KEY=VALUE`` items as ``{key: value}`` (each value as :func:`_value` reads it)."""
    return {k: _value(v) for k, v in (o.split("=", 1) for o in items)}


def tracker_options(ap: argparse.ArgumentParser, items, flag: str = "--tracker") -> dict:
    """``--tracker KEY=VALUE`` items (or ``flag``'s) as ``{key: value}``; one line
    (``ap.error``, exit 2) for an item without ``=``."""
    bad = [o for o in items if "=" not in o]
    if bad:
        ap.error(f"{flag}: KEY=VALUE, got {bad[0]!r}")
    return _fields(items)


def scenario_for(
    management: str,
    max_tracks: int,
    steps: int,
    options=(),
    birth_scans: int = 1,
    ground_prior: bool = True,
    mpc=(),
):
    """raid_4r8t with the per-target filter (and the track table, ``options``: more
    ``[tracker]`` fields as ``KEY=VALUE``; ``birth_scans``: the multi-scan births;
    ``ground_prior``: the filter's reflection to z >= 0; ``mpc``: ``[mpc]`` fields as
    ``KEY=VALUE``, in every row)."""
    from mjx_radar.scenario.reader import load_scenario

    sc = load_scenario("raid_4r8t")
    changes = {"filter": {"structure": "per-target", "ground_prior": ground_prior}}
    if management == "managed":
        changes["tracker"] = {"management": "managed", "max_tracks": max_tracks, **_fields(options)}
        if birth_scans > 1:  # absent otherwise: the default program
            changes["tracker"]["birth_scans"] = birth_scans
    if mpc:
        changes["mpc"] = _fields(mpc)
    return sc.replace(timing={"steps": steps}, **changes)


def run_chunk(sc, method, seed, trials, steps, cutoff):
    from mjx_radar.engine.runner import run_trials

    res = run_trials(run_spec(sc), method, seed, np.asarray(trials), steps, full=True)
    truth = res["target"][..., :3]  # [T, K, M, 3]
    present, pos, exist = res["present"], res["track_pos"], res["track_exist"]
    t, k = truth.shape[:2]
    folded = mirror_folded(truth)
    out = np.zeros((5, t, k))
    for i in range(t):
        for j in range(k):
            out[:4, i, j] = gospa(truth[i, j], present[i, j], pos[i, j], exist[i, j], cutoff)
            if np.any(present[i, j] & (truth[i, j, :, 2] < 0)):  # else the same as above
                out[4, i, j] = gospa(folded[i, j], present[i, j], pos[i, j], exist[i, j], cutoff)[0]
            else:
                out[4, i, j] = out[0, i, j]
    return {
        "gospa": out[0],
        "gospa_mirror": out[4],
        "loc": out[1],
        "missed": out[2],
        "false": out[3],
        "confirmed": exist.sum(-1),
        "present": present.sum(-1),
        # drones below the radars' plane by more than c/2: the mirror image above (all a
        # range-only fleet on the ground can tell) is more than c away (docs/track_management.md)
        "below": (present & (truth[..., 2] < -cutoff / 2)).sum(-1),
        "rmse_pos": res["rmse_pos"],
        "lost": res["lost"],
        "sim_s": np.asarray(res["sim_s"]),
        "compile_s": np.asarray(res["compile_s"]),
    }


def summarise(out: Path, dt: float, cases) -> dict:
    summary = {}
    head = "| management | method | trials | mean GOSPA [m] | loc. RMS [m] | missed | false |"
    head += " confirmed - present | mean GOSPA, mirror-folded truth [m] |"
    lines = [head, "|---|---|---|---|---|---|---|---|---|"]
    for management, method in cases:
        files = sorted((out / management / method).glob("trials_*.npz"))
        if not files:
            continue
        first = np.load(files[0])
        keys = [k for k in first.files if first[k].ndim >= 2]
        d = {k: np.concatenate([np.load(f)[k] for f in files]) for k in keys}
        matched = d["present"] - d["missed"]
        loc_rms = np.sqrt(d["loc"].sum() / max(matched.sum(), 1))
        per_s = int(round(1 / dt))
        k = d["gospa"].shape[1] // per_s * per_s
        mirror = d.get("gospa_mirror")  # absent in chunks written before it was kept

        def by_s(a, k=k, per_s=per_s):
            return a[:, :k].reshape(a.shape[0], -1, per_s).mean((0, 2))

        summary[f"{management}/{method}"] = {
            "trials": int(d["gospa"].shape[0]),
            "gospa_mean": float(d["gospa"].mean()),
            "gospa_mirror_mean": None if mirror is None else float(mirror.mean()),
            "loc_rms": float(loc_rms),
            "missed_mean": float(d["missed"].mean()),
            "false_mean": float(d["false"].mean()),
            "below_mean": float(d["below"].mean()) if "below" in d else None,
            "gospa_per_s": by_s(d["gospa"]).round(2).tolist(),
            "gospa_mirror_per_s": None if mirror is None else by_s(mirror).round(2).tolist(),
            "confirmed_per_s": by_s(d["confirmed"]).round(2).tolist(),
            "present_per_s": by_s(d["present"]).round(2).tolist(),
        }
        s = summary[f"{management}/{method}"]
        lines.append(
            f"| {management} | {method} | {s['trials']} | {s['gospa_mean']:.2f} | "
            f"{loc_rms:.2f} | {s['missed_mean']:.2f} | {s['false_mean']:.2f} | "
            f"{(d['confirmed'] - d['present']).mean():+.2f} | "
            + ("– |" if mirror is None else f"{s['gospa_mirror_mean']:.2f} |")
        )
    (out / "summary.json").write_text(json.dumps(summary, indent=1))
    (out / "summary.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    for key, s in summary.items():
        print(f"{key}: confirmed per second {s['confirmed_per_s']}")
        print(f"{' ' * len(key)}  present per second   {s['present_per_s']}")
        print(f"{' ' * len(key)}  GOSPA per second     {s['gospa_per_s']}")
        print(f"{' ' * len(key)}  mirror-folded        {s['gospa_mirror_per_s']}")
        print(f"{' ' * len(key)}  drones below -c/2 per step {s['below_mean']}")
    return summary


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--trials", type=int, default=200)
    ap.add_argument("--chunk", type=int, default=50)
    ap.add_argument("--steps", type=int, default=1600)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--methods", default="ddr-sfim,stationary")
    ap.add_argument("--management", default="managed,known")
    ap.add_argument("--max-tracks", type=int, default=16)
    ap.add_argument(
        "--birth-scans",
        default="1",
        help="[tracker] birth_scans of the managed rows, a list (1,3: rows managed, managed_b3)",
    )
    ap.add_argument("--cutoff", type=float, default=50.0, help="GOSPA cut-off c [m]")
    ap.add_argument(
        "--ground-prior",
        choices=("on", "off"),
        default="on",
        help="[filter] ground_prior of every row: reflect estimates to z >= 0 (default on)",
    )
    ap.add_argument(
        "--tracker",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a [tracker] field of the managed runs, e.g. birth_height_std=30.0, association=gnn",
    )
    ap.add_argument(
        "--mpc",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="an [mpc] field of every run, e.g. alpha_assoc=10 (the planner against range "
        "coincidences)",
    )
    a = ap.parse_args(argv)
    try:
        scans = [int(b) for b in a.birth_scans.split(",")]
    except ValueError:
        scans = [0]
    if not all(1 <= b <= 10 for b in scans):
        ap.error(f"--birth-scans: integers in [1, 10], got {a.birth_scans!r}")
    tracker_options(ap, a.tracker)
    tracker_options(ap, a.mpc, "--mpc")
    rows = [(g, b) for g in a.management.split(",") for b in (scans if g == "managed" else [1])]
    runs = [(label(g, b), m, g, b) for g, b in rows for m in a.methods.split(",")]
    cases = [(name, m) for name, m, _, _ in runs]
    dt = None
    try:  # every row's scenario first: a bad field is one line before any run
        scenarios = {
            (k, b): scenario_for(
                k, a.max_tracks, a.steps, a.tracker, b, a.ground_prior == "on", a.mpc
            )
            for _, _, k, b in runs
        }
    except ScenarioError as e:
        ap.error(str(e))
    # XLA's deterministic GPU kernels, as `mjx-radar study` has them: a seed and a chunk
    # size then fix the numbers from one call to the next (mjx_radar.engine.determinism)
    determinism.apply()
    for management, method, kind, b in runs:
        sc = scenarios[kind, b]
        dt = sc.timing.dt_filter
        for t0 in range(0, a.trials, a.chunk):
            t1 = min(t0 + a.chunk, a.trials)
            f = a.out / management / method / f"trials_{t0:04d}_{t1:04d}.npz"
            if f.exists():
                print(f"{management}/{method} trials {t0}-{t1}: kept", flush=True)
                continue
            w = time.perf_counter()
            r = run_chunk(sc, method, a.seed, range(t0, t1), a.steps, a.cutoff)
            f.parent.mkdir(parents=True, exist_ok=True)
            np.savez_compressed(f.with_suffix(".tmp.npz"), **r)
            f.with_suffix(".tmp.npz").rename(f)
            print(
                f"{management}/{method} trials {t0}-{t1}: GOSPA {r['gospa'].mean():.2f} m, "
                f"confirmed {r['confirmed'].mean():.2f} vs present {r['present'].mean():.2f}, "
                f"missed {r['missed'].mean():.2f}, false {r['false'].mean():.2f} "
                f"({time.perf_counter() - w:.0f} s, compile {float(r['compile_s']):.0f} s)",
                flush=True,
            )
    summarise(a.out, dt, cases)


if __name__ == "__main__":
    main()
