#include "esfleet/core/trajectory_io.hpp"

#include <array>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <string_view>

namespace esfleet {
namespace {

constexpr std::size_t kFields = 4;  // t x y theta

std::runtime_error line_error(const std::string& path, std::size_t line_no,
                              const std::string& what) {
  return std::runtime_error(path + ":" + std::to_string(line_no) + ": " + what);
}

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

/// Splits `line` at whitespace into at most `out.size()` tokens; returns how many it found in
/// total (which may exceed out.size(): those extra tokens are counted, not stored).
std::size_t split(std::string_view line, std::array<std::string_view, kFields>& out) {
  std::size_t count = 0, i = 0;
  while (i < line.size()) {
    while (i < line.size() && is_space(line[i])) ++i;
    if (i == line.size()) break;
    const std::size_t start = i;
    while (i < line.size() && !is_space(line[i])) ++i;
    if (count < out.size()) out[count] = line.substr(start, i - start);
    ++count;
  }
  return count;
}

/// "'<token>' <what>". Built by appending: `"'" + std::string(...)` trips GCC 12's
/// -Wrestrict false positive (GCC bug 105329).
std::string describe(std::string_view token, std::string_view what) {
  std::string s;
  s.reserve(token.size() + what.size() + 3);
  s.append("'").append(token).append("' ").append(what);
  return s;
}

/// Parses a whole token as a finite double; returns an error description or an empty string.
std::string parse_finite(std::string_view token, double& value) {
  const char* const end = token.data() + token.size();
  const auto [ptr, ec] = std::from_chars(token.data(), end, value);
  if (ec == std::errc::result_out_of_range) return describe(token, "is out of range");
  if (ec != std::errc() || ptr != end) return describe(token, "is not a number");
  if (!std::isfinite(value)) return describe(token, "is not finite");
  return {};
}

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
  errno = 0;
  std::ifstream in(path);
  if (!in) {
    throw std::runtime_error("cannot open trajectory '" + path +
                             "': " + (errno != 0 ? std::strerror(errno) : "unknown error"));
  }
  std::vector<TimedPose> trajectory;
  std::string line;
  std::size_t line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    std::array<std::string_view, kFields> tokens;
    const std::size_t count = split(line, tokens);
    if (count == 0 || tokens[0].front() == '#') continue;
    if (count != kFields) {
      throw line_error(path, line_no,
                       "expected 4 fields (t x y theta), got " + std::to_string(count));
    }
    std::array<double, kFields> v{};
    for (std::size_t i = 0; i < kFields; ++i) {
      if (std::string what = parse_finite(tokens[i], v[i]); !what.empty()) {
        throw line_error(path, line_no, "field " + std::to_string(i + 1) + ": " + what);
      }
    }
    trajectory.push_back({v[0], {v[1], v[2], v[3]}});
  }
  if (in.bad()) throw std::runtime_error("cannot read trajectory '" + path + "': read error");
  return trajectory;
}

}  // namespace esfleet
