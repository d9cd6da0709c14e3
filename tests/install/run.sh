#!/usr/bin/env bash
# Installs the built tree into a temporary prefix, then configures, builds and runs a tiny
# downstream project that uses find_package(tether) and links tether::tether.
set -euo pipefail
build_dir=$1
downstream_src=$2
link_flags=${3:-}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cmake --install "$build_dir" --prefix "$work/prefix" > "$work/install.log"
test -f "$work/prefix/lib/cmake/tether/tetherConfig.cmake"
test -f "$work/prefix/include/tether/core/values.h"
cmake -S "$downstream_src" -B "$work/build" -DCMAKE_PREFIX_PATH="$work/prefix" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_EXE_LINKER_FLAGS="$link_flags" > "$work/configure.log" \
  || { cat "$work/configure.log"; exit 1; }
cmake --build "$work/build" -j2 > "$work/build.log" || { cat "$work/build.log"; exit 1; }
"$work/build/app"
