#include "esfleet/core/relations.hpp"

#include <algorithm>
#include <array>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <optional>
#include <stdexcept>
#include <string_view>
#include <tuple>
#include <utility>

namespace esfleet {
namespace {

constexpr std::size_t kFields = 8;  // t1 t2 x y z roll pitch yaw

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

/// Index of the pose in `sorted` (ascending stamps) nearest to `t`, if within `tolerance`.
/// A tie goes to the earlier pose. A non-finite `t` never matches.
std::optional<std::size_t> nearest(const std::vector<TimedPose>& sorted, double t,
                                   double tolerance) {
  if (sorted.empty() || !std::isfinite(t)) return std::nullopt;
  const auto after = std::lower_bound(sorted.begin(), sorted.end(), t,
                                      [](const TimedPose& p, double s) { return p.stamp < s; });
  auto best = after;
  if (after == sorted.end() ||
      (after != sorted.begin() && t - std::prev(after)->stamp <= after->stamp - t)) {
    best = std::prev(after);
  }
  if (std::abs(best->stamp - t) > tolerance) return std::nullopt;
  return static_cast<std::size_t>(best - sorted.begin());
}

/// Mean and population standard deviation (two passes, so no cancellation).
std::pair<double, double> mean_and_std(const std::vector<double>& values) {
  if (values.empty()) return {0.0, 0.0};
  const auto n = static_cast<double>(values.size());
  double sum = 0.0;
  for (double v : values) sum += v;
  const double mean = sum / n;
  double squares = 0.0;
  for (double v : values) squares += (v - mean) * (v - mean);
  return {mean, std::sqrt(squares / n)};
}

}  // namespace

std::vector<Relation> read_relations(const std::string& path) {
  errno = 0;
  std::ifstream in(path);
  if (!in) {
    throw std::runtime_error("cannot open relations '" + path +
                             "': " + (errno != 0 ? std::strerror(errno) : "unknown error"));
  }
  std::vector<Relation> relations;
  std::string line;
  std::size_t line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    std::array<std::string_view, kFields> tokens;
    const std::size_t count = split(line, tokens);
    if (count == 0 || tokens[0].front() == '#') continue;
    if (count != kFields) {
      throw line_error(
          path, line_no,
          "expected 8 fields (t1 t2 x y z roll pitch yaw), got " + std::to_string(count));
    }
    std::array<double, kFields> v{};
    for (std::size_t i = 0; i < kFields; ++i) {
      if (std::string what = parse_finite(tokens[i], v[i]); !what.empty()) {
        throw line_error(path, line_no, "field " + std::to_string(i + 1) + ": " + what);
      }
    }
    relations.push_back({v[0], v[1], {v[2], v[3], normalize_angle(v[7])}});
  }
  if (in.bad()) throw std::runtime_error("cannot read relations '" + path + "': read error");
  return relations;
}

RelationsResult evaluate_relations(const std::vector<TimedPose>& trajectory,
                                   const std::vector<Relation>& relations,
                                   const RelationsOptions& options) {
  if (!std::isfinite(options.time_offset)) {
    throw std::invalid_argument("RelationsOptions::time_offset must be finite");
  }
  if (!std::isfinite(options.tolerance) || options.tolerance < 0.0) {
    throw std::invalid_argument("RelationsOptions::tolerance must be finite and >= 0");
  }
  for (std::size_t i = 0; i < trajectory.size(); ++i) {
    if (!std::isfinite(trajectory[i].stamp)) {
      throw std::invalid_argument("trajectory pose " + std::to_string(i) +
                                  " has a non-finite stamp");
    }
  }

  std::vector<TimedPose> sorted = trajectory;
  std::stable_sort(sorted.begin(), sorted.end(),
                   [](const TimedPose& a, const TimedPose& b) { return a.stamp < b.stamp; });

  std::vector<double> trans_errors, rot_errors;
  trans_errors.reserve(relations.size());
  rot_errors.reserve(relations.size());
  for (const Relation& r : relations) {
    const auto i1 = nearest(sorted, r.t1 - options.time_offset, options.tolerance);
    const auto i2 = nearest(sorted, r.t2 - options.time_offset, options.tolerance);
    if (!i1 || !i2) continue;
    const Pose2 est = sorted[*i2].pose.relative_to(sorted[*i1].pose);  // inv(P1)·P2
    const Pose2 err = est.relative_to(r.rel);                          // inv(rel)·est
    trans_errors.push_back(std::hypot(err.x, err.y));
    rot_errors.push_back(std::abs(normalize_angle(err.theta)));
  }

  RelationsResult result;
  result.total = relations.size();
  result.matched = trans_errors.size();
  std::tie(result.trans_mean, result.trans_std) = mean_and_std(trans_errors);
  const double outlier_rot = deg_to_rad(options.outlier_rot_deg);
  for (std::size_t i = 0; i < trans_errors.size(); ++i) {
    result.trans_max = std::max(result.trans_max, trans_errors[i]);
    if (trans_errors[i] > options.outlier_trans || rot_errors[i] > outlier_rot) ++result.outliers;
  }
  const auto [rot_mean, rot_std] = mean_and_std(rot_errors);
  result.rot_mean_deg = rad_to_deg(rot_mean);
  result.rot_std_deg = rad_to_deg(rot_std);
  return result;
}

}  // namespace esfleet
