#!/usr/bin/env bash
# Issue 23 study (docs/detection.md): on clutter_3r4t (Swerling I Pd from each radar's SNR),
# DDR-SFIM planning with the Pd-aware cost (detection.planner = true, the bundled scenario)
# and without it (planner = false, the same world) vs stationary radars; 200 trials (GPU).
#
#   benchmarks/studies/study_detection.sh [OUT] [TRIALS]          # GPU: defaults runs/study_detection 200
#   STEPS=40 ROLLOUTS=analytic benchmarks/studies/study_detection.sh /tmp/det_cpu 2   # small CPU check
set -euo pipefail
out=${1:-runs/study_detection}
trials=${2:-200}
mjx=${MJX_RADAR:-mjx-radar}    # e.g. MJX_RADAR=.venv/bin/mjx-radar PYTHON=.venv/bin/python
py=${PYTHON:-python}
extra=()
[[ -n ${STEPS:-} ]] && extra+=(--steps "$STEPS")
[[ -n ${ROLLOUTS:-} ]] && extra+=(--rollouts "$ROLLOUTS")
mkdir -p "$out/scenarios"
src=$("$py" -c 'from mjx_radar.scenario.reader import resolve_path; print(resolve_path("clutter_3r4t"))')
cp "$src" "$out/scenarios/clutter_3r4t.toml"
sed -e 's/^name = "clutter_3r4t"/name = "clutter_3r4t_pd_blind"/' \
    -e 's/^planner = true .*/planner = false/' "$src" > "$out/scenarios/clutter_3r4t_pd_blind.toml"
grep -q '^planner = false' "$out/scenarios/clutter_3r4t_pd_blind.toml"
# stationary radars do not plan: one run of them (on the Pd-aware file) is the baseline
$mjx study "$out/scenarios/clutter_3r4t.toml" --methods stationary,ddr-sfim \
  --trials "$trials" "${extra[@]}" --out "$out/pd_aware"
$mjx study "$out/scenarios/clutter_3r4t_pd_blind.toml" --methods ddr-sfim \
  --trials "$trials" "${extra[@]}" --out "$out/pd_blind"
$mjx report "$out/pd_aware"
$mjx report "$out/pd_blind"
