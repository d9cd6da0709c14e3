#!/usr/bin/env bash
# Checks the layering of the includes, builds everything (Release) and runs every test. Dataset
# tests read ../shared/datasets and skip with a message where it is absent.
set -euo pipefail
cd "$(dirname "$0")/.."
# An include against the layers (DESIGN.md, "Layout") fails here, before the build; ctest runs
# the same check again (layers.includes) beside the check of the checker.
bash scripts/check_layers.sh .
# With the distributed solvers (MPI, PETSc, MUMPS, METIS): their tests run under mpirun.
bash scripts/install_deps.sh --mpi
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DTETHER_BUILD_TESTS=ON -DTETHER_WITH_MPI=ON
cmake --build build -j"$(nproc)"
cd build
ctest --output-on-failure -j"$(nproc)"
