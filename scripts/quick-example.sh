#!/usr/bin/env bash
# Installs dependencies, builds demfem and runs the quick coupled study on the built-in DEM backend.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
build=${DEMFEM_BUILD_DIR:-build}
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release
cmake --build "$build" -j "$(nproc)" --target demfem demfem-fem demfem-dem
"$build"/apps/demfem run studies/quick.json --output out/quick
