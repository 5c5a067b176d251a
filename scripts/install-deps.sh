#!/usr/bin/env bash
# Installs every build and test dependency of demfem from Debian's packages (run as root).
# Nothing is downloaded from elsewhere and nothing is vendored.
set -euo pipefail
packages=(
  build-essential cmake pkg-config ccache
  libeigen3-dev libsuitesparse-dev libspectra-dev
  libzmq3-dev cppzmq-dev nlohmann-json3-dev
  catch2 libcli11-dev libnlopt-cxx-dev libnlopt-dev
  liggghts libliggghts-dev openmpi-bin libopenmpi-dev
  calculix-ccx python3-zmq python3-numpy gnuplot-nox
  libvtk9-dev
  clang libclang-rt-dev libomp-dev
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "installing: ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -q
  apt-get install -y -q --no-install-recommends "${missing[@]}"
fi
