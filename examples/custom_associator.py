"""An associator of your own, registered from the script and used by a scenario (docs/extending.md).

    python examples/custom_associator.py [--small]
    mjx-radar run clutter_3r4t --plugin examples/custom_associator.py --association auction

The associator (examples/_auction.py, one module) is a global nearest neighbour per radar:
the assignment of tracks to a cluttered scan's returns of least total Mahalanobis
distance, found by Bertsekas' auction. One registration makes it ``[tracker] association
= "auction"``: it drives the per-target bank and, with ``[tracker] management =
"managed"``, the track table. The script compares it with the built-in PDA.
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))  # _auction.py, also as --plugin

from _auction import auction_associator  # noqa: E402

import mjx_radar  # noqa: E402

mjx_radar.register_associator("auction", auction_associator)

if __name__ == "__main__":
    from _common import parse, small

    args = parse(__doc__.splitlines()[0], "custom_associator")
    scenario = small(mjx_radar.load_scenario("clutter_3r4t"), args)
    trials, steps = (1, 16) if args.small else (8, None)
    method = "stationary" if args.small else "ddr-sfim"  # small: no planner to compile
    lines = []
    for association in ("pda", "auction"):
        s = scenario.replace(tracker={"association": association})
        run = mjx_radar.simulate(s, method, trials=trials, steps=steps, seed=0, progress=False)
        lines.append(f"{association:>8}: mean RMSE {run.summary()['rmse_pos']:.3f} m")
    print("\n".join(lines))
    (args.out / "custom_associator.txt").write_text("\n".join(lines) + "\n")
