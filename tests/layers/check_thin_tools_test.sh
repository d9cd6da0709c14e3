#!/usr/bin/env bash
# The thin command line (docs/architecture.md): no function in tools/ longer than 80 lines and
# tools/main.cc at most 150 lines. The function-length checker itself must report a function
# of 81 lines and pass one of 80, so the rule cannot pass by the checker missing them.
# Usage: check_thin_tools_test.sh SOURCE_DIR
set -euo pipefail
src=$1
checker="$src/scripts/check_function_length.py"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# A function at the left margin with n lines in all (signature and closing brace included).
make_function() {
  local n=$1 file=$2
  {
    echo "int Long(int a, int b) {"
    for ((i = 0; i < n - 3; ++i)); do echo "  a += b;"; done
    echo "  return a;"
    echo "}"
  } > "$file"
}
make_function 81 "$work/long.cc"
make_function 80 "$work/ok.cc"
if python3 "$checker" --max-lines 80 "$work/long.cc" > "$work/out.txt" 2>&1; then
  cat "$work/out.txt"
  echo "FAIL: the checker passed a function of 81 lines"
  exit 1
fi
grep -q "long.cc:1: 81 lines" "$work/out.txt" || { cat "$work/out.txt"; echo "FAIL: the report does not name the function"; exit 1; }
python3 "$checker" --max-lines 80 "$work/ok.cc" > /dev/null || { echo "FAIL: the checker refused 80 lines"; exit 1; }

python3 "$checker" --max-lines 80 "$src/tools"
lines=$(wc -l < "$src/tools/main.cc")
if [ "$lines" -gt 150 ]; then
  echo "FAIL: tools/main.cc has $lines lines (at most 150: it is only the table of commands)"
  exit 1
fi
echo "tools/main.cc: $lines lines"
