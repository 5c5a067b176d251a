#!/usr/bin/env bash
# Installs dependencies, builds demfem and runs the whole test suite (unit + physics labels).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
build=${DEMFEM_BUILD_DIR:-build}
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release
cmake --build "$build" -j "$(nproc)"
cd "$build"
# OpenMPI refuses to run as root unless told; CI runs as root.
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
ctest --output-on-failure -j "$(nproc)" "$@"
