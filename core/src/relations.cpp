#include "esfleet/core/relations.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <iterator>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <tuple>
#include <utility>
#include <vector>

#include "line_fields.hpp"

namespace esfleet {
namespace {

using detail::read_number_rows;

constexpr std::size_t kFields = 8;  // t1 t2 x y z roll pitch yaw

/// Index of the entry in `sorted` (ascending `stamp` members: TimedPose, IndexedStamp) nearest
/// to `t`, if within `tolerance`. A tie goes to the earlier entry. A non-finite `t` never
/// matches.
template <typename Stamped>
std::optional<std::size_t> nearest(const std::vector<Stamped>& sorted, double t, double tolerance) {
  if (sorted.empty() || !std::isfinite(t)) return std::nullopt;
  const auto after = std::lower_bound(sorted.begin(), sorted.end(), t,
                                      [](const Stamped& p, double s) { return p.stamp < s; });
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

void check_options(const RelationsOptions& options) {
  if (!std::isfinite(options.time_offset)) {
    throw std::invalid_argument("RelationsOptions::time_offset must be finite");
  }
  if (!std::isfinite(options.tolerance) || options.tolerance < 0.0) {
    throw std::invalid_argument("RelationsOptions::tolerance must be finite and >= 0");
  }
}

/// A scan's stamp and its index in the caller's (unsorted) list.
struct IndexedStamp {
  double stamp = 0.0;
  std::size_t index = 0;
};

/// `trajectory` in stamp order (equal stamps keep their order), for nearest(). Throws
/// std::invalid_argument naming the first pose with a non-finite stamp.
std::vector<TimedPose> sorted_by_stamp(const std::vector<TimedPose>& trajectory) {
  for (std::size_t i = 0; i < trajectory.size(); ++i) {
    if (!std::isfinite(trajectory[i].stamp)) {
      throw std::invalid_argument("trajectory pose " + std::to_string(i) +
                                  " has a non-finite stamp");
    }
  }
  std::vector<TimedPose> sorted = trajectory;
  std::stable_sort(sorted.begin(), sorted.end(),
                   [](const TimedPose& a, const TimedPose& b) { return a.stamp < b.stamp; });
  return sorted;
}

bool is_finite(const Pose2& p) {
  return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.theta);
}

}  // namespace

std::vector<Relation> read_relations(const std::string& path) {
  std::vector<Relation> relations;
  read_number_rows<kFields>(
      path, "relations", "t1 t2 x y z roll pitch yaw", [&](const std::array<double, kFields>& v) {
        relations.push_back({v[0], v[1], {v[2], v[3], normalize_angle(v[7])}});
      });
  return relations;
}

RelationsResult evaluate_relations(const std::vector<TimedPose>& trajectory,
                                   const std::vector<Relation>& relations,
                                   const RelationsOptions& options) {
  check_options(options);
  const std::vector<TimedPose> sorted = sorted_by_stamp(trajectory);

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

std::vector<std::optional<RelationEnds>> match_relation_ends(const std::vector<double>& stamps,
                                                             const std::vector<Relation>& relations,
                                                             const RelationsOptions& options) {
  check_options(options);
  std::vector<IndexedStamp> sorted;
  sorted.reserve(stamps.size());
  for (std::size_t i = 0; i < stamps.size(); ++i) {
    if (!std::isfinite(stamps[i])) {
      throw std::invalid_argument("scan " + std::to_string(i) + " has a non-finite stamp");
    }
    sorted.push_back({stamps[i], i});
  }
  std::stable_sort(sorted.begin(), sorted.end(),
                   [](const IndexedStamp& a, const IndexedStamp& b) { return a.stamp < b.stamp; });
  std::vector<std::optional<RelationEnds>> ends;
  ends.reserve(relations.size());
  for (const Relation& r : relations) {
    const auto i1 = nearest(sorted, r.t1 - options.time_offset, options.tolerance);
    const auto i2 = nearest(sorted, r.t2 - options.time_offset, options.tolerance);
    if (!i1 || !i2) {
      ends.emplace_back();
      continue;
    }
    ends.push_back(RelationEnds{sorted[*i1].index, sorted[*i2].index});
  }
  return ends;
}

DerivedRelationsResult evaluate_derived_relations(const std::vector<Pose2>& reference,
                                                  const std::vector<Pose2>& estimate,
                                                  const std::vector<std::size_t>& gaps) {
  if (reference.size() != estimate.size()) {
    throw std::invalid_argument("derived relations: " + std::to_string(reference.size()) +
                                " reference poses but " + std::to_string(estimate.size()) +
                                " estimated poses");
  }
  for (std::size_t i = 0; i < reference.size(); ++i) {
    if (!is_finite(reference[i]) || !is_finite(estimate[i])) {
      throw std::invalid_argument("derived relations: pose " + std::to_string(i) +
                                  " is not finite");
    }
  }
  DerivedRelationsResult result;
  std::vector<double> all_trans, all_rot;
  for (const std::size_t gap : gaps) {
    if (gap == 0) throw std::invalid_argument("derived relations: a gap must be >= 1");
    std::vector<double> trans, rot;
    for (std::size_t i = 0; i + gap < reference.size(); ++i) {
      const Pose2 rel = reference[i + gap].relative_to(reference[i]);
      const Pose2 est = estimate[i + gap].relative_to(estimate[i]);
      const Pose2 err = est.relative_to(rel);  // inv(rel)·est
      trans.push_back(std::hypot(err.x, err.y));
      rot.push_back(std::abs(normalize_angle(err.theta)));
    }
    DerivedGap g;
    g.gap = gap;
    g.count = trans.size();
    g.trans_mean = mean_and_std(trans).first;
    g.rot_mean_deg = rad_to_deg(mean_and_std(rot).first);
    result.gaps.push_back(g);
    all_trans.insert(all_trans.end(), trans.begin(), trans.end());
    all_rot.insert(all_rot.end(), rot.begin(), rot.end());
  }
  result.count = all_trans.size();
  std::tie(result.trans_mean, result.trans_std) = mean_and_std(all_trans);
  const auto [rot_mean, rot_std] = mean_and_std(all_rot);
  result.rot_mean_deg = rad_to_deg(rot_mean);
  result.rot_std_deg = rad_to_deg(rot_std);
  for (double t : all_trans) result.trans_max = std::max(result.trans_max, t);
  return result;
}

StampOrder stamp_order(const std::vector<double>& stamps) {
  StampOrder out;
  for (std::size_t i = 1; i < stamps.size(); ++i) {
    if (!(stamps[i] > stamps[i - 1])) {
      if (out.not_after == 0) out.first = i;
      ++out.not_after;
    }
  }
  return out;
}

AbsoluteErrorResult evaluate_absolute(const std::vector<TimedPose>& trajectory,
                                      const std::vector<TimedPose>& reference, double tolerance) {
  if (!std::isfinite(tolerance) || tolerance < 0.0) {
    throw std::invalid_argument("evaluate_absolute: tolerance must be finite and >= 0");
  }
  const std::vector<TimedPose> sorted = sorted_by_stamp(trajectory);
  // Matched pairs: (reference position, estimated position).
  std::vector<std::array<double, 4>> pairs;
  for (std::size_t i = 0; i < reference.size(); ++i) {
    const TimedPose& r = reference[i];
    if (!std::isfinite(r.stamp) || !is_finite(r.pose)) {
      throw std::invalid_argument("reference pose " + std::to_string(i) + " is not finite");
    }
    const auto k = nearest(sorted, r.stamp, tolerance);
    if (k) pairs.push_back({r.pose.x, r.pose.y, sorted[*k].pose.x, sorted[*k].pose.y});
  }
  AbsoluteErrorResult result;
  result.total = reference.size();
  result.matched = pairs.size();
  if (pairs.size() < 2) return result;
  // Centroids, then the rotation (and scale) that best maps the estimate's spread onto the
  // reference's: Umeyama's closed form, in 2D.
  const auto n = static_cast<double>(pairs.size());
  double rx = 0, ry = 0, ex = 0, ey = 0;
  for (const auto& [ax, ay, bx, by] : pairs) {
    rx += ax / n;
    ry += ay / n;
    ex += bx / n;
    ey += by / n;
  }
  double dot = 0, cross = 0, spread = 0;
  for (const auto& [ax, ay, bx, by] : pairs) {
    const double px = ax - rx, py = ay - ry, qx = bx - ex, qy = by - ey;
    dot += qx * px + qy * py;
    cross += qx * py - qy * px;
    spread += qx * qx + qy * qy;
  }
  const double angle = std::atan2(cross, dot);
  result.scale = spread > 0 ? std::hypot(dot, cross) / spread : 1.0;
  auto errors = [&](double scale) {
    const double c = scale * std::cos(angle), s = scale * std::sin(angle);
    std::vector<double> e;
    e.reserve(pairs.size());
    for (const auto& [ax, ay, bx, by] : pairs) {
      const double qx = bx - ex, qy = by - ey;
      e.push_back(std::hypot(c * qx - s * qy + rx - ax, s * qx + c * qy + ry - ay));
    }
    return e;
  };
  auto rms = [&](const std::vector<double>& e) {
    double sq = 0;
    for (double v : e) sq += v * v;
    return std::sqrt(sq / n);
  };
  const std::vector<double> rigid = errors(1.0);
  result.rms = rms(rigid);
  result.mean = mean_and_std(rigid).first;
  result.max = *std::max_element(rigid.begin(), rigid.end());
  result.rms_scaled = rms(errors(result.scale));
  return result;
}

}  // namespace esfleet
