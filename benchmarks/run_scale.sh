#!/usr/bin/env bash
# Scale: simulates Manhattan worlds of N poses (default 125k, 250k, 500k, 1M), optimises each
# once with the default settings (chordal start, LM over CHOLMOD) and prints a Markdown table
# with the whole process's wall time, its peak resident memory (GNU time) and the memory per
# pose, plus the solver's own split. Needs ~6 GB of memory and ~5 minutes for 1M poses.
# Usage: benchmarks/run_scale.sh [BUILD_DIR] [N ...]
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
shift || true
sizes=("$@")
[ ${#sizes[@]} -gt 0 ] || sizes=(125000 250000 500000 1000000)
tether=$build/tools/tether
[ -x "$tether" ] || { echo "build $tether first (cmake --build $build --target tether_cli)" >&2; exit 1; }
[ -x /usr/bin/time ] || { echo "needs GNU time: apt-get install -y time" >&2; exit 1; }
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
echo "| poses | factors | initial chi2 | final chi2 | iterations | status | init [s] | solve [s] | whole process [s] | peak memory [MB] | memory per pose [KB] |"
echo "|---|---|---|---|---|---|---|---|---|---|---|"
for n in "${sizes[@]}"; do
  "$tether" simulate manhattan --poses "$n" --seed 1 -o "$out/m.g2o" > /dev/null
  /usr/bin/time -f "%e %M" -o "$out/time" "$tether" optimize "$out/m.g2o" -q -o "$out/o.g2o" > "$out/log" 2>&1 || true
  read -r wall rss_kb < "$out/time"
  factors=$(sed -n 's/^read .* \([0-9]*\) factors.*/\1/p' "$out/log")
  init=$(sed -n "s/^initialisation .*, \([0-9.]*\) s$/\1/p" "$out/log")
  solve=$(awk '/^  time/ {print $2}' "$out/log")
  ichi=$(awk '/initial chi2/ {print $3}' "$out/log")
  fchi=$(awk '/final chi2/ {print $3}' "$out/log")
  iters=$(awk '/^  iterations/ {print $2}' "$out/log")
  status=$(awk '/^  status/ {print $2}' "$out/log" | tr -d ':')
  awk -v n="$n" -v f="$factors" -v i="$ichi" -v c="$fchi" -v it="$iters" -v st="$status" -v ini="$init" \
      -v so="$solve" -v w="$wall" -v r="$rss_kb" \
      'BEGIN {printf "| %d | %d | %s | %s | %s | %s | %s | %s | %s | %.0f | %.2f |\n", n, f, i, c, it, st, ini, so, w, r / 1024, r / n}'
  rm -f "$out/m.g2o" "$out/o.g2o"
done
