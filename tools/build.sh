#!/usr/bin/env bash
# Installs missing packages, configures and builds esfleet into build/ (executables in
# build/bin). With arguments, builds only those targets (e.g. tools/build.sh esfleet-leader).
set -euo pipefail
cd "$(dirname "$0")/.."
tools/install-deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
if [ $# -gt 0 ]; then
  cmake --build build -j "$(nproc)" --target "$@"
else
  cmake --build build -j "$(nproc)"
fi
