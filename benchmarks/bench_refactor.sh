#!/usr/bin/env bash
# A refactor's cost on the CPU: the README quick start's cold compile (split by JAX's own
# compile-duration events, benchmarks/compile_split.py) and one MPPI call
# (bench_mppi.py), for the code before (a source tree, e.g. `git worktree add BASE REV`)
# and this tree, PAIRS pairs side by side, each process pinned to its own 2 cores
# (needs 4 x PAIRS cores). Prints one line per process; compare medians.
#   bash benchmarks/bench_refactor.sh BASE [PAIRS]
set -euo pipefail
BASE=$(cd "$1" && pwd); PAIRS=${2:-4}; NEW=$(pwd); SPLIT=$NEW/benchmarks/compile_split.py
export JAX_PLATFORMS=cpu
one() { # tree label cores i
  local tree=$1 label=$2 cores=$3 i=$4 tmp
  tmp=$(mktemp -d)
  cd "$tree"
  local bench=benchmarks/bench_mppi.py; [ -f "$bench" ] || bench=scripts/bench_mppi.py
  PYTHONPATH=${EXTRA_PATH:+$EXTRA_PATH:}$tree taskset -c "$cores" python3 "$SPLIT" run \
    scenarios/smoke.toml --out "$tmp/run" --force --cache-dir "$tmp/cache" > "$tmp/q.log" 2>&1
  PYTHONPATH=${EXTRA_PATH:+$EXTRA_PATH:}$tree taskset -c "$cores" python3 "$bench" \
    --methods ddr-sfim --calls 20 > "$tmp/m.log" 2>&1
  echo "$label $i: $(grep -o 'compile [0-9.]* s' "$tmp/q.log") $(grep SPLIT "$tmp/q.log")" \
    "$(grep mppi_call_s "$tmp/m.log" | tail -1)"
}
for i in $(seq 0 $((PAIRS - 1))); do
  one "$BASE" before "$((4 * i)),$((4 * i + 1))" "$i" &
  one "$NEW" after "$((4 * i + 2)),$((4 * i + 3))" "$i" &
done
wait
