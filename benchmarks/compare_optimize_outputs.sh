#!/usr/bin/env bash
# Every output file of `tether optimize` from two builds, compared byte for byte: the graph,
# the covariances, the plot (with a ground truth) and the rejected closures (GNC, switchable),
# on simulated graphs with a truth and on public g2o files. One line per run: "same" where
# every file and the exit code agree.
#   usage: benchmarks/compare_optimize_outputs.sh BEFORE_TETHER AFTER_TETHER
set -euo pipefail
before=$(realpath "$1")
after=$(realpath "$2")
data="$(cd "$(dirname "$0")/../../shared/datasets/g2o" 2>/dev/null && pwd || true)"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$after" simulate manhattan --poses 400 --seed 5 -o "$work/m.g2o" --ground-truth "$work/m_truth.g2o" >/dev/null
"$after" simulate landmarks --poses 150 --seed 5 -o "$work/l.g2o" --ground-truth "$work/l_truth.g2o" >/dev/null
"$after" simulate sphere --poses 300 --seed 5 -o "$work/s.g2o" --ground-truth "$work/s_truth.g2o" >/dev/null
# run NAME INPUT ARGS...: both builds write into folders of their own; the files are compared.
run() {
  local name=$1 input=$2
  shift 2
  local codes=""
  for side in before after; do
    local bin=${!side} dir="$work/$side/$name"
    mkdir -p "$dir"
    local args=("$@")
    args=("${args[@]//OUT/$dir}")
    set +e
    (cd "$dir" && "$bin" optimize "$input" -q "${args[@]}" >"$dir/stdout.txt" 2>&1)
    codes+="$? "
    set -e
    rm -f "$dir/stdout.txt"
  done
  local verdict=same
  [ "$(echo $codes | cut -d' ' -f1)" = "$(echo $codes | cut -d' ' -f2)" ] || verdict="DIFFERENT exit codes ($codes)"
  diff -r "$work/before/$name" "$work/after/$name" >/dev/null || verdict="DIFFERENT files"
  echo "| $name | $(ls "$work/after/$name" | tr '\n' ' ')| exit ${codes% } | $verdict |"
}
echo "| run | files | exit codes | |"
echo "|---|---|---|---|"
run manhattan "$work/m.g2o" -o OUT/o.g2o --covariance all --plot OUT/p.svg --ground-truth "$work/m_truth.g2o"
run manhattan-ids "$work/m.g2o" -o OUT/o.g2o --covariance 3,7,99 --covariance-out OUT/c.txt --linear ldlt
run manhattan-gnc "$work/m.g2o" -o OUT/o.g2o --gnc --plot OUT/p.svg
run manhattan-switchable "$work/m.g2o" -o OUT/o.g2o --switchable --rejected-out OUT/r.g2o
run landmarks "$work/l.g2o" -o OUT/o.g2o --covariance all --linear qr --plot OUT/p.svg --ground-truth "$work/l_truth.g2o"
run sphere "$work/s.g2o" -o OUT/o.g2o --covariance 1,2 --plot OUT/p.svg --ground-truth "$work/s_truth.g2o"
run bad-key "$work/m.g2o" -o OUT/o.g2o --covariance 123456
run gauge-key "$work/m.g2o" -o OUT/o.g2o --covariance 0
if [ -n "$data" ]; then
  for f in intel input_M3500_g2o sphere2500 parking-garage; do
    run "$f" "$data/$f.g2o" -o OUT/o.g2o --plot OUT/p.svg --covariance 1,2,3
    run "$f-robust" "$data/$f.g2o" -o OUT/o.g2o --robust loop=huber:1
  done
else
  echo "(../shared/datasets/g2o is absent: the public files were not run)"
fi
