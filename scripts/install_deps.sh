#!/usr/bin/env bash
# Installs the Debian packages tether needs to build and test (only those missing).
#   install_deps.sh          what every build needs
#   install_deps.sh --mpi    and MPI, PETSc, MUMPS and METIS for the distributed solvers
#                            (cmake -DTETHER_WITH_MPI=ON; docs/distributed.md)
set -euo pipefail
packages=(
  build-essential cmake git
  libeigen3-dev libsuitesparse-dev libceres-dev
  libgtest-dev libgmock-dev libbenchmark-dev libcli11-dev
  libopenblas0-pthread zlib1g-dev
  librosbag-storage-dev libsensor-msgs-dev libnav-msgs-dev
  pybind11-dev python3-dev python3-numpy python3-pytest python3-matplotlib
)
if [ "${1:-}" = "--mpi" ]; then
  packages+=(libopenmpi-dev openmpi-bin libpetsc-real-dev libmumps-dev libmetis-dev)
elif [ $# -gt 0 ]; then
  echo "install_deps.sh: unknown option '$1' (use --mpi or nothing)" >&2
  exit 2
fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "installing: ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update
  apt-get install -y --no-install-recommends "${missing[@]}"
fi
