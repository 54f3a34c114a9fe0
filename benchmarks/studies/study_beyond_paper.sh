#!/bin/bash
# Issue 22's study on a GPU: DDR-SFIM vs stationary vs CCR-SFIM, 200 trials each, on the
# three scenarios beyond the paper (docs/beyond_paper.md, docs/scenarios.md):
#
#   scenarios/waypoints_3r4t.toml  four drones flying waypoint missions (1200 steps, 30 s)
#   scenarios/mixed_6r4t.toml      two fixed long-range sites + four mobile vehicles (600 steps)
#   scenarios/raid_4r8t.toml       eight drones in two waves with appear / leave times (1600 steps)
#
# Usage (from the repository root, after `pip install -e .` with JAX for the GPU):
#   bash benchmarks/studies/study_beyond_paper.sh [OUT_ROOT]      # default studies/beyond_paper
# Each study is resumable: re-running the same command continues it (--resume).
# Then fill in docs/beyond_paper.md's results section from OUT_ROOT/*/report.md.
#
# CV filter vs IMM: the three scenarios run the paper's CV CKF (filter.structure =
# "joint"); the manoeuvring scenario is also run with the per-target CV bank and with the
# per-target IMM bank (filter.motion = "imm": CV + coordinated turns, docs/filters.md), the
# CV-vs-IMM comparison on the same filter structure.
set -euo pipefail

OUT=${1:-studies/beyond_paper}
TRIALS=200
METHODS=ddr-sfim,stationary,ccr-sfim
SEED=0
mkdir -p "$OUT"

study() {  # study NAME SCENARIO [extra args]
  local name=$1 scenario=$2; shift 2
  local resume=()
  [ -f "$OUT/$name/study.json" ] && resume=(--resume)
  mjx-radar study "$scenario" --methods "$METHODS" --trials "$TRIALS" --seed "$SEED" \
    --chunk 50 --out "$OUT/$name" "${resume[@]}" "$@"
  mjx-radar report "$OUT/$name"
}

study waypoints   scenarios/waypoints_3r4t.toml
study mixed       scenarios/mixed_6r4t.toml
study raid        scenarios/raid_4r8t.toml

# The manoeuvring scenario with the per-target CV bank (the baseline of the IMM below).
BANK="$OUT/waypoints_per_target.toml"
sed -e 's/^name = "waypoints_3r4t"/name = "waypoints_3r4t_bank"/' \
    scenarios/waypoints_3r4t.toml > "$BANK"
printf '\n[filter]\nstructure = "per-target"\n' >> "$BANK"
study waypoints_bank "$BANK"

# The same per-target bank with the IMM (CV + CT(+-w), the [filter] defaults w, p_s).
IMM="$OUT/waypoints_imm.toml"
sed -e 's/^name = "waypoints_3r4t"/name = "waypoints_3r4t_imm"/' \
    scenarios/waypoints_3r4t.toml > "$IMM"
printf '\n[filter]\nstructure = "per-target"\nmotion = "imm"\n' >> "$IMM"
study waypoints_imm "$IMM"

echo "studies in $OUT: waypoints mixed raid waypoints_bank waypoints_imm (report.md in each)"
