#!/usr/bin/env bash
# The main job on a default input made here: simulate a 2D Manhattan world with loop
# closures, optimise it with Levenberg-Marquardt over CHOLMOD, and draw the file's start, the
# result and the simulated ground truth, with the absolute trajectory error of each.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install_deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j"$(nproc)" --target tether_cli
mkdir -p build/demo
./build/tools/tether simulate manhattan --poses 3000 --seed 1 -o build/demo/manhattan.g2o \
  --ground-truth build/demo/manhattan_truth.g2o
./build/tools/tether optimize build/demo/manhattan.g2o -o build/demo/manhattan_optimized.g2o \
  --plot build/demo/manhattan.svg --ground-truth build/demo/manhattan_truth.g2o
echo "demo: the picture is build/demo/manhattan.svg"
