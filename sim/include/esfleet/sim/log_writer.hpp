#pragma once
// Writes one simulated robot's run as files: a CARMEN log (<dir>/<id>.log) that core's
// CarmenReader reads back with odometry, and its true trajectory (<dir>/<id>.truth) in the
// trajectory_io format ("stamp x y theta", %.6f), one line per scan with the scan's stamp.
//
// Log lines per scan: an ODOM line (odometry pose, true forward and turn speeds, accel 0), then
// the laser line, both stamped with the scan stamp (ipc and logger timestamp, host "esfleet-sim").
//  - FLASER when the scan covers exactly 180 degrees with an odd beam count (the only layout
//    FLASER can express unambiguously: beam j at -90 + j * 180 / (n - 1) degrees). Its pose
//    fields hold the odometry (as a raw log's do; the truth is only in the .truth file).
//    No-return beams are written as 81.91, the CARMEN no-return level, which CarmenReader
//    flags as no-returns with its default options.
//  - ROBOTLASER1 otherwise, carrying start angle, field of view, resolution and the maximum
//    range, no-returns written as the maximum range.
// Ranges are written with 4 decimals (0.1 mm), poses and angles with enough digits to read back
// the same float/double within 1e-6. The files grow as the run goes (not written atomically);
// esfleet-sim flushes them once per second of sim time and at the end.

#include <cstdio>
#include <memory>
#include <string>

#include "esfleet/core/geometry.hpp"
#include "esfleet/core/laser_scan.hpp"

namespace esfleet::sim {

/// CARMEN's no-return level (SICK logs write 81.91; CarmenReader's default threshold is 81.9).
inline constexpr double kCarmenNoReturn = 81.91;

class RobotLogWriter {
 public:
  /// Creates (truncates) <dir>/<robot_id>.log and <dir>/<robot_id>.truth; `dir` must exist.
  /// Throws std::runtime_error naming the file on failure.
  RobotLogWriter(const std::string& dir, const std::string& robot_id);

  /// Appends one scan (with odometry set) and its true pose. `speed` (m/s) and `turn_rate`
  /// (rad/s) go into the ODOM line. Throws std::runtime_error naming the file on a write error.
  void write(const LaserScan& scan, const Pose2& truth, double speed, double turn_rate);
  /// Flushes both files; throws std::runtime_error naming the file on failure.
  void flush();

  const std::string& log_path() const { return log_path_; }
  const std::string& truth_path() const { return truth_path_; }

 private:
  struct Closer {
    void operator()(std::FILE* f) const { std::fclose(f); }
  };
  std::string log_path_, truth_path_;
  std::unique_ptr<std::FILE, Closer> log_, truth_;
};

}  // namespace esfleet::sim
