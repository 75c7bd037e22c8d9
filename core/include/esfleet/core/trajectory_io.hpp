#pragma once
// Plain-text trajectory files: one "t x y theta" line per pose. Written by the SLAM and
// localisation programs, read by the accuracy tools (esfleet-eval) and by tests.
//
// Format: four whitespace-separated numbers per line — stamp (s, the log's clock), x and y (m),
// theta (rad). Lines whose first non-blank character is '#' and blank lines are comments.

#include <string>
#include <vector>

#include "esfleet/core/geometry.hpp"

namespace esfleet {

/// Writes "t x y theta" per line (stamp %.6f, x y %.6f m, theta %.6f rad), in the given order.
/// Atomic: writes "<path>.tmp" and renames it over `path`, so a reader never sees half a file.
/// Output is byte-identical for identical input. Throws std::runtime_error naming the path if
/// a value is not finite (it could not be read back) or the file cannot be written.
void write_trajectory(const std::string& path, const std::vector<TimedPose>& trajectory);

/// Reads the format written by write_trajectory (any number of digits is accepted), in file
/// order; '#' comments and blank lines are skipped. Throws std::runtime_error
/// "<path>:<line>: <what>" on a malformed line (wrong field count, non-numeric, non-finite) and
/// a std::runtime_error naming the path if the file cannot be opened or read.
std::vector<TimedPose> read_trajectory(const std::string& path);

}  // namespace esfleet
