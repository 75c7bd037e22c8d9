#pragma once
// What the fuzz targets share: a failed invariant is a finding, reported like a crash.

#include <cstdio>
#include <cstdlib>

namespace esfleet::fuzz {

/// Aborts (libFuzzer saves the input as a crash) when `ok` is false, naming the invariant.
inline void check(bool ok, const char* what) {
  if (ok) return;
  std::fprintf(stderr, "fuzz invariant violated: %s\n", what);
  std::abort();
}

}  // namespace esfleet::fuzz
