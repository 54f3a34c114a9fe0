#!/usr/bin/env bash
# Issue 24, terrain: the 200-trial study of DDR-SFIM on hills_4r4t with and without
# occlusion-aware planning (mpc.los), for docs/terrain.md ("Study" section).
# Run on a GPU machine from the repository root (after `source scripts/gpu_setup.sh`):
#   bash benchmarks/studies/study_terrain.sh [OUT_DIR]
# Writes OUT_DIR/los_off and OUT_DIR/los_on (study.json, report.md, figures) and prints
# the two summaries; same seed and trials in both, so trial i is the same world
# (placement, drones, noise) in both studies (common random numbers).
set -euo pipefail
OUT=${1:-runs/study_terrain}
TRIALS=${TRIALS:-200}
mkdir -p "$OUT"
# The occlusion-aware variant: hills_4r4t with mpc.los = true, written through the Python
# API (Scenario.replace + to_toml: the terrain path becomes absolute, so the copy works
# from any folder).
python3 - "$OUT" <<'PY'
import sys
from pathlib import Path
import mjx_radar
s = mjx_radar.load_scenario("scenarios/hills_4r4t.toml")
s.replace(name="hills_4r4t_los", mpc={"los": True}).to_toml(Path(sys.argv[1]) / "hills_4r4t_los.toml")
PY
python3 -m mjx_radar study scenarios/hills_4r4t.toml --methods ddr-sfim --trials "$TRIALS" \
  --seed 0 --out "$OUT/los_off"
python3 -m mjx_radar study "$OUT/hills_4r4t_los.toml" --methods ddr-sfim --trials "$TRIALS" \
  --seed 0 --out "$OUT/los_on"
python3 -m mjx_radar report "$OUT/los_off" || true
python3 -m mjx_radar report "$OUT/los_on" || true
# One table for docs/terrain.md: per study, RMSE (mean over trials and steps, and at the
# last step), lost-track rate at the last step, and mean visible pairs per step.
python3 - "$OUT" <<'PY'
import sys
from pathlib import Path
import pandas as pd
out = Path(sys.argv[1])
for name in ("los_off", "los_on"):
    m = pd.read_parquet(out / name / "metrics.parquet")
    last = m[m.step == m.step.max()]
    print(f"{name}: trials {m.trial.nunique()}, rmse_pos mean {m.rmse_pos.mean():.2f} m, "
          f"median at last step {last.rmse_pos.median():.2f} m, lost at last step "
          f"{last.lost.mean():.3f}, visible_pairs mean {m.visible_pairs.mean():.2f} of 16")
PY
