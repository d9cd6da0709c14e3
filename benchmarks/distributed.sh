#!/bin/bash
# The distributed solver (`--linear petsc`, MUMPS's Cholesky over MPI processes) against the
# single-process CHOLMOD solve, on the public g2o files (or the files given).
#
#   bash benchmarks/distributed.sh TETHER [FILE...]     (default: every ../shared/datasets/g2o file)
#
# Per file: `tether optimize` with --linear cholmod in one process, then with --linear petsc
# under `mpirun -np K --oversubscribe` for K in $PROCS (default "1 2 4"), each with its default
# chordal start. Printed per run: final chi2, iterations, the optimise phase and the whole
# process (from the summary), and the peak resident memory of the largest process
# (/usr/bin/time around each process). This machine has 2 cores: K = 4 shares them.
# Build with -DTETHER_WITH_MPI=ON (scripts/install_deps.sh --mpi).
set -euo pipefail
TETHER=${1:?usage: distributed.sh TETHER [FILE...]}
shift
DATA=${TETHER_DATASETS_DIR:-$(dirname "$0")/../../shared/datasets}
FILES=("$@")
if [ ${#FILES[@]} -eq 0 ]; then FILES=("$DATA"/g2o/*.g2o); fi
PROCS=${PROCS:-1 2 4}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_btl_vader_single_copy_mechanism=none
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# One row from a run's summary and its processes' peak memory files.
row() {
  local name=$1 out=$2
  local chi2 its opt whole mem
  chi2=$(grep "final chi2" "$out" | awk '{print $3}')
  its=$(grep "^  iterations" "$out" | awk '{print $2}')
  opt=$(grep -o "optimise [0-9.]*" "$out" | awk '{print $2}')
  whole=$(grep -o "whole process [0-9.]*" "$out" | awk '{print $3}')
  mem=$(cat "$work"/mem.* 2>/dev/null | sort -n | tail -1)
  printf "| %s | %s | %s | %s | %s | %s | %.0f |\n" "$(basename "$3")" "$name" "$chi2" "$its" "$opt" "$whole" \
    "$(echo "${mem:-0} / 1024" | bc -l)"
}
echo "| file | run | final chi2 | iterations | optimise [s] | whole process [s] | peak memory per process [MB] |"
echo "|---|---|---|---|---|---|---|"
for f in "${FILES[@]}"; do
  rm -f "$work"/mem.*
  /usr/bin/time -f "%M" -o "$work/mem.0" "$TETHER" optimize "$f" --linear cholmod -q > "$work/out" 2>&1
  row "cholmod, 1 process" "$work/out" "$f"
  for k in $PROCS; do
    rm -f "$work"/mem.*
    mpirun -np "$k" --oversubscribe bash -c '/usr/bin/time -f "%M" -o "$0/mem.$OMPI_COMM_WORLD_RANK" "$@"' \
      "$work" "$TETHER" optimize "$f" --linear petsc -q > "$work/out" 2>&1
    row "petsc, $k process(es)" "$work/out" "$f"
  done
done
