#!/usr/bin/env bash
# The kidnapped robot in LiDAR SLAM, measured (benchmarks/RESULTS.md): kidnap detection on the
# uncropped shared logs and their scan-only and low-cost versions (no kidnap may be declared),
# and on kidnapped copies of intel, aces and fr079 (30 s cut out, the robot carried; the
# stamps' gap kept or closed; scan-only), then the full runs that merge the kidnapped logs.
# The defaults throughout, apart from what each row names.
#
#   bash benchmarks/lidar_kidnap.sh [build/tools/tether] [OUT_DIR] [detect|merge|all]
#
# detect: every input with --no-loop-closure (detection and relocation are local SLAM's: the
#         loop closures do not change them), one row each: the kidnaps declared, the
#         declarations withdrawn because the scan fitted the current submap near its last pose
#         (relocations), and for a kidnapped log the first scan after its cut.
# merge:  the kidnapped logs with the defaults: where the new trajectory joined the map, and
#         the relation errors of the relations that do not cross the cut against the uncropped
#         log's run on the same relations.
set -euo pipefail
cd "$(dirname "$0")/.."
T=${1:-build/tools/tether}
OUT=${2:-/tmp/lidar_kidnap}
MODE=${3:-all}
D=../shared/datasets/lidar
mkdir -p "$OUT"
declare -A CUT_AT=([intel]=400 [aces]=300 [fr079]=600)

# The kidnapped copies: NAME.clf and NAME.cut (the first scan after the cut, from 1).
make_kidnapped() {
  local log=$1 kind=$2 name="$OUT/$1-$2"
  [ -s "$name.cut" ] && return
  local args=(--kidnap "${CUT_AT[$log]},30")
  case $kind in
    gap) args+=(--kidnap-offset 0.3,-0.2,0.5) ;;
    nogap) args+=(--kidnap-close-gap) ;;
    gap-so) args+=(--kidnap-close-gap --no-odometry) ;;
  esac
  "$T" lidar-degrade "$D/raw/$log.clf.gz" -o "$name.clf" "${args[@]}" > "$name.degrade.log"
  awk '/the first scan after the cut/ { print $4 }' "$name.degrade.log" > "$name.cut"
}

# kidnap.csv: the scans (from 1) where a kidnap was declared (and acted on), and relocated.
declared() { awk '$1 != "#" && $12 == 1 && $13 == 0 { printf "%s%s", sep, $1; sep = "," }' "$1/kidnap.csv"; }
relocated() { awk '$1 != "#" && $13 == 1 { printf "%s%s", sep, $1; sep = "," }' "$1/kidnap.csv"; }

detect_row() {  # name log cut-scan [lidar args...]
  local name=$1 log=$2 cut=$3
  shift 3
  local dir="$OUT/detect-$name"
  mkdir -p "$dir"
  if ! "$T" lidar "$log" -o "$dir" -q --no-loop-closure "$@" > "$dir/run.log" 2>&1; then
    echo "| $name | failed: $(tail -1 "$dir/run.log") |"
    return
  fi
  local d r verdict
  d=$(declared "$dir")
  r=$(relocated "$dir")
  if [ "$cut" = - ]; then
    verdict=$([ -z "$d" ] && echo "no false detection" || echo "**false detection**")
  else
    verdict=$(echo "$d" | tr ',' '\n' | awk -v c="$cut" '$1 >= c && $1 <= c + 3 { hit = 1 } $1 != "" && ($1 < c || $1 > c + 3) { extra++ }
      END { printf "%s", hit ? "detected within 3 scans" : "**missed**"; if (extra) printf ", **%d false**", extra }')
  fi
  echo "| $name | $cut | ${d:--} | ${r:--} | $verdict |"
}

detect() {
  echo "| input | first scan after the cut | kidnaps declared at | lost and found nearby at | verdict |"
  echo "|---|---|---|---|---|"
  for log in intel aces fr079; do
    local raw="$D/raw/$log.clf.gz"
    detect_row "$log" "$raw" -
    detect_row "$log-scan-only" "$raw" - --odometry none
    [ -s "$OUT/$log-lds.log" ] || "$T" lidar-degrade "$raw" -o "$OUT/$log-lds.log" --preset lds --seed 1 > /dev/null
    detect_row "$log-lds" "$OUT/$log-lds.log" -
  done
  detect_row mit-killian "$D/bags/mit-killian.bag" -
  detect_row mit-killian-scan-only "$D/bags/mit-killian.bag" - --odometry none
  for log in intel aces fr079; do
    for kind in gap nogap gap-so; do
      make_kidnapped "$log" "$kind"
      detect_row "$log-$kind" "$OUT/$log-$kind.clf" "$(cat "$OUT/$log-$kind.cut")"
    done
  done
}

# The relations of the uncropped log that lie wholly before or wholly after the cut (stamps
# as in the uncropped log: the gap kept), and each run scored on them.
merge() {
  echo "| log | kidnaps declared at | each new trajectory | relations error, kidnapped / uncropped (m, deg) | ratio | within trajectories: ratio (relations) |"
  echo "|---|---|---|---|---|---|"
  for log in intel aces fr079; do
    local raw="$D/raw/$log.clf.gz" rel="$D/raw/$log.relations"
    local full="$OUT/merge-$log"
    mkdir -p "$full"
    [ -s "$full/trajectory.tum" ] || "$T" lidar "$raw" -o "$full" -q > "$full/run.log" 2>&1
    make_kidnapped "$log" gap
    local dir="$OUT/merge-$log-gap"
    mkdir -p "$dir"
    "$T" lidar "$OUT/$log-gap.clf" -o "$dir" -q > "$dir/run.log" 2>&1 || { echo "| $log-gap | failed |"; continue; }
    # The cut in the log's stamps: CUT_AT s from the first scan's stamp, for 30 s.
    local first cut0 cut1
    first=$(awk '$1 != "#" { print $1; exit }' "$full/trajectory.tum")
    cut0=$(awk -v f="$first" -v a="${CUT_AT[$log]}" 'BEGIN { printf "%.3f", f + a }')
    cut1=$(awk -v f="$first" -v a="${CUT_AT[$log]}" 'BEGIN { printf "%.3f", f + a + 30 }')
    awk -v a="$cut0" -v b="$cut1" '!(($1 < a && $2 > a) || ($1 < b && $2 > b) || ($1 >= a && $1 <= b) || ($2 >= a && $2 <= b))' \
      "$rel" > "$dir/relations"
    # Of those, the ones within one trajectory of the kidnapped run (crossing no declared kidnap,
    # true or false): where trajectories stayed apart, what joined shows here.
    awk 'NR == FNR { if ($1 != "#" && $3 != t) { starts[n++] = $2; t = $3 } next }
      { for (i = 1; i < n; ++i) if (($1 < starts[i]) != ($2 < starts[i])) next; print }' \
      "$dir/trajectory.csv" "$dir/relations" > "$dir/relations-within"
    local k u kw uw joined
    k=$(score "$dir/trajectory.tum" "$dir/relations")
    u=$(score "$full/trajectory.tum" "$dir/relations")
    kw=$(score "$dir/trajectory.tum" "$dir/relations-within")
    uw=$(score "$full/trajectory.tum" "$dir/relations-within")
    joined=$(grep -o 'trajectory [0-9]* starts there; [^:]*' "$dir/run.log" | sed 's/ starts there;/:/' | paste -sd ';' -)
    echo "| $log-gap | $(declared "$dir") | ${joined:--} | $k / $u | $(ratio "$k" "$u") | $(ratio "$kw" "$uw") ($(wc -l < "$dir/relations-within")) |"
  done
}

# Mean translational and rotational relation errors of a trajectory: "m deg".
score() { "$T" lidar-eval "$1" "$2" | awk '/^translational error/ {t = $3} /^rotational error/ {r = $3} END {print t, r}'; }
ratio() { echo "$1 $2" | awk '{ printf "%.2f", $1 / $3 }'; }

case $MODE in
  detect) detect ;;
  merge) merge ;;
  all) detect; merge ;;
  *) echo "mode: detect, merge or all" >&2; exit 2 ;;
esac
