#!/usr/bin/env bash
# Runs `tether optimize` on every file in ../shared/datasets/g2o with Gauss-Newton and
# Levenberg-Marquardt over CHOLMOD, 5 times each, and prints a Markdown table with the
# median wall time of the whole process (read, initialise, solve, write).
# Usage: benchmarks/run_datasets.sh [BUILD_DIR] [REPEATS] [INIT]
#   INIT: file | spanning-tree | chordal (default: the program's default, chordal). `file`
#   starts from the file's vertices (files with edges only: the spanning-tree composition),
#   the start g2o's own optimiser uses.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
repeats=${2:-5}
init=${3:-}
init_args=()
[ -z "$init" ] || init_args=(--init "$init")
data=../shared/datasets/g2o
tether=$build/tools/tether
[ -x "$tether" ] || { echo "build $tether first (cmake --build $build --target tether_cli)" >&2; exit 1; }
[ -d "$data" ] || { echo "no $data: the datasets folder is not beside the repository" >&2; exit 1; }
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
echo "| file | solver | poses | edges | initial chi2 | final chi2 | iterations | status | median wall time [s] ($repeats runs) |"
echo "|---|---|---|---|---|---|---|---|---|"
for f in intel MIT CSAIL manhattan ais2klinik kitti_00 input_M3500_g2o sphere2500 parking-garage smallGrid3D tinyGrid3D; do
  for s in gn lm; do
    times=()
    for ((k = 0; k < repeats; ++k)); do
      t0=$(date +%s.%N)
      "$tether" optimize "$data/$f.g2o" --solver "$s" --linear cholmod "${init_args[@]}" -q -o "$out/o.g2o" > "$out/log" 2>&1 || true
      t1=$(date +%s.%N)
      times+=("$(awk -v a="$t0" -v b="$t1" 'BEGIN {printf "%.4f", b - a}')")
    done
    median=$(printf '%s\n' "${times[@]}" | sort -g | awk '{a[NR]=$1} END {printf "%.3f", a[int((NR+1)/2)]}')
    poses=$(sed -n 's/^read .*: \([0-9]*\) poses.*/\1/p' "$out/log")
    edges=$(sed -n 's/^read .* \([0-9]*\) factors.*/\1/p' "$out/log")
    init=$(awk '/initial chi2/ {print $3}' "$out/log")
    final=$(awk '/final chi2/ {print $3}' "$out/log")
    iters=$(awk '/^  iterations/ {print $2}' "$out/log")
    status=$(awk '/^  status/ {print $2}' "$out/log" | tr -d ':')
    echo "| $f | $s | $poses | $edges | $init | $final | $iters | $status | $median |"
  done
done
