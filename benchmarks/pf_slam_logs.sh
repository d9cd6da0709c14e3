#!/bin/bash
# Grid-based particle filter SLAM (`tether pf-slam`) on the benchmark logs, scored with the
# relations metric.
#
#   bash benchmarks/pf_slam_logs.sh TETHER OUT [LOG...]      (default logs: intel aces fr079)
#
# Per log: `tether pf-slam` with $PF_ARGS (default: none, the defaults: 30 particles), its wall
# time and peak memory (/usr/bin/time), then `tether lidar-eval` of its trajectory against the
# log's relations. Needs ../shared/datasets (or TETHER_DATASETS_DIR).
set -euo pipefail
TETHER=${1:?usage: pf_slam_logs.sh TETHER OUT [LOG...]}
OUT=${2:?usage: pf_slam_logs.sh TETHER OUT [LOG...]}
shift 2
LOGS=${*:-intel aces fr079}
DATA=${TETHER_DATASETS_DIR:-$(dirname "$0")/../../shared/datasets}
PF_ARGS=${PF_ARGS:-}
mkdir -p "$OUT"
for log in $LOGS; do
  clf="$DATA/lidar/raw/$log.clf.gz"
  [ -f "$clf" ] || { echo "skip $log: $clf not found"; continue; }
  # shellcheck disable=SC2086
  /usr/bin/time -f "$log: %e s wall, %M KB peak" "$TETHER" pf-slam "$clf" -o "$OUT/$log" -q $PF_ARGS \
    > "$OUT/$log.txt" 2>&1
  "$TETHER" lidar-eval "$OUT/$log/trajectory.tum" "$DATA/lidar/raw/$log.relations" >> "$OUT/$log.txt"
  grep -E "wall|processed|distinct tiles|real time|translational error|rotational error|more than 1 m" "$OUT/$log.txt"
done
