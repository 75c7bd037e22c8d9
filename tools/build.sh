#!/usr/bin/env bash
# Installs missing packages, configures and builds esfleet into build/ (executables in build/bin).
set -euo pipefail
cd "$(dirname "$0")/.."
tools/install-deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j "$(nproc)"
