#include "esfleet/core/trajectory_io.hpp"

#include <array>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <string_view>
#include <vector>

#include "line_fields.hpp"

namespace esfleet {
namespace {

using detail::read_number_rows;

constexpr std::size_t kFields = 4;  // t x y theta

}  // namespace

void write_trajectory(const std::string& path, const std::vector<TimedPose>& trajectory) {
  // Format everything first: a bad value must not leave a temporary file behind.
  std::string text;
  text.reserve(trajectory.size() * 48);
  char buf[160];
  for (std::size_t i = 0; i < trajectory.size(); ++i) {
    const TimedPose& p = trajectory[i];
    if (!std::isfinite(p.stamp) || !std::isfinite(p.pose.x) || !std::isfinite(p.pose.y) ||
        !std::isfinite(p.pose.theta)) {
      throw std::runtime_error("cannot write trajectory '" + path + "': pose " + std::to_string(i) +
                               " has a non-finite value");
    }
    const int n = std::snprintf(buf, sizeof buf, "%.6f %.6f %.6f %.6f\n", p.stamp, p.pose.x,
                                p.pose.y, p.pose.theta);
    if (n < 0 || static_cast<std::size_t>(n) >= sizeof buf) {
      throw std::runtime_error("cannot write trajectory '" + path + "': pose " + std::to_string(i) +
                               " does not fit the line format");
    }
    text.append(buf, static_cast<std::size_t>(n));
  }

  const std::string tmp = path + ".tmp";
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (f == nullptr) {
    throw std::runtime_error("cannot write trajectory '" + path + "': cannot open '" + tmp +
                             "': " + std::strerror(errno));
  }
  const bool written = std::fwrite(text.data(), 1, text.size(), f) == text.size();
  const int write_errno = errno;
  const bool closed = std::fclose(f) == 0;
  if (!written || !closed) {
    const int err = !written ? write_errno : errno;
    std::remove(tmp.c_str());
    throw std::runtime_error("cannot write trajectory '" + path + "': writing '" + tmp +
                             "' failed: " + std::strerror(err));
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    std::remove(tmp.c_str());
    throw std::runtime_error("cannot write trajectory '" + path + "': renaming '" + tmp +
                             "' failed: " + std::strerror(err));
  }
}

std::vector<TimedPose> read_trajectory(const std::string& path) {
  std::vector<TimedPose> trajectory;
  read_number_rows<kFields>(path, "trajectory", "t x y theta",
                            [&](const std::array<double, kFields>& v) {
                              trajectory.push_back({v[0], {v[1], v[2], v[3]}});
                            });
  return trajectory;
}

}  // namespace esfleet
