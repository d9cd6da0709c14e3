#!/usr/bin/env bash
# Builds everything (Release) and runs every test. Dataset tests read ../shared/datasets and
# skip with a message where it is absent.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install_deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DTETHER_BUILD_TESTS=ON
cmake --build build -j"$(nproc)"
cd build
ctest --output-on-failure -j"$(nproc)"
