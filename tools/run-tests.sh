#!/usr/bin/env bash
# The whole test suite from a fresh machine: install packages, build, run every CTest test.
set -euo pipefail
cd "$(dirname "$0")/.."
tools/build.sh
ctest --test-dir build --output-on-failure -j "$(nproc)" "$@"

# Fuzzing (docs/fuzzing.md): a clang build of the libFuzzer targets in build-fuzz, each target
# fuzzed for ESFLEET_FUZZ_SECONDS (default 15) from its committed corpus; fails on any finding.
# ESFLEET_FUZZ_TESTS=0 skips it (e.g. when re-running a few tests with ctest arguments).
if [ "${ESFLEET_FUZZ_TESTS:-1}" != 0 ]; then
  CC=clang CXX=clang++ cmake -S . -B build-fuzz -DESFLEET_FUZZ=ON \
    -DCMAKE_BUILD_TYPE=RelWithDebInfo -DESFLEET_FUZZ_SECONDS="${ESFLEET_FUZZ_SECONDS:-15}"
  cmake --build build-fuzz -j "$(nproc)"
  ctest --test-dir build-fuzz --output-on-failure -j "$(nproc)" -L fuzz
fi
