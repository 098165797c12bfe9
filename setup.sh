#!/usr/bin/env bash
# One command on a fresh Debian 12 machine: installs the Debian packages sph
# needs, builds ./sph, and runs the default case (input/circle2d.nml), which
# ends with a summary of its errors against the exact solution.
# With CI=true the default run is skipped (CI runs the tests instead).
set -euo pipefail
cd "$(dirname "$0")"

PACKAGES="make pkg-config fypp gfortran openmpi-bin libopenmpi-dev libhdf5-openmpi-dev hdf5-tools \
libfftw3-dev libmetis-dev python3-numpy python3-h5py python3-matplotlib python3-scipy \
python3-pyfftw python3-pytest python3-vtk9 python3-venv gerris libgfs-dev"

SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
missing=$(dpkg-query -W -f='${Package} ${Status}\n' $PACKAGES 2>/dev/null \
          | awk '$4 != "installed" {print $1}'; \
          for p in $PACKAGES; do dpkg-query -W "$p" >/dev/null 2>&1 || echo "$p"; done)
if [ -n "$missing" ]; then
  echo "== installing: $(echo $missing | tr '\n' ' ')"
  $SUDO apt-get update
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y --no-install-recommends $PACKAGES
fi

echo "== building ./sph"
make -j"$(nproc)"

if [ "${CI:-false}" != "true" ]; then
  echo "== running the default case: input/circle2d.nml"
  export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
  mpirun -np 2 ./sph input/circle2d.nml
fi
