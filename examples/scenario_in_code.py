"""A scenario built entirely in Python: radars, drones and obstacles, then saved and run.

    python examples/scenario_in_code.py [--small]

Writes the scenario as TOML (loadable by ``mjx-radar run``) and the run directory
(``mjx-radar render`` / ``snapshot`` / ``mjx_radar.Run.load`` read it).
"""

import math

from _common import parse

import mjx_radar
from mjx_radar import MPCConfig, MPPIConfig, Obstacle, Scenario, Timing

args = parse(__doc__.splitlines()[0], "scenario_in_code")
n = 2 if args.small else 4
scenario = Scenario(
    name="two_blocks",
    n_radars=n,
    # drones: rows [x, y, z, vx, vy, vz] in m and m/s
    target_init=((0.0, 20.0, 60.0, 12.0, 4.0, 0.0), (-20.0, -10.0, 45.0, -8.0, 10.0, 0.0)),
    # fixed radar starts [x, y, heading], required with obstacles
    radar_init=tuple(
        (250.0 * math.cos(a), 250.0 * math.sin(a), a + math.pi)
        for a in (2 * math.pi * i / n for i in range(n))
    ),
    obstacles=(
        Obstacle(kind="box", pos=(120.0, 120.0, 0.0), size=(30.0, 20.0, 25.0)),  # half extents
        Obstacle(kind="cylinder", pos=(-120.0, 100.0, 0.0), size=(15.0, 20.0)),  # r, half height
    ),
    timing=Timing(steps=16 if args.small else 400),
    mpc=MPCConfig(
        horizon=8 if args.small else 15,
        los=True,  # occlusion-aware planner
        rollout="analytic" if args.small else "mjx",
    ),  # small: compiles faster
    mppi=MPPIConfig(samples=64, iterations=3) if args.small else MPPIConfig(),
)
scenario = mjx_radar.validate(scenario)  # the rules of a TOML file; ScenarioError if not
scenario.to_toml(args.out / "two_blocks.toml")

run = mjx_radar.simulate(scenario, "ddr-sfim", trials=2 if args.small else 4, seed=1)
run.save(args.out / "run", force=True)
print(run.summary())
ds = run.trajectories  # xarray: dims trial, step, radar, radar_state, ...
travelled = abs(ds.radar_states.sel(radar_state="v")).mean(["trial", "step"]) * ds.time_s[-1]
print("mean distance driven per radar [m]:", travelled.values.round(1))
print(f"wrote {args.out / 'two_blocks.toml'} and {args.out / 'run'}")
