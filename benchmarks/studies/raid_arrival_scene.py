"""The managed track table alone on ``raid_4r8t``'s first wave (docs/track_management.md).

No planner and no physics: four radars stand still at a random placement (uniform in
``±placement_half_width``, on the ground), the four drones of wave 1 fly CV with white
acceleration (``sigma_w2``) and each scan goes to the tracker's predict and update, as
in the closed loop. A fast loop on a CPU for what the arrivals cost (one compile, then
B layouts x T scans vmapped). Per scan: drones with a confirmed track within c, false
confirmed tracks, GOSPA (c, p = 2, α = 2); and, for each drone without a track, the
nearest live track: its distance, the drone's χ² under that track's position
covariance, the radars that saw it::

    python benchmarks/studies/raid_arrival_scene.py --layouts 32 --scans 120 \\
        --tracker height_std=60 --tracker birth_height_std=15
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))  # run_raid_managed, diagnose_raid_tracks

#: the study's recommended table ("Height priors of births and tracks"); --tracker overrides
BASE = {
    "management": "managed",
    "max_tracks": 16,
    "association": "jpda",
    "marginals": "lbp",
    "hit_radars": 4,
    "delete_misses": 10,
    "birth_scans": 2,
}


def simulate(options: dict, layouts: int, scans: int, seed: int) -> dict:
    """``{exist, pos, truth, status, cov, seen, radars}`` per layout and scan (numpy)."""
    import jax
    import jax.numpy as jnp

    from mjx_radar.env import trackers
    from mjx_radar.env.scan import Scan
    from mjx_radar.scenario.reader import load_scenario
    from mjx_radar.task.task import build

    sc = load_scenario("raid_4r8t")
    drones = np.asarray(sc.target_init, np.float32)[:4]
    fixed = [[-300.0, -200, 0], [250, -300, 0], [300, 250, 0], [-250, 300, 0]]  # replaced
    sc = sc.replace(
        target_init=drones.tolist(),
        target_motion=(),
        radars=fixed,
        tracker={**BASE, **options},
        filter={"structure": "per-target", "ground_prior": True},
    )
    task, params = build(sc, "stationary")
    ops, model, noise = trackers.make(task, params), task.measurement, params.noise
    dt, q, w = sc.timing.dt_filter, params.sigma_w2, sc.placement_half_width
    multi = sc.tracker.birth_scans > 1
    eye, zero = jnp.eye(6 * len(drones)), jnp.zeros(6 * len(drones))
    none = Scan(None, jnp.int32(0), jnp.int32(0), jnp.int32(0), None, None)

    def one(key):
        k_r, key = jax.random.split(key)
        xy = jax.random.uniform(k_r, (4, 2), minval=-w, maxval=w)
        radars = jnp.concatenate([xy, jnp.zeros((4, 1))], 1)

        def scan(carry, _):
            modes, key, x = carry
            key, k_z, k_w = jax.random.split(key, 3)
            dv = jnp.sqrt(q * dt) * jax.random.normal(k_w, (len(drones), 3))
            x = x.at[:, 3:].add(dv).at[:, :3].add(dt * x[:, 3:])
            z = model.sample(k_z, radars, x[:, :3], noise)
            _, _, modes = ops.predict(zero, eye, modes)
            _, _, modes = ops.update(zero, eye, modes, z, radars, none)
            view, table = ops.tracks(modes), (modes[0] if multi else modes)
            cov = table.cov[:, :3, :3]
            out = (view.exist, view.mean[:, :3], x[:, :3], table.status, cov, table.gated.sum(-1))
            return (modes, key, x), (*out, radars)

        init = (ops.init(zero, eye), key, jnp.asarray(drones))
        return jax.lax.scan(scan, init, None, length=scans)[1]

    keys = jax.random.split(jax.random.PRNGKey(seed), layouts)
    names = ("exist", "pos", "truth", "status", "cov", "seen", "radars")
    return dict(zip(names, (np.asarray(a) for a in jax.jit(jax.vmap(one))(keys)), strict=True))


def score(rec: dict, c: float):
    """``found, false, gospa [B, T]`` and the nearest live track of each missed drone
    (GOSPA and its assignment: ``run_raid_managed.gospa``, ``diagnose_raid_tracks.matches``)."""
    from diagnose_raid_tracks import matches
    from run_raid_managed import gospa as gospa_of

    b_n, t_n, m = rec["truth"].shape[:3]
    found, false, gospa = np.zeros((b_n, t_n)), np.zeros((b_n, t_n)), np.zeros((b_n, t_n))
    present = np.ones(m, bool)  # the first wave: every drone present
    nearest = []  # (scan, distance, χ², radars that saw it, confirmed)
    for b in range(b_n):
        for k in range(t_n):
            truth, pos, exist = rec["truth"][b, k], rec["pos"][b, k], rec["exist"][b, k]
            gospa[b, k], _, missed, false[b, k] = gospa_of(truth, present, pos, exist, c)
            found[b, k] = m - missed
            live = np.flatnonzero(rec["status"][b, k] > 0)
            got = matches(truth, present, pos, exist, c)
            for i in np.setdiff1d(np.arange(m), got) if live.size else ():
                e = pos[live] - truth[i]
                j = np.argmin(np.linalg.norm(e, axis=-1))
                chi2 = e[j] @ np.linalg.solve(rec["cov"][b, k][live[j]], e[j])
                st = rec["status"][b, k][live[j]] == 2
                nearest.append((k, np.linalg.norm(e[j]), chi2, rec["seen"][b, k][live[j]], st))
    return found, false, gospa, np.asarray(nearest).reshape(-1, 5)


def main(argv=None) -> int:
    from run_raid_managed import tracker_options

    from mjx_radar.errors import ScenarioError

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--layouts", type=int, default=32)
    ap.add_argument("--scans", type=int, default=120)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--cutoff", type=float, default=50.0)
    ap.add_argument("--tracker", action="append", default=[], metavar="KEY=VALUE")
    a = ap.parse_args(argv)
    try:
        rec = simulate(tracker_options(ap, a.tracker), a.layouts, a.scans, a.seed)
    except ScenarioError as e:  # a bad --tracker field: one line, before any work
        ap.error(str(e))
    found, false, gospa, near = score(rec, a.cutoff)
    for k in sorted({4, 10, 20, 40, a.scans // 2, a.scans - 1}):
        f, g, e = found[:, k].mean(), false[:, k].mean(), gospa[:, k].mean()
        print(f"scan {k + 1:4d}: found {f:.2f}, false {g:.2f}, GOSPA {e:.1f} m")
    print(f"mean GOSPA over {a.scans} scans: {gospa.mean():.2f} m")
    late = near[near[:, 0] >= a.scans // 3]  # after the first third: not births' latency
    conf = late[late[:, 4] == 1]
    print(f"missed drone-steps after scan {a.scans // 3}: {len(late)}, the nearest live track")
    if len(conf):
        q = lambda x: np.quantile(x, [0.1, 0.5, 0.9]).round(1).tolist()  # noqa: E731
        print(f"  confirmed in {len(conf) / len(late):.2f}; of those, 10/50/90 %:")
        print(f"  distance [m] {q(conf[:, 1])}, the drone's chi2 under its P {q(conf[:, 2])}")
        print(f"  radars that saw it {q(conf[:, 3])}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
