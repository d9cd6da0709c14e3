#!/usr/bin/env bash
# LiDAR SLAM on logs it was not tuned on: each benchmark log as it is, without its odometry, and
# degraded to a low-cost scanner (360 beams over the log's field of view, 6 m, 2 cm noise, 5%
# dropped returns, every other scan), with and without odometry; then mit-killian. The defaults
# throughout: no option of `tether lidar` is set. Prints one row per run (relations error, the
# relations off by more than 1 m, closures kept by the solution, the self-check, real time).
#
#   bash benchmarks/lidar_any_log.sh [build/tools/tether] [OUT_DIR] [LOGS...]
# LOGS: intel aces fr079 (default) and/or mit-killian.
set -euo pipefail
cd "$(dirname "$0")/.."
T=${1:-build/tools/tether}
OUT=${2:-/tmp/lidar_any_log}
shift 2 2>/dev/null || true
LOGS=("$@")
[ ${#LOGS[@]} -gt 0 ] || LOGS=(intel aces fr079)
D=../shared/datasets/lidar
mkdir -p "$OUT"

# Prints: case | translational error | rotational error | > 1 m | kept | self-check | real time
row() {
  local name=$1 dir=$2 relations=$3 logged=$4
  local eval="" kept fit rt
  if [ -n "$relations" ]; then
    eval=$("$T" lidar-eval "$dir/trajectory.tum" "$relations")
  fi
  kept=$(grep -o 'kept by the solution [^ ]*' "$dir/run.log" | awk '{print $5}')
  fit=$(grep -o '[0-9.]*% of them fit it; [^(]*' "$dir/run.log" | sed 's/ of them fit it;/ fit,/')
  local total
  total=$(grep -o '^time [0-9.]*' "$dir/run.log" | awk '{print $2}')
  rt=$(awk -v l="$logged" -v t="$total" 'BEGIN { printf "%.1fx", l / t }')
  if [ -n "$eval" ]; then
    local te re far
    te=$(echo "$eval" | awk '/^translational error/ {print $3 " m (max " $8}' | tr -d ')')
    re=$(echo "$eval" | awk '/^rotational error/ {print $3 " deg"}')
    far=$(echo "$eval" | awk '/more than 1 m/ {print $NF}')
    echo "| $name | $te) | $re | $far | $kept | $fit | $rt |"
  else
    echo "| $name | - | - | - | $kept | $fit | $rt |"
  fi
}

run() {  # name log relations logged-seconds [extra lidar args...]
  local name=$1 log=$2 relations=$3 logged=$4
  shift 4
  mkdir -p "$OUT/$name"
  "$T" lidar "$log" -o "$OUT/$name" -q "$@" > "$OUT/$name/run.log" 2>&1 || { echo "| $name | failed: $(tail -1 "$OUT/$name/run.log") |"; return; }
  row "$name" "$OUT/$name" "$relations" "$logged"
}

echo "| case | translational error | rotational error | relations > 1 m | closures kept | self-check | real time |"
echo "|---|---|---|---|---|---|---|"
for log in "${LOGS[@]}"; do
  if [ "$log" = mit-killian ]; then
    # Uniform stamps: real time is counted against the log's true 7678 s.
    run mit-killian "$D/bags/mit-killian.bag" "" 7678
    continue
  fi
  raw="$D/raw/$log.clf.gz"
  rel="$D/raw/$log.relations"
  span=$(zcat "$raw" | awk '$1 == "FLASER" { t = $(NF - 2); if (first == "") first = t; last = t } END { printf "%.1f", last - first }')
  run "$log" "$raw" "$rel" "$span"
  run "$log-scan-only" "$raw" "$rel" "$span" --odometry none
  "$T" lidar-degrade "$raw" -o "$OUT/$log-lds.log" --preset lds --seed 1 > /dev/null
  run "$log-lds" "$OUT/$log-lds.log" "$rel" "$span"
  run "$log-lds-scan-only" "$OUT/$log-lds.log" "$rel" "$span" --odometry none
done
