#!/usr/bin/env bash
# The plugin guide prints its project's files in full and quotes the odometry_scale example:
# each fenced block after a "<!-- file: PATH -->" line must equal the file PATH (relative to
# the source tree), and each block after "<!-- excerpt: PATH -->" must occur in PATH, word for
# word. Every file of tests/install/plugin_project must be printed.
#   usage: check_plugin_guide.sh SOURCE_DIR
set -euo pipefail
src=$1
guide="$src/docs/writing-a-factor-plugin.md"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# Splits the guide into work/N.kind (kind: file or excerpt) holding the block, and work/N.path.
awk -v dir="$work" '
  /^<!-- (file|excerpt): .* -->$/ { n++; kind = $2; sub(":", "", kind); path = $3
                                    print path > (dir "/" n ".path"); want = 1; next }
  want && /^```/ { want = 0; inside = 1; out = dir "/" n "." kind; printf "" > out; next }
  inside && /^```$/ { inside = 0; next }
  inside { print > out }' "$guide"
status=0
checked=0
for p in "$work"/*.path; do
  [ -e "$p" ] || break
  n=${p%.path}
  path=$(cat "$p")
  if [ -f "$n.file" ]; then
    diff -u "$src/$path" "$n.file" > "$work/diff" || { echo "FAIL: the guide's $path differs from the file:"; cat "$work/diff"; status=1; }
  else
    python3 - "$src/$path" "$n.excerpt" <<'PY' || { echo "FAIL: the guide's excerpt of $path is not in the file"; status=1; }
import sys
sys.exit(0 if open(sys.argv[2]).read() in open(sys.argv[1]).read() else 1)
PY
  fi
  checked=$((checked + 1))
done
for f in "$src"/tests/install/plugin_project/*; do
  grep -qx "<!-- file: tests/install/plugin_project/$(basename "$f") -->" "$guide" \
    || { echo "FAIL: the guide does not print $(basename "$f")"; status=1; }
done
[ "$checked" -ge 5 ] || { echo "FAIL: only $checked marked blocks found in $guide"; status=1; }
[ "$status" -eq 0 ] && echo "the guide prints $checked blocks, each word for word as in the source tree"
exit $status
