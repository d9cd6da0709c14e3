#!/usr/bin/env bash
# Checks that the includes between tether's modules point down the layers of DESIGN.md:
#
#   core  <  factors, plugins  <  solvers  <  frontends  <  tools, python_bindings  <  benchmarks
#
# A module's sources and headers may include its own headers and the public headers of the
# modules below it. Reported, one line each (file:line: what and why):
#   - an include of tether/<module>/... where <module> is on the same level or above (two
#     modules on one level do not include each other);
#   - an include of a header directly under tether/ (the umbrella tether/tether.h of
#     tether::solvers, the tools' tether/bench.h, ...) whose module is on the same level or above;
#   - a quoted include that is another module's private header (its src/ or any folder but
#     include/): a module uses another through its public headers only, whatever the level.
# tests/, examples/ and docs/ may include anything and are not read. Nothing is compiled: the
# include lines are read as written (an include in a block comment counts too).
#
# usage: scripts/check_layers.sh [ROOT]    ROOT: a tether source tree (default: this one)
# Exit status: 0 when nothing is found, 1 when something is (listed on stdout), 2 when ROOT
# is not a source tree.
set -uo pipefail

root=${1:-"$(dirname "$0")/.."}
if ! cd "$root" 2>/dev/null || [ ! -d core ]; then
  echo "check_layers: $root is not a tether source tree (no core/ folder)" >&2
  exit 2
fi

modules=(core factors plugins solvers frontends tools python_bindings benchmarks)

# The level of a module, or nothing for a folder that is not one.
level() {
  case $1 in
    core) echo 0 ;;
    factors | plugins) echo 1 ;;
    solvers) echo 2 ;;
    frontends) echo 3 ;;
    tools | python_bindings) echo 4 ;;
    benchmarks) echo 5 ;;
  esac
}

# The module whose public include folder holds tether/<name> (a header directly under tether/).
top_level_owner() {
  local m
  for m in "${modules[@]}"; do
    if [ -f "$m/include/tether/$1" ]; then
      echo "$m"
      return
    fi
  done
}

# The private header (path from the root) that quoted include $2 of a file in folder $1 of
# module $3 reaches in another module, or nothing. A path that resolves from the including
# file's folder counts where it lands; one that does not is looked for in the other modules'
# folders (the compiler finds such a file only through an include path into them).
private_target() {
  local dir=$1 inc=$2 mod=$3 path m found
  if [ -f "$dir/$inc" ]; then
    path=$(realpath -m --relative-to=. "$dir/$inc")
    m=${path%%/*}
    if [ "$m" != "$mod" ] && [ -n "$(level "$m")" ] && [[ $path != "$m"/include/* ]]; then echo "$path"; fi
    return
  fi
  # Within its own module (an include path of its own): not another module's.
  if [ -n "$(find "$mod" -path "*/$inc" -print -quit 2>/dev/null)" ]; then return; fi
  for m in "${modules[@]}"; do
    if [ "$m" = "$mod" ] || [ ! -d "$m" ]; then continue; fi
    found=$(find "$m" -path "*/$inc" -not -path "$m/include/*" -print -quit 2>/dev/null)
    if [ -n "$found" ]; then
      echo "$found"
      return
    fi
  done
}

include_re='^[[:space:]]*#[[:space:]]*include[[:space:]]*([<"])([^>"]+)[>"]'
found_any=0
report() {
  echo "$1"
  found_any=1
}

for mod in "${modules[@]}"; do
  [ -d "$mod" ] || continue
  r=$(level "$mod")
  while IFS= read -r hit; do
    file=${hit%%:*}
    rest=${hit#*:}
    line=${rest%%:*}
    text=${rest#*:}
    [[ $text =~ $include_re ]] || continue
    quote=${BASH_REMATCH[1]}
    inc=${BASH_REMATCH[2]}
    if [[ $inc == tether/* ]]; then
      sub=${inc#tether/}
      if [[ $sub == */* ]]; then
        target=${sub%%/*}
      else
        target=$(top_level_owner "$sub")
      fi
      [ -n "$target" ] && [ "$target" != "$mod" ] || continue
      t=$(level "$target")
      [ -n "$t" ] || continue
      if [ "$t" -gt "$r" ]; then
        report "$file:$line: $mod includes $inc, a header of $target, which is a level above it"
      elif [ "$t" -eq "$r" ]; then
        report "$file:$line: $mod includes $inc, a header of $target, which is on its level"
      fi
    elif [ "$quote" = '"' ]; then
      private=$(private_target "$(dirname "$file")" "$inc" "$mod")
      if [ -n "$private" ]; then
        report "$file:$line: $mod includes \"$inc\", the private header $private of ${private%%/*}"
      fi
    fi
  done < <(grep -rnE --include='*.h' --include='*.hpp' --include='*.cc' --include='*.cpp' --include='*.in' \
    '^[[:space:]]*#[[:space:]]*include' "$mod" 2>/dev/null | sort -t: -k1,1 -k2,2n)
done
exit $found_any
