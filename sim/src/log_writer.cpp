#include "esfleet/sim/log_writer.hpp"

#include <cerrno>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

namespace esfleet::sim {
namespace {

constexpr const char* kHost = "esfleet-sim";

std::FILE* open_or_throw(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (!f) throw std::runtime_error(path + ": cannot create: " + std::strerror(errno));
  return f;
}

/// FLASER can express only 180 degrees with an odd beam count (see the header).
bool fits_flaser(const LaserScan& scan) {
  const std::size_t n = scan.ranges.size();
  if (n < 3 || n % 2 == 0) return false;
  const double fov = static_cast<double>(scan.angle_increment) * static_cast<double>(n - 1);
  return std::abs(fov - deg_to_rad(180.0)) < 1e-5 &&
         std::abs(scan.angle_min + deg_to_rad(90.0)) < 1e-5;
}

void append_ranges(std::string& line, const LaserScan& scan, double no_return) {
  char buf[32];
  for (std::size_t i = 0; i < scan.ranges.size(); ++i) {
    const double r = scan.is_no_return(i) ? no_return : static_cast<double>(scan.ranges[i]);
    std::snprintf(buf, sizeof buf, " %.4f", r);
    line += buf;
  }
}

}  // namespace

RobotLogWriter::RobotLogWriter(const std::string& dir, const std::string& robot_id)
    : log_path_(dir + "/" + robot_id + ".log"), truth_path_(dir + "/" + robot_id + ".truth") {
  log_.reset(open_or_throw(log_path_));
  truth_.reset(open_or_throw(truth_path_));
  std::fprintf(log_.get(), "# esfleet-sim: robot %s, odometry starts at 0 at the start pose\n",
               robot_id.c_str());
  std::fprintf(truth_.get(), "# esfleet-sim: true poses of robot %s (stamp x y theta)\n",
               robot_id.c_str());
}

void RobotLogWriter::write(const LaserScan& scan, const Pose2& truth, double speed,
                           double turn_rate) {
  const Pose2 odom = scan.odometry.value_or(Pose2{});
  const double t = scan.stamp;
  std::fprintf(log_.get(), "ODOM %.6f %.6f %.6f %.6f %.6f 0 %.6f %s %.6f\n", odom.x, odom.y,
               odom.theta, speed, turn_rate, t, kHost, t);
  std::string line;
  line.reserve(scan.ranges.size() * 9 + 200);
  char buf[256];
  if (fits_flaser(scan)) {
    std::snprintf(buf, sizeof buf, "FLASER %zu", scan.ranges.size());
    line += buf;
    append_ranges(line, scan, kCarmenNoReturn);
    std::snprintf(buf, sizeof buf, " %.6f %.6f %.6f %.6f %.6f %.6f %.6f %s %.6f", odom.x, odom.y,
                  odom.theta, odom.x, odom.y, odom.theta, t, kHost, t);
  } else {
    const double fov =
        static_cast<double>(scan.angle_increment) * static_cast<double>(scan.ranges.size() - 1);
    std::snprintf(buf, sizeof buf, "ROBOTLASER1 0 %.9g %.9g %.9g %.9g 0.01 0 %zu",
                  static_cast<double>(scan.angle_min), fov,
                  static_cast<double>(scan.angle_increment), static_cast<double>(scan.max_range),
                  scan.ranges.size());
    line += buf;
    append_ranges(line, scan, scan.max_range);
    std::snprintf(buf, sizeof buf, " 0 %.6f %.6f %.6f %.6f %.6f %.6f %.6f %.6f 0 0 0 %.6f %s %.6f",
                  odom.x, odom.y, odom.theta, odom.x, odom.y, odom.theta, speed, turn_rate, t,
                  kHost, t);
  }
  line += buf;
  line += '\n';
  if (std::fputs(line.c_str(), log_.get()) < 0) {
    throw std::runtime_error(log_path_ + ": write failed: " + std::strerror(errno));
  }
  if (std::fprintf(truth_.get(), "%.6f %.6f %.6f %.6f\n", t, truth.x, truth.y, truth.theta) < 0) {
    throw std::runtime_error(truth_path_ + ": write failed: " + std::strerror(errno));
  }
}

void RobotLogWriter::flush() {
  if (std::fflush(log_.get()) != 0) {
    throw std::runtime_error(log_path_ + ": write failed: " + std::strerror(errno));
  }
  if (std::fflush(truth_.get()) != 0) {
    throw std::runtime_error(truth_path_ + ": write failed: " + std::strerror(errno));
  }
}

}  // namespace esfleet::sim
