#!/usr/bin/env bash
# Out-of-tree plugin test: installs the built tree into a temporary prefix, builds the plugin
# project in SRC_DIR against it with find_package(tether), and has the INSTALLED program load
# the plugin: `tether optimize --plugin` must read the plugin's tag, solve, and write it back;
# `tether plugins list --plugin` must show it.
#   usage: run_plugin_project.sh BUILD_DIR SRC_DIR [LINK_FLAGS]
# LINK_FLAGS go into the plugin's link (a sanitised tree needs the sanitiser runtime there).
set -euo pipefail
build_dir=$1
plugin_src=$2
link_flags=${3:-}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

cmake --install "$build_dir" --prefix "$work/prefix" > "$work/install.log"
tether="$work/prefix/bin/tether"
test -x "$tether" || fail "the installed program $tether is missing"
test -f "$work/prefix/include/tether/plugins/plugin.h" || fail "plugin.h was not installed"
for example in range_2d position_prior; do
  test -f "$work/prefix/lib/tether/plugins/$example.so" || fail "example plugin $example.so was not installed"
done

cmake -S "$plugin_src" -B "$work/build" -DCMAKE_PREFIX_PATH="$work/prefix" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_MODULE_LINKER_FLAGS="$link_flags" -DCMAKE_SHARED_LINKER_FLAGS="$link_flags" > "$work/configure.log" \
  || { cat "$work/configure.log"; fail "configuring the plugin project"; }
cmake --build "$work/build" -j2 > "$work/build.log" || { cat "$work/build.log"; fail "building the plugin project"; }
plugin="$work/build/heading_prior.so"
test -f "$plugin" || fail "the plugin project did not produce $plugin"

# Four poses in a row; pose 0 is fixed at heading 0, the relative headings are measured 0
# (information 1), and a strong heading prior (information 1e4) puts pose 3 at 0.3 rad. The
# translations are free to follow, so the solution turns evenly: 0.1, 0.2, 0.3 rad.
cat > "$work/in.g2o" <<'G2O'
VERTEX_SE2 0 0 0 0
VERTEX_SE2 1 1 0 0
VERTEX_SE2 2 2 0 0
VERTEX_SE2 3 3 0 0
FIX 0
EDGE_SE2 0 1 1 0 0 100 0 0 100 0 1
EDGE_SE2 1 2 1 0 0 100 0 0 100 0 1
EDGE_SE2 2 3 1 0 0 100 0 0 100 0 1
EDGE_HEADING_PRIOR_SE2 3 0.3 10000
G2O
"$tether" optimize --plugin "$plugin" "$work/in.g2o" -o "$work/out.g2o" > "$work/optimize.log" 2>&1 \
  || { status=$?; cat "$work/optimize.log"; fail "tether optimize --plugin exited with status $status"; }
grep -q '^EDGE_HEADING_PRIOR_SE2 3 0.3 10000$' "$work/out.g2o" \
  || { cat "$work/out.g2o"; fail "the output does not hold the plugin's edge"; }
awk '$1 == "VERTEX_SE2" && $2 == 3 { ok = ($5 > 0.299 && $5 < 0.301) } END { exit !ok }' "$work/out.g2o" \
  || { cat "$work/optimize.log" "$work/out.g2o"; fail "pose 3 did not turn to the prior's heading 0.3"; }
awk '$1 == "VERTEX_SE2" && $2 == 1 { ok = ($5 > 0.099 && $5 < 0.101) } END { exit !ok }' "$work/out.g2o" \
  || { cat "$work/optimize.log" "$work/out.g2o"; fail "pose 1 is not at heading 0.1"; }

"$tether" plugins list --plugin "$plugin" > "$work/list.txt" 2>&1 \
  || { status=$?; cat "$work/list.txt"; fail "tether plugins list --plugin exited with status $status"; }
grep -q 'EDGE_HEADING_PRIOR_SE2' "$work/list.txt" || { cat "$work/list.txt"; fail "plugins list does not show the tag"; }
grep -q 'heading_prior' "$work/list.txt" || { cat "$work/list.txt"; fail "plugins list does not show the plugin"; }
# The installed example plugins load into the installed program too.
"$tether" plugins list --plugin "$work/prefix/lib/tether/plugins/range_2d.so" \
  --plugin "$work/prefix/lib/tether/plugins/position_prior.so" > "$work/examples.txt" 2>&1 \
  || { cat "$work/examples.txt"; fail "the installed example plugins do not load"; }
for tag in EDGE_RANGE_SE2_XY EDGE_POSITION_PRIOR_SE2 EDGE_POSITION_PRIOR_SE3; do
  grep -q "$tag" "$work/examples.txt" || { cat "$work/examples.txt"; fail "plugins list does not show $tag"; }
done
echo "out-of-tree plugin: built, loaded, solved and written back"
