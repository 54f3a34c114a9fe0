#!/usr/bin/env bash
# clutter_3r4t on one GPU (docs/tracking.md, "Association over time"): JPDA against the
# K-best MHT (K = 16, 64, 256; K = 16 and 64 with label-free merging), DDR-SFIM, 200 trials x 600 steps, and the figures at 200 steps
# from the same runs' first 200 steps (draw for draw the 200-step run): lost and unmatched
# trials, median per-trial mean GOSPA and RMSE. One process per variant on the same GPU (their
# compilations overlap; no preallocation), then one pass that reads the finished studies back
# and writes OUT/trackers.csv and benchmarks/results/clutter_trackers_TAG.json (TAG: h200).
#
#   source scripts/gpu_setup.sh && bash benchmarks/studies/clutter_trackers.sh [OUT] [TRIALS]
#   STEPS=40 PREFIX=20 TAG=cpu VARIANTS=jpda,mht bash benchmarks/studies/clutter_trackers.sh /tmp/ct 2
#   VARIANTS=mht-1024 TAG=h200_k1024 bash benchmarks/studies/clutter_trackers.sh   # K = 1024 alone
#   VARIANTS=jpda,mht-jpda,mht-jpda-b4 TAG=h200_branch bash benchmarks/studies/clutter_trackers.sh  # branch, then JPDA
#
# The labelled observer's figures (the bound the goals are stated against) come from
# benchmarks/studies/association_bound.py; BOUND=1 adds its 200-step run afterwards.
set -euo pipefail
out=${1:-runs/clutter_trackers}
trials=${2:-200}
py=${PYTHON:-python3}
variants=${VARIANTS:-jpda,mht,mht-64,mht-256,mht-16-labels,mht-64-labels}
tag=${TAG:-h200}
common=(--out "$out" --methods ddr-sfim --trials "$trials" --chunk "$trials"
  --steps "${STEPS:-600}" --prefix "${PREFIX:-200}")
mkdir -p "$out"
pids=()
for v in ${variants//,/ }; do
  XLA_PYTHON_CLIENT_PREALLOCATE=false "$py" benchmarks/studies/compare_trackers.py \
    "${common[@]}" --variants "$v" > "$out/$v.log" 2>&1 &
  pids+=($!)
done
status=0
for p in "${pids[@]}"; do wait "$p" || status=1; done
tail -n 3 "$out"/*.log
[[ $status == 0 ]] || { echo "clutter_trackers: a variant failed (logs in $out)"; exit 1; }
"$py" benchmarks/studies/compare_trackers.py "${common[@]}" --variants "$variants" \
  --result "clutter_trackers_${tag}"
if [[ ${BOUND:-0} == 1 ]]; then
  "$py" benchmarks/studies/association_bound.py --out "$out/bound_200" --method ddr-sfim \
    --trials "$trials" --steps 200 --chunk 50
fi
