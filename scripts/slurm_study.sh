#!/bin/bash
# The paper's Monte Carlo study on a SLURM cluster (docs/scaling.md, "Studies over devices,
# processes and hosts"). Both ways write chunk files to one shared study directory:
#
#   1. Array job, 4 independent tasks of one GPU each (`--shard I/N`), then a
#      dependent job that consolidates (`--resume`) and writes the report:
#        bash scripts/slurm_study.sh submit            # on the login node
#   2. One job over several nodes, one process per node, JAX's multi-controller
#      runtime (`--distributed`; process 0 consolidates):
#        sbatch --nodes=4 --array=0 scripts/slurm_study.sh distributed
#
# Every worker must get the same arguments (scenarios, --methods, --trials, --steps,
# --seed, --chunk, --rollouts, --precision): they fix the numbers, and a worker with
# other values is refused (exit 2). The numbers do not depend on how many tasks, GPUs
# or nodes run them. Edit the #SBATCH lines (partition, account, time) for your cluster.
#
#SBATCH --job-name=mjx-radar-study   # name shown by squeue
#SBATCH --array=0-3                  # 4 shards: SLURM_ARRAY_TASK_ID = 0..3, SLURM_ARRAY_TASK_COUNT = 4
#SBATCH --nodes=1                    # one node per array task (distributed: --nodes=K on the command line)
#SBATCH --ntasks-per-node=1          # one process per node
#SBATCH --gpus-per-task=1            # one GPU per process (a process uses every GPU it is given)
#SBATCH --cpus-per-task=8            # host threads: XLA compiles the scenarios' programs in parallel
#SBATCH --mem=64G                    # host memory per process
#SBATCH --time=04:00:00              # per task; a task killed by the limit loses only its chunk in flight
#SBATCH --output=slurm-%x-%A_%a.out  # one log per array task (%A: array job id, %a: task id)

set -euo pipefail                                   # stop at the first failing command

MODE=${1:-shard}                                    # submit | shard | consolidate | distributed
STUDY_DIR=${STUDY_DIR:-$PWD/studies/paper}          # shared directory: every node must see it
CHUNK=${CHUNK:-125}                                 # trials per GPU per call and per file: part of the numbers
export MJX_RADAR_CACHE_DIR=${MJX_RADAR_CACHE_DIR:-$PWD/.cache/mjx_radar}  # shared compilation cache
STUDY_ARGS=(                                        # the paper study: 3 scenarios x 5 methods x 500 trials
  scenarios/paper_3r4t.toml scenarios/paper_6r3t.toml scenarios/paper_4r4t.toml
  --trials 500 --chunk "$CHUNK" --out "$STUDY_DIR"  # 600 steps (the scenarios'), all methods, seed 0
)

case "$MODE" in
submit)                                             # login node: the array, then the final step
  SELF=$(readlink -f "$0")                          # this script, by absolute path
  JOB=$(sbatch --parsable "$SELF" shard)            # 4 array tasks; prints the array job id
  sbatch --dependency=afterany:"$JOB" --array=0 "$SELF" consolidate  # after all tasks ended, ok or not
  echo "submitted array job $JOB and its consolidation"  # squeue -u $USER shows both
  ;;
shard)                                              # one array task = one shard of the chunks
  N=${SLURM_ARRAY_TASK_COUNT:?run through sbatch --array}  # number of shards (4 with --array=0-3)
  I=${SLURM_ARRAY_TASK_ID:?run through sbatch --array}     # this task's shard, 0..N-1
  mjx-radar study "${STUDY_ARGS[@]}" --shard "$I/$N"       # chunks i with i % N == I; present files skipped
  ;;                                                # the last shard to finish consolidates already
consolidate)                                        # after the array: redo lost chunks, consolidate
  mjx-radar study "${STUDY_ARGS[@]}" --resume       # runs only chunks a killed task lost; writes study.json
  mjx-radar report "$STUDY_DIR"                     # figures/*.png, summary.csv, report.md
  ;;
distributed)                                        # one job, K nodes, one process per node
  srun --ntasks-per-node=1 \
    mjx-radar study "${STUDY_ARGS[@]}" --distributed  # coordinator, process count and id: from SLURM
  mjx-radar report "$STUDY_DIR"                     # process 0 consolidated before srun returned
  ;;
*)
  echo "usage: bash $0 submit | sbatch --nodes=K --array=0 $0 distributed" >&2  # a wrong mode
  exit 2
  ;;
esac
