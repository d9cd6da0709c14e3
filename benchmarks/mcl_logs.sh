#!/bin/bash
# Monte Carlo localisation on the benchmark logs, in maps tether's own mapping made.
#
#   bash benchmarks/mcl_logs.sh TETHER OUT [LOG...]      (default logs: intel aces fr079)
#
# Per log: `tether lidar` maps it (fr079 without odometry: with it, its mapping run jumps
# 3.7 m at the door at 309 s, and that run is the reference; see RESULTS.md), then
# - tracking: `tether mcl` over the whole log from the mapping run's first pose, with
#   $TRACK_PARTICLES particles (default 500), against the mapping run's trajectory;
# - global localisation: 20 start times drawn with a fixed seed, each a uniform start over the
#   free space with $GLOBAL_PARTICLES particles (default 10000) for $GLOBAL_SCANS scans
#   (default 600, about two minutes of these logs); converged where the estimate is within
#   0.5 m and 10 degrees of the mapping run's pose from some scan to the end, and the time
#   from the start to that scan.
# Extra `tether mcl` options for every run: $MCL_ARGS. Needs ../shared/datasets (or
# TETHER_DATASETS_DIR).
set -euo pipefail
TETHER=${1:?usage: mcl_logs.sh TETHER OUT [LOG...]}
OUT=${2:?usage: mcl_logs.sh TETHER OUT [LOG...]}
shift 2
LOGS=${*:-intel aces fr079}
DATA=${TETHER_DATASETS_DIR:-$(dirname "$0")/../../shared/datasets}
TRACK_PARTICLES=${TRACK_PARTICLES:-500}
GLOBAL_PARTICLES=${GLOBAL_PARTICLES:-10000}
GLOBAL_SCANS=${GLOBAL_SCANS:-600}
MCL_ARGS=${MCL_ARGS:-}
mkdir -p "$OUT"
for log in $LOGS; do
  clf="$DATA/lidar/raw/$log.clf.gz"
  [ -f "$clf" ] || { echo "skip $log: $clf not found"; continue; }
  map="$OUT/map-$log"
  if [ ! -f "$map/map.yaml" ]; then
    odometry=""
    [ "$log" = fr079 ] && odometry="--odometry none"
    "$TETHER" lidar "$clf" -o "$map" -q $odometry > "$OUT/map-$log.txt"
  fi
  first=$(awk '!/^#/{print; exit}' "$map/trajectory.tum")
  pose=$(echo "$first" | awk '{printf "%s,%s,%.9f", $2, $3, 2*atan2($7, $8)}')
  echo "== $log: tracking, $TRACK_PARTICLES particles"
  "$TETHER" mcl "$clf" --map "$map/map.yaml" -o "$OUT/track-$log" -q --initial-pose="$pose" \
    --particles "$TRACK_PARTICLES" --reference "$map/trajectory.tum" $MCL_ARGS | grep -E "time:|against|converged|injected"
  span=$(grep -v '^#' "$map/trajectory.tum" | awk 'NR==1{a=$1} {b=$1} END{print b-a}')
  converged=0
  times=""
  for k in $(seq 1 20); do
    start=$(awk -v s="$span" -v k="$k" 'BEGIN{srand(1000 + k); print int(rand() * (s - 150))}')
    line=$("$TETHER" mcl "$clf" --map "$map/map.yaml" -o "$OUT/global-$log" -q --start-time "$start" \
      --max-scans "$GLOBAL_SCANS" --particles "$GLOBAL_PARTICLES" --reference "$map/trajectory.tum" $MCL_ARGS |
      grep -E "^converged|^not converged")
    if [[ $line == converged* ]]; then
      converged=$((converged + 1))
      t=$(echo "$line" | sed -E 's/.*, ([0-9.]+) s into the run.*/\1/')
      times="$times $t"
      echo "  start ${start} s: converged after $t s"
    else
      echo "  start ${start} s: not converged"
    fi
  done
  echo "== $log: global localisation converged on $converged of 20 starts; seconds to converge:$times"
done
