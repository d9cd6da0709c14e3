#!/usr/bin/env bash
# Consistency of the landmark filters: the invariant EKF's average NEES over 50 worlds (seeds
# 1000..1049, known association) for each min_range and number of correction iterations, with
# the EKF and the UKF beside it, at both experiments' noise. Filters only (--no-graph); about
# 5 minutes on 2 cores. Prints one Markdown table.
# Usage: benchmarks/ekf_consistency.sh [BUILD_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
tether=$build/tools/tether
[ -x "$tether" ] || { echo "build $tether first (cmake --build $build --target tether_cli)" >&2; exit 1; }
echo "| experiment | method | min_range [m] | iterations | average NEES, mean over steps | steps inside the 95% interval | trajectory RMSE [m] |"
echo "|---|---|---|---|---|---|---|"
first=1
for r in 0 2 3 4 6; do
  for i in 1 2 5; do
    out=$("$tether" ekf-demo --seeds 50 --first-seed 1000 --association known --no-graph --nees -q \
      --invariant-min-range "$r" --invariant-iterations "$i")
    for e in 1 2; do
      # The filter table: | exp | assoc | method | trajectory RMSE | ...; the NEES table: | exp |
      # assoc | method | runs | mean | inside | ...
      echo "$out" | awk -F'|' -v e="$e" -v r="$r" -v i="$i" -v first="$first" '
        /average NEES/ { nees = 1 }
        { gsub(/^ +| +$/, "", $2); gsub(/^ +| +$/, "", $4) }
        !nees && $2 == e && ($4 == "invariant EKF" || (first && ($4 == "EKF" || $4 == "UKF"))) {
          split($5, rmse, " "); key = $4; rm[key] = rmse[1]
        }
        nees && $2 == e && ($4 == "invariant EKF" || (first && ($4 == "EKF" || $4 == "UKF"))) {
          gsub(/^ +| +$/, "", $6); gsub(/^ +| +$/, "", $7)
          mr = ($4 == "invariant EKF") ? r : "0"; it = ($4 == "invariant EKF") ? i : "-"
          printf "| %s | %s | %s | %s | %s | %s | %s |\n", e, $4, mr, it, $6, $7, rm[$4]
        }'
    done
    first=0
  done
done
