#!/usr/bin/env bash
# Final chi2 and iterations of two tether builds on every public g2o file, for GN and LM from
# the default (chordal) start and LM from the file's start: a table, and "same" where the two
# builds print the same summary numbers to the digit.
#   usage: benchmarks/compare_results.sh BEFORE_TETHER AFTER_TETHER
set -euo pipefail
before=$1
after=$2
data="$(cd "$(dirname "$0")/../../shared/datasets/g2o" && pwd)"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
summary() {  # binary file extra-args...
  local bin=$1 file=$2
  shift 2
  "$bin" optimize "$data/$file.g2o" -q -o "$out/o.g2o" "$@" 2>&1 |
    awk '/final chi2/ {c = $3} /^  iterations/ {i = $2} END {print c, i}'
}
echo "| file | run | before: final chi2, iterations | after: final chi2, iterations | |"
echo "|---|---|---|---|---|"
for f in intel MIT CSAIL manhattan ais2klinik kitti_00 input_M3500_g2o sphere2500 parking-garage smallGrid3D tinyGrid3D; do
  for run in "gn" "lm" "lm --init file"; do
    read -r -a args <<< "--solver $run"
    b=$(summary "$before" "$f" "${args[@]}")
    a=$(summary "$after" "$f" "${args[@]}")
    same=$([ "$a" = "$b" ] && echo same || echo DIFFERENT)
    echo "| $f | $run | $b | $a | $same |"
  done
done
