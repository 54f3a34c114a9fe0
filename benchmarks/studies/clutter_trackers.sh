#!/usr/bin/env bash
# clutter_3r4t on one GPU (docs/tracking.md, "The multiple-hypothesis tracker"): JPDA against
# the K-best MHT, DDR-SFIM, 200 trials, at 200 and at 600 steps; lost and unmatched trials,
# median per-trial mean GOSPA and RMSE. Writes the studies under OUT and the tables to
# benchmarks/results/clutter_trackers_{200,600}_TAG.json (TAG default h200).
#
#   source scripts/gpu_setup.sh && bash benchmarks/studies/clutter_trackers.sh [OUT] [TRIALS]
#   VARIANTS=jpda,mht,mht-64 TAG=cpu bash benchmarks/studies/clutter_trackers.sh /tmp/ct 8
#
# The labelled observer's figures (the bound the goal is stated against) come from
# benchmarks/studies/association_bound.py (BOUND=1 adds its 200-step run, about 2 min more).
set -euo pipefail
out=${1:-runs/clutter_trackers}
trials=${2:-200}
py=${PYTHON:-python3}
variants=${VARIANTS:-jpda,mht}
tag=${TAG:-h200}
for steps in 200 600; do
  "$py" benchmarks/studies/compare_trackers.py --out "$out/steps_$steps" --variants "$variants" \
    --methods ddr-sfim --trials "$trials" --chunk "$trials" --steps "$steps" \
    --result "clutter_trackers_${steps}_${tag}"
done
if [[ ${BOUND:-0} == 1 ]]; then
  "$py" benchmarks/studies/association_bound.py --out "$out/bound_200" --method ddr-sfim \
    --trials "$trials" --steps 200 --chunk 50
fi
