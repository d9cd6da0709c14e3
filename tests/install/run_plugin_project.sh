#!/usr/bin/env bash
# Out-of-tree plugin test: installs the built tree into a temporary prefix and builds the
# project of docs/writing-a-factor-plugin.md (SRC_DIR holds exactly the guide's files) against
# it with find_package(tether), as the guide does. Then, with the INSTALLED program:
#   - check_jacobians must pass (tether/core/jacobian_check.h from the installed tree);
#   - `tether optimize --plugin` must read the guide's graph.g2o, solve it to the ground truth
#     and write the plugin's tags back; `tether plugins list --plugin` must show them;
#   - the installed example plugins must load, odometry_scale.so among them (a variable type
#     VERTEX_SCALE and EDGE_SE2_SCALED), and solve the guide's scale.g2o.
#   usage: run_plugin_project.sh BUILD_DIR SRC_DIR [LINK_FLAGS]
# LINK_FLAGS go into the plugin's link (a sanitised tree needs the sanitiser runtime there).
set -euo pipefail
build_dir=$1
plugin_src=$(cd "$2" && pwd)
link_flags=${3:-}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

cmake --install "$build_dir" --prefix "$work/prefix" > "$work/install.log"
tether="$work/prefix/bin/tether"
test -x "$tether" || fail "the installed program $tether is missing"
test -f "$work/prefix/include/tether/plugins/plugin.h" || fail "plugin.h was not installed"
for example in range_2d position_prior odometry_scale barron_loss; do
  test -f "$work/prefix/lib/tether/plugins/$example.so" || fail "example plugin $example.so was not installed"
done
test -f "$work/prefix/include/tether/core/jacobian_check.h" || fail "jacobian_check.h was not installed"
test -f "$work/prefix/include/tether/core/loss_registry.h" || fail "loss_registry.h was not installed"

cmake -S "$plugin_src" -B "$work/build" -DCMAKE_PREFIX_PATH="$work/prefix" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_MODULE_LINKER_FLAGS="$link_flags" -DCMAKE_SHARED_LINKER_FLAGS="$link_flags" \
  -DCMAKE_EXE_LINKER_FLAGS="$link_flags" > "$work/configure.log" \
  || { cat "$work/configure.log"; fail "configuring the plugin project"; }
cmake --build "$work/build" -j2 > "$work/build.log" || { cat "$work/build.log"; fail "building the plugin project"; }
plugin="$work/build/my_factors.so"
test -f "$plugin" || fail "the plugin project did not produce $plugin"

# The guide's Jacobian check: exit status 0, and one "ok" line per factor type.
"$work/build/check_jacobians" "$plugin" > "$work/jacobians.txt" 2>&1 \
  || { status=$?; cat "$work/jacobians.txt"; fail "check_jacobians exited with status $status"; }
cat "$work/jacobians.txt"
for type in Bearing2D Distance2D; do
  grep -q "^$type .*: ok$" "$work/jacobians.txt" || fail "check_jacobians does not report $type as ok"
done

# The guide's graph: noise-free measurements of eight poses around a 4 m square and three
# landmarks; the solution must be the ground truth (the file has 9 decimals).
cd "$work"
"$tether" optimize --plugin "$plugin" "$plugin_src/graph.g2o" -o "$work/out.g2o" > "$work/optimize.log" 2>&1 \
  || { status=$?; cat "$work/optimize.log"; fail "tether optimize --plugin exited with status $status"; }
grep -q '^EDGE_BEARING_SE2_XY 3 10 1.570796327 400$' "$work/out.g2o" \
  || { cat "$work/out.g2o"; fail "the output does not hold the plugin's bearing edge"; }
grep -q '^EDGE_DISTANCE_SE2 1 5 4 100$' "$work/out.g2o" \
  || { cat "$work/out.g2o"; fail "the output does not hold the plugin's distance edge"; }
cat > "$work/truth.txt" <<'TRUTH'
VERTEX_SE2 0 0 0 0
VERTEX_SE2 1 2 0 0
VERTEX_SE2 2 4 0 1.5707963267948966
VERTEX_SE2 3 4 2 1.5707963267948966
VERTEX_SE2 4 4 4 3.141592653589793
VERTEX_SE2 5 2 4 3.141592653589793
VERTEX_SE2 6 0 4 -1.5707963267948966
VERTEX_SE2 7 0 2 -1.5707963267948966
VERTEX_XY 10 2 2
VERTEX_XY 11 5.5 -1
VERTEX_XY 12 -1 5
TRUTH
# Largest difference from the truth over every coordinate (headings compared modulo 2 pi).
awk 'function wrap(a) { while (a > 3.141592653589793) a -= 6.283185307179586;
                        while (a <= -3.141592653589793) a += 6.283185307179586; return a }
     function abs(a) { return a < 0 ? -a : a }
     FNR == NR { for (i = 3; i <= NF; ++i) t[$1, $2, i] = $i; n[$1, $2] = NF; next }
     ($1, $2) in n { seen++
       for (i = 3; i <= n[$1, $2]; ++i) {
         d = $i - t[$1, $2, i]; if ($1 == "VERTEX_SE2" && i == 5) d = wrap(d)
         if (abs(d) > worst) worst = abs(d) } }
     END { printf "largest difference from the ground truth: %.1e over %d vertices\n", worst, seen
           exit !(seen == 11 && worst < 1e-6) }' "$work/truth.txt" "$work/out.g2o" \
  || { cat "$work/optimize.log" "$work/out.g2o"; fail "the solution is not the ground truth"; }

# Without the plugin the first line with a new tag is refused.
if "$tether" optimize "$plugin_src/graph.g2o" -o "$work/none.g2o" > "$work/none.log" 2>&1; then
  fail "tether optimize without --plugin accepted the plugin's tags"
fi
grep -q "unknown tag 'EDGE_BEARING_SE2_XY'" "$work/none.log" || { cat "$work/none.log"; fail "no unknown-tag error"; }

"$tether" plugins list --plugin "$plugin" > "$work/list.txt" 2>&1 \
  || { status=$?; cat "$work/list.txt"; fail "tether plugins list --plugin exited with status $status"; }
for word in EDGE_BEARING_SE2_XY EDGE_DISTANCE_SE2 'loaded plugin my_factors 0.1.0'; do
  grep -q "$word" "$work/list.txt" || { cat "$work/list.txt"; fail "plugins list does not show '$word'"; }
done
# The installed example plugins load into the installed program too, by bare name from the
# installed plugin folder.
"$tether" plugins list --plugin "$work/prefix/lib/tether/plugins/range_2d.so" \
  --plugin "$work/prefix/lib/tether/plugins/position_prior.so" \
  --plugin "$work/prefix/lib/tether/plugins/odometry_scale.so" > "$work/examples.txt" 2>&1 \
  || { cat "$work/examples.txt"; fail "the installed example plugins do not load"; }
for tag in EDGE_RANGE_SE2_XY EDGE_POSITION_PRIOR_SE2 EDGE_POSITION_PRIOR_SE3 VERTEX_SCALE EDGE_SE2_SCALED; do
  grep -q "$tag" "$work/examples.txt" || { cat "$work/examples.txt"; fail "plugins list does not show $tag"; }
done
# The example robust loss, by bare name, used by name in a rule.
"$tether" optimize --plugin odometry_scale.so --plugin barron_loss.so "$plugin_src/scale.g2o" -q \
  --robust all=barron:1 > "$work/barron.log" 2>&1 \
  || { cat "$work/barron.log"; fail "tether optimize --plugin barron_loss.so --robust all=barron:1 failed"; }
grep -q "1 robust loss" "$work/barron.log" || { cat "$work/barron.log"; fail "barron_loss.so does not load"; }
# The guide's scale graph: odometry 10% long, two position fixes; the scale comes back as 1/1.1.
"$tether" optimize --plugin odometry_scale.so "$plugin_src/scale.g2o" -o "$work/scale_out.g2o" \
  > "$work/scale.log" 2>&1 || { cat "$work/scale.log"; fail "tether optimize --plugin odometry_scale.so failed"; }
awk '$1 == "VERTEX_SCALE" && $2 == 100 { ok = ($3 > 0.9090909 && $3 < 0.9090910) } END { exit !ok }' \
  "$work/scale_out.g2o" || { cat "$work/scale.log" "$work/scale_out.g2o"; fail "the scale is not 1/1.1"; }
echo "out-of-tree plugin: built, Jacobians checked, loaded, solved to the ground truth and written back"
