#!/usr/bin/env bash
# Distil DDR-SFIM MPPI into one set policy for paper_3r4t and paper_4r4t (behaviour
# cloning, then DAgger), optionally fine-tune it with PPO, then evaluate it against MPPI
# on paper_3r4t and on paper_6r3t (a fleet it never saw): median RMSE, radar-drone pairs
# inside the keep-out, ms per control call (docs/learning.md, "Distillation").
# On one GPU, from the repository root, after `source scripts/gpu_setup.sh`:
#   bash benchmarks/studies/distill_policy.sh
# Resumable: every stage checkpoints (the policy after each iteration, each evaluation
# figure as it comes) and is skipped once done; the command stops itself before BUDGET
# seconds (default 540), so the same command again goes on where it stopped (keep runs/
# on the machine, or carry runs/distill: without its state.npz files, a resume starts
# Adam and the replay buffers afresh from the saved network). With $OUT set, all of RUN
# but state.npz and the result file are copied there. It prints "distill_policy: done".
# Settings (environment variables): RUN, TRIALS, BUDGET, BC_STEPS, DAGGER_STEPS,
# PPO_STEPS (0: no fine-tuning), NUM_ENVS, UPDATES, RESULT (the benchmarks/results file),
# SHIELD (1: the keep-out shield on the policy's controls, in training and in policy:DIR),
# TRAIN (scenarios distilled on), EVAL (scenarios evaluated on), TUNE (PPO's scenario),
# FEATURES (v1, or v2: keep-out and ground / line-of-sight set features), KEEPOUT_WEIGHT
# (the cloning loss's keep-out hinge, 0: off), COMMAND (the result file's command line),
# DEPLOY_SHIELD (1: also evaluate shielded-policy:DIR, the shield at evaluation only).
# BC_STEPS and DAGGER_STEPS default to 6 and 20 iterations of NUM_ENVS trials x 150
# periods x the TRAIN scenarios. The keep-out and terrain run (paper_3r4t, paper_6r3t and
# hills_4r4t, one call; 4 + 8 iterations of the three scenarios):
#   FEATURES=v2 KEEPOUT_WEIGHT=1000 TRAIN=paper_3r4t,paper_4r4t,hills_4r4t \
#   EVAL=paper_3r4t,paper_6r3t,hills_4r4t BC_STEPS=460800 DAGGER_STEPS=1382400 \
#   RUN=runs/distill_v2 RESULT=benchmarks/results/distill_policy_v2_h200.json \
#   bash benchmarks/studies/distill_policy.sh
set -euo pipefail
RUN=${RUN:-runs/distill}
TRIALS=${TRIALS:-500}
BUDGET=${BUDGET:-540}
NUM_ENVS=${NUM_ENVS:-256}
TRAIN=${TRAIN:-paper_3r4t,paper_4r4t}
# one iteration = NUM_ENVS trials x 150 periods x 2 scenarios = 76,800 labelled steps at 256
ITER=$((NUM_ENVS * 150 * $(echo "$TRAIN" | tr ',' '\n' | grep -c .)))
BC_STEPS=${BC_STEPS:-$((6 * ITER))}        # 6 iterations, MPPI driving (460800)
DAGGER_STEPS=${DAGGER_STEPS:-$((20 * ITER))}  # 14 more, the policy driving (1536000)
PPO_STEPS=${PPO_STEPS:-0}           # > DAGGER_STEPS: fine-tune on paper_3r4t to this total
RESULT=${RESULT:-benchmarks/results/distill_policy_h200.json}
FEATURES=${FEATURES:-v1}
KEEPOUT_WEIGHT=${KEEPOUT_WEIGHT:-0}
EVAL=${EVAL:-paper_3r4t,paper_6r3t}
TUNE=${TUNE:-paper_3r4t}
UPDATES=${UPDATES:-300}
POLICY=$RUN/policy
START=$(date +%s)
mkdir -p "$RUN"
left() { echo $((BUDGET - ($(date +%s) - START))); }
minutes() { python3 -c "print(max(0.5, ($(left) - ${1:-0}) / 60))"; }
stage_steps() { # steps done by stage $1: bc, dagger (a later stage: all), ppo (an earlier: none)
  python3 - "$POLICY/policy.json" "$1" <<'PY' 2>/dev/null || echo 0
import json, sys
order = ["bc", "dagger", "ppo"]
s = json.load(open(sys.argv[1]))
now, stage = order.index(s.get("algo", "ppo")), order.index(sys.argv[2])
print(s["steps_done"] if now == stage else (10**15 if now > stage else 0))
PY
}
save_out() { # what comes back from a device run: all of RUN but the buffers (state.npz)
  [ -n "${OUT:-}" ] || return 0
  mkdir -p "$OUT/distill"
  (cd "$RUN" && find . -type f ! -name state.npz -print0 | tar --null -cf - -T -) |
    tar -xf - -C "$OUT/distill"
  if [ -f "$RESULT" ]; then cp "$RESULT" "$OUT/"; fi
}
enough() { # enough time left for a stage that needs $1 seconds (compile and one step)?
  if [ "$(left)" -lt "$1" ]; then
    echo "distill_policy: $(left) s left, run the same command again to go on"
    save_out
    exit 0
  fi
}
COMMON=(--num-envs "$NUM_ENVS" --batch-size 512 --updates "$UPDATES" --hidden 64 --buffer-size 120000 --lr 1e-3)
if [ "${SHIELD:-0}" = 1 ]; then COMMON+=(--shield); fi
EXTRA=""
if [ "$FEATURES" != v1 ] || [ "$KEEPOUT_WEIGHT" != 0 ]; then
  COMMON+=(--features "$FEATURES" --keepout-weight "$KEEPOUT_WEIGHT")
  EXTRA=", features $FEATURES, keep-out weight $KEEPOUT_WEIGHT"
fi
if [ "$(stage_steps bc)" -lt "$BC_STEPS" ]; then
  enough 150
  python3 scripts/train_policy.py "$TRAIN" --algo bc --steps "$BC_STEPS" \
    --out "$POLICY" "${COMMON[@]}" --max-minutes "$(minutes 20)"
fi
[ "$(stage_steps bc)" -ge "$BC_STEPS" ] || { echo "distill_policy: bc not done, run again"; save_out; exit 0; }
if [ "$(stage_steps dagger)" -lt "$DAGGER_STEPS" ]; then
  enough 150
  python3 scripts/train_policy.py "$TRAIN" --algo dagger --steps "$DAGGER_STEPS" \
    --out "$POLICY" "${COMMON[@]}" --beta 0 --max-minutes "$(minutes 20)"
fi
[ "$(stage_steps dagger)" -ge "$DAGGER_STEPS" ] || { echo "distill_policy: dagger not done, run again"; save_out; exit 0; }
if [ "$PPO_STEPS" -gt "$DAGGER_STEPS" ] && [ "$(stage_steps ppo)" -lt "$PPO_STEPS" ]; then
  enough 240
  python3 scripts/train_policy.py "$TUNE" --algo ppo --steps "$PPO_STEPS" --out "$POLICY" \
    --num-envs 1024 --batch-size 512 --num-minibatches 16 --unroll-length 10 --lr 1e-4 \
    --init-noise-std 0.2 --penalty-scale 1 --no-eval --eval-every 2000000 \
    --max-minutes "$(minutes 20)"
  [ "$(stage_steps ppo)" -ge "$PPO_STEPS" ] || { echo "distill_policy: ppo not done, run again"; save_out; exit 0; }
fi
enough 120
DEPLOY=""
if [ "${DEPLOY_SHIELD:-0}" = 1 ]; then DEPLOY="--deploy-shield"; fi
timeout "$(($(left) - 10))" python3 benchmarks/studies/distill_eval.py --policy "$POLICY" \
  --scenarios "$EVAL" --trials "$TRIALS" --work "$RUN/eval" --json "$RESULT" $DEPLOY \
  --label "Trained on $TRAIN: bc to $BC_STEPS, dagger to $DAGGER_STEPS labelled steps, ppo to $PPO_STEPS, shield ${SHIELD:-0}$EXTRA; curve: $RUN/policy/curve.csv." \
  --command "${COMMAND:-bash benchmarks/studies/distill_policy.sh}" || {
  echo "distill_policy: evaluation cut short, run the same command again to go on"
  save_out
  exit 0
}
save_out
echo "distill_policy: done ($RESULT)"
