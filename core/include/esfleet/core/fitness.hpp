#pragma once
// Fitness of a candidate pose (paper, equation under Eq. 9), maximised by the ES:
//
//   fit = p_occ * sum_i map(c_i),   p_occ = sum_i hit'(c_i) / (sum_i hit'(c_i) + sum_i err'(c_i))
//
// c_i is the cell of beam i's end point under the candidate pose, map(c) = hit / (hit + err)
// (0 when unknown), hit'(c) = [hit(c) > 0], err'(c) = [err(c) > 0]; p_occ = 0 when both sums are
// 0. Condition 2 of the paper drops the penalty: fit = sum_i map(c_i).
//
// The evaluator pre-scales the end points to cell units once; each evaluation is one rotation,
// one floor and one 4-byte score load per beam (GridMap::Lookup).

#include <cstdint>
#include <vector>

#include "esfleet/core/geometry.hpp"
#include "esfleet/core/grid_map.hpp"
#include "esfleet/core/scan_points.hpp"

namespace esfleet {

struct FitnessValue {
  float fitness = 0.0f;      ///< p_occ * sum_map (Condition 1) or sum_map (Condition 2)
  float sum_map = 0.0f;      ///< sum of map values at the end points
  float p_occ = 0.0f;        ///< penalty factor
  std::int32_t n_hit = 0;    ///< end points in cells with hit > 0
  std::int32_t n_err = 0;    ///< end points in cells with err > 0
  std::int32_t n_known = 0;  ///< end points in observed cells (hit + err > 0)
  std::int32_t n_points = 0;
  /// Share of the end points in observed cells that fell on cells with hit > 0: how well the
  /// scan agrees with the map where the map knows something (1 = perfectly); 0 if none known.
  float agreement() const {
    return n_known > 0 ? static_cast<float>(n_hit) / static_cast<float>(n_known) : 0.0f;
  }
  /// Share of all end points that fell in observed cells; 0 if there are none.
  double known_share() const {
    return n_points > 0 ? static_cast<double>(n_known) / static_cast<double>(n_points) : 0.0;
  }
};

struct FitnessOptions {
  bool use_penalty = true;  ///< Condition 1 (with p_occ); false = Condition 2
  int level = 0;            ///< map pyramid level (0 = full resolution)
  int stride = 1;           ///< use every stride-th end point only (coarse levels)
  /// Ours: bilinear interpolation of map values between cell centres (sub-cell precision);
  /// the penalty still counts the end point's own cell.
  bool interpolate = false;
};

class FitnessEvaluator {
 public:
  /// Keeps a reference to nothing but the map's look-up view: the map must not gain tiles
  /// while the evaluator is used.
  FitnessEvaluator(const GridMap& map, const ScanPoints& points, FitnessOptions options = {});
  /// Paper fitness at full resolution, Condition 1 or 2.
  FitnessEvaluator(const GridMap& map, const ScanPoints& points, bool use_penalty)
      : FitnessEvaluator(map, points, FitnessOptions{.use_penalty = use_penalty}) {}

  FitnessValue evaluate(const Pose2& pose) const;
  /// Fitness only (the ES hot path).
  float fitness(const Pose2& pose) const { return evaluate(pose).fitness; }
  std::size_t size() const { return px_.size(); }

 private:
  GridMap::Lookup lookup_;
  double inv_cell_;
  FitnessOptions options_;
  std::vector<float> px_, py_;  ///< end points in cell units
};

/// One scan scored at many positions for one heading at a time, on one pyramid level without
/// interpolation: the same FitnessValue as FitnessEvaluator::evaluate, bit for bit, for a
/// fraction of the cost where many positions share a heading (the global search's coarse
/// stage). The level is copied into one dense array (a load per end point instead of a tile
/// look-up) and the end points are rotated once per heading.
class HeadingScorer {
 public:
  /// Throws std::invalid_argument if options.interpolate is set. Copies what it needs: the
  /// map may change afterwards (the copy does not follow it).
  HeadingScorer(const GridMap& map, const ScanPoints& points, FitnessOptions options);

  /// The heading evaluate() scores at (radians).
  void set_heading(double theta);
  /// FitnessEvaluator::evaluate({x, y, theta}) for the theta of set_heading().
  FitnessValue evaluate(double x, double y) const;

  /// For the heading of set_heading(): the column in cells() of every end point for a
  /// candidate at x, and the row for a candidate at y, as evaluate() computes them (not
  /// clamped: outside [0, width()) or [0, height()) the end point reads an unknown cell).
  void columns(double x, std::int32_t* out) const;
  void rows(double y, std::int32_t* out) const;
  /// The level's scores the scorer reads, row-major, width() x height().
  const float* cells() const { return cells_.data(); }
  std::int32_t width() const { return width_; }
  std::int32_t height() const { return height_; }
  std::size_t size() const { return px_.size(); }

 private:
  FitnessOptions options_;
  double inv_cell_;
  bool heading_ok_ = false;
  std::vector<float> px_, py_;  ///< end points in cell units
  /// For the current heading: cos * px, sin * py, sin * px, cos * py.
  std::vector<float> cpx_, spy_, spx_, cpy_;
  /// The level's scores, row-major from (x0_, y0_), then one unknown cell (outside).
  std::vector<float> cells_;
  std::int32_t x0_ = 0, y0_ = 0, width_ = 0, height_ = 0;
};

/// Where the fitness around a pose curves least in the plane (a corridor's axis), and how much.
struct Flattest {
  double vx = 1.0, vy = 0.0;  ///< unit direction
  double ratio = 0.0;         ///< least curvature / greatest (0 when it does not curve at all)
  bool curved = false;        ///< the greatest curvature is > 0 (the pose is a maximum somewhere)
};

/// The curvature of `eval`'s fitness at `p` in x and y by central differences over `step`
/// metres (`f0`: the fitness at `p`): the direction of the least and its share of the greatest.
/// The tracking's hold along the motion and the final pass's loop matches use it.
Flattest flattest_direction(const FitnessEvaluator& eval, const Pose2& p, double f0, double step);

}  // namespace esfleet
