#!/usr/bin/env bash
# clutter_3r4t on one GPU (docs/tracking.md, "The multiple-hypothesis tracker"): JPDA against
# the K-best MHT (K = 16 and 64), DDR-SFIM, 200 trials x 600 steps, the figures at 200 steps
# from the same runs' first 200 steps (draw for draw the 200-step run): lost and unmatched
# trials, median per-trial mean GOSPA and RMSE. Writes the studies under OUT and the table
# to benchmarks/results/clutter_trackers_TAG.json (TAG default h200).
#
#   source scripts/gpu_setup.sh && bash benchmarks/studies/clutter_trackers.sh [OUT] [TRIALS]
#   STEPS=40 PREFIX=20 TAG=cpu bash benchmarks/studies/clutter_trackers.sh /tmp/ct 2   # CPU check
#
# The labelled observer's figures (the bound the goal is stated against) come from
# benchmarks/studies/association_bound.py (BOUND=1 adds its 200-step run, about 2 min more).
set -euo pipefail
out=${1:-runs/clutter_trackers}
trials=${2:-200}
py=${PYTHON:-python3}
variants=${VARIANTS:-jpda,mht,mht-64}
tag=${TAG:-h200}
"$py" benchmarks/studies/compare_trackers.py --out "$out" --variants "$variants" \
  --methods ddr-sfim --trials "$trials" --chunk "$trials" --steps "${STEPS:-600}" \
  --prefix "${PREFIX:-200}" --result "clutter_trackers_${tag}"
if [[ ${BOUND:-0} == 1 ]]; then
  "$py" benchmarks/studies/association_bound.py --out "$out/bound_200" --method ddr-sfim \
    --trials "$trials" --steps 200 --chunk 50
fi
