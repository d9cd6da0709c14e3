#!/usr/bin/env bash
# scripts/check_layers.sh on small trees made here: one whose includes all point down the layers
# passes, silent; each kind of violation added to it alone fails the check, which names the file,
# the line and the rule. usage: check_layers_test.sh PATH_TO_check_layers.sh
set -uo pipefail
check=$1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
failures=0

fail() {
  echo "FAIL: $*"
  failures=$((failures + 1))
}

# A tree with every kind of include the rule allows: public headers of lower modules, a
# module's own private headers, the solvers' umbrella from above it, the tools' headers from
# the benchmarks, and tests that include anything.
clean_tree() {
  local d=$1
  mkdir -p "$d"/core/include/tether/core "$d"/core/src "$d"/factors/include/tether/factors \
    "$d"/plugins/include/tether/plugins "$d"/solvers/include/tether/solvers "$d"/solvers/src \
    "$d"/solvers/ceres "$d"/frontends/include/tether/frontends/lidar "$d"/frontends/src/lidar \
    "$d"/tools/include/tether "$d"/tools/src "$d"/benchmarks/micro "$d"/tests/core
  echo '#pragma once' >"$d"/core/include/tether/core/values.h
  printf '#include "tether/core/values.h"\n' >"$d"/core/src/values.cc
  printf '#pragma once\n#include "tether/core/values.h"\n' >"$d"/factors/include/tether/factors/prior.h
  printf '#pragma once\n#include <tether/core/values.h>\n' >"$d"/plugins/include/tether/plugins/plugin.h
  printf '#pragma once\n#include "tether/factors/prior.h"\n#include "tether/plugins/plugin.h"\n' \
    >"$d"/solvers/include/tether/solvers/optimizer.h
  printf '#pragma once\n#include "tether/solvers/optimizer.h"\n' >"$d"/solvers/include/tether/tether.h
  echo '#pragma once' >"$d"/solvers/src/problem.h
  printf '#include "problem.h"\n#include "tether/solvers/optimizer.h"\n' >"$d"/solvers/src/optimizer.cc
  printf '#include "../src/problem.h"\n' >"$d"/solvers/ceres/ceres_adapter.cc
  printf '#pragma once\n#include "tether/tether.h"\n' >"$d"/frontends/include/tether/frontends/lidar/scan.h
  echo '#pragma once' >"$d"/frontends/src/lidar/number_lines.h
  printf '#include "number_lines.h"\n#include "tether/frontends/lidar/scan.h"\n' >"$d"/frontends/src/lidar/scan.cc
  printf '#pragma once\n#include "tether/frontends/lidar/scan.h"\n' >"$d"/tools/include/tether/bench.h
  printf '#include "tether/bench.h"\n' >"$d"/tools/src/bench.cc
  printf '#include "tether/bench.h"\n#include "tether/solvers/optimizer.h"\n' >"$d"/benchmarks/micro/bench.cc
  printf '#include "problem.h"\n#include "tether/bench.h"\n#include "../../solvers/src/problem.h"\n' \
    >"$d"/tests/core/values_test.cc
}

clean_tree "$work/clean"
out=$(bash "$check" "$work/clean" 2>&1)
code=$?
[ "$code" -eq 0 ] || fail "the clean tree: exit $code, expected 0; output:"$'\n'"$out"
[ -z "$out" ] || fail "the clean tree printed:"$'\n'"$out"

# expect NAME FILE LINE_TEXT EXPECTED: appends LINE_TEXT to FILE of a fresh clean tree and
# expects the check to fail with one line naming FILE, the line number and EXPECTED.
expect() {
  local name=$1 file=$2 text=$3 want=$4 d="$work/$1" out code line
  clean_tree "$d"
  mkdir -p "$(dirname "$d/$file")"
  echo "$text" >>"$d/$file"
  line=$(wc -l <"$d/$file")
  out=$(bash "$check" "$d" 2>&1)
  code=$?
  if [ "$code" -ne 1 ]; then
    fail "$name: exit $code, expected 1; output:"$'\n'"$out"
  elif [ "$(printf '%s\n' "$out" | wc -l)" -ne 1 ]; then
    fail "$name: expected one line, got:"$'\n'"$out"
  elif [[ $out != "$file:$line: "*"$want"* ]]; then
    fail "$name: expected \"$file:$line: ...$want...\", got:"$'\n'"$out"
  else
    echo "ok: $name: $out"
  fi
}

expect core_includes_solvers core/src/values.cc '#include "tether/solvers/optimizer.h"' \
  'core includes tether/solvers/optimizer.h, a header of solvers, which is a level above it'
expect factors_includes_plugins factors/include/tether/factors/prior.h '#include "tether/plugins/plugin.h"' \
  'factors includes tether/plugins/plugin.h, a header of plugins, which is on its level'
expect solvers_includes_frontends_spaced solvers/src/optimizer.cc '  #  include <tether/frontends/lidar/scan.h>' \
  'solvers includes tether/frontends/lidar/scan.h, a header of frontends, which is a level above it'
expect core_includes_umbrella core/src/values.cc '#include "tether/tether.h"' \
  'core includes tether/tether.h, a header of solvers, which is a level above it'
expect frontends_includes_tools frontends/src/lidar/scan.cc '#include "tether/bench.h"' \
  'frontends includes tether/bench.h, a header of tools, which is a level above it'
expect benchmarks_includes_private benchmarks/micro/bench.cc '#include "problem.h"' \
  'benchmarks includes "problem.h", the private header solvers/src/problem.h of solvers'
expect frontends_includes_private_by_path frontends/src/lidar/scan.cc '#include "../../../solvers/src/problem.h"' \
  'the private header solvers/src/problem.h of solvers'

out=$(bash "$check" "$work/no_such_tree" 2>&1)
code=$?
[ "$code" -eq 2 ] || fail "a folder that is not a source tree: exit $code, expected 2; output:"$'\n'"$out"

if [ "$failures" -ne 0 ]; then
  echo "$failures check(s) failed"
  exit 1
fi
echo "every check passed"
