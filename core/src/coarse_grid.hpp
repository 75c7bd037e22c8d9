#pragma once
// Private to core: the recovery search's coarse stage (recovery.cpp), here for its test
// (tests/core/coarse_grid_test.cpp). The map around the prediction is max-pooled into blocks of
// `factor` x `factor` cells, and a square grid of positions, half a block apart, is scored at
// every heading by the sum of the pooled values under the end points.
//
// Scoring each position point by point costs a look-up per end point and position. Here a
// position's block under an end point moves by one half-block column per grid step, so for one
// heading the scores are sums of whole rows of a copy of the pooled blocks with every column
// doubled: one contiguous run per end point and grid row, which the compiler vectorises.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "esfleet/core/geometry.hpp"
#include "esfleet/core/grid_map.hpp"

namespace esfleet::coarse_grid {

/// a / b rounded towards minus infinity (b > 0).
inline std::int32_t floor_div(std::int32_t a, std::int32_t b) {
  return a >= 0 ? a / b : -((-a + b - 1) / b);
}

/// The map's cells as scores over a window (occupied: the map value, free: -free_penalty,
/// unknown: 0), read from the map's tiles, and the same max-pooled into blocks of `factor` x
/// `factor` cells aligned at multiples of `factor` (a power of two).
class PooledWindow {
 public:
  /// The cells [x_min, x_max] x [y_min, y_max] (level 0), grown to whole blocks.
  PooledWindow(const GridMap& map, std::int32_t x_min, std::int32_t y_min, std::int32_t x_max,
               std::int32_t y_max, std::int32_t factor, float free_penalty);
  bool any_hit() const { return known_; }
  std::int32_t factor() const { return factor_; }
  /// The window's size in blocks.
  std::int32_t blocks_x() const { return bw_; }
  std::int32_t blocks_y() const { return bh_; }
  /// The first cell of the window (a multiple of the factor).
  std::int32_t x0() const { return x0_; }
  std::int32_t y0() const { return y0_; }
  /// The pooled value of block (bx, by), counted from the window's first; 0 outside.
  float block(std::int32_t bx, std::int32_t by) const {
    const bool inside = (bx >= 0) & (by >= 0) & (bx < bw_) & (by < bh_);
    return coarse_[inside ? static_cast<std::size_t>(by) * static_cast<std::size_t>(bw_) +
                                static_cast<std::size_t>(bx)
                          : coarse_.size() - 1];
  }
  /// The pooled value of the block holding level-0 cell (cx, cy); 0 outside.
  float coarse(std::int32_t cx, std::int32_t cy) const {
    return block(floor_div(cx - x0_, factor_), floor_div(cy - y0_, factor_));
  }
  /// The value of level-0 cell (cx, cy), read from the map (anywhere).
  float fine(std::int32_t cx, std::int32_t cy) const { return value(lookup_.score(cx, cy)); }
  /// Adds fine(cx + k, cy) to acc[k] for k in [0, count).
  void add_fine_row(std::int32_t cx, std::int32_t cy, std::size_t count, float* acc) const;

 private:
  float value(float score) const {
    return score > 0.0f ? score : (score == 0.0f ? -free_penalty_ : 0.0f);
  }

  GridMap::Lookup lookup_;
  float free_penalty_;
  std::int32_t factor_;
  std::int32_t x0_ = 0, y0_ = 0;
  std::int32_t bw_ = 0, bh_ = 0;
  std::vector<float> coarse_;  ///< bw_ x bh_ blocks, then one 0 for outside
  bool known_ = false;
};

/// out[(iy + n) * (2n + 1) + ix + n] = the sum over the end points j, in order from 0.0f, of
/// window.fine(floor(cx + px[j]) + ix, floor(cy + py[j]) + iy), for ix and iy in [-n, n]: the
/// scores of the positions (cx + ix, cy + iy) at full resolution, a row of cells per end point
/// and grid row.
void fine_sums(const PooledWindow& window, double cx, double cy, const float* px, const float* py,
               std::size_t count, int n, float* out);

/// Scores of the positions (cx + q ix, cy + q iy), ix and iy in [-n, n], q = factor / 2 cells
/// (cell coordinates, level 0). Its copy of the pooled blocks covers the window and 2n
/// half-blocks around it, whatever the end points' range.
class GridScorer {
 public:
  GridScorer(const PooledWindow& window, double cx, double cy, int n);
  /// The side of the grid, 2n + 1.
  std::size_t side() const { return side_; }
  /// out[(iy + n) * side() + ix + n] = the sum over the end points j, in order from 0.0f, of
  /// window.coarse(floor(cx + q ix + px[j]), floor(cy + q iy + py[j])). An end point that
  /// stays outside the window at every position adds nothing (its 0s are left out: adding
  /// +0.0f changes no sum started at +0.0f).
  void score(const float* px, const float* py, std::size_t count, float* out) const;

 private:
  const PooledWindow& window_;
  double cx_, cy_;
  int n_;
  std::size_t side_;
  std::int32_t u_lo_ = 0, u_hi_ = 0;  ///< half-block columns the copy holds
  std::int32_t v_lo_ = 0, v_hi_ = 0;  ///< half-block rows it holds
  std::int32_t b_lo_ = 0;             ///< the copy's first block row
  std::size_t width_ = 0;
  std::vector<float> rows_;  ///< block rows b_lo_.., each the blocks of columns u_lo_..u_hi_
};

/// A pose and its score (coarse or fine).
struct Scored {
  float score;
  Pose2 pose;
};

/// The `keep` best distinct poses of the scored grid (best first; ties by index): the greedy
/// pass over all scores sorted, on the fewest of the best that decide it. A pose is distinct
/// when no pose taken before lies within `dxy` and `dtheta` of it; only positive scores count.
template <class PoseOf>
std::vector<Scored> best_distinct(const std::vector<float>& scores, std::size_t keep, double dxy,
                                  double dtheta, PoseOf pose_of) {
  std::vector<std::uint32_t> order;
  for (std::size_t i = 0; i < scores.size(); ++i) {
    if (scores[i] > 0.0f) order.push_back(static_cast<std::uint32_t>(i));
  }
  const auto better = [&scores](std::uint32_t a, std::uint32_t b) {
    return scores[a] > scores[b] || (scores[a] == scores[b] && a < b);
  };
  std::vector<Scored> out;
  // The greedy pass over the best m decides as over all of them once it has `keep` poses; a
  // pass that has not reads 4 times as many, until it has read them all.
  for (std::size_t m = std::min(order.size(), std::max<std::size_t>(256, 8 * keep));;
       m = std::min(order.size(), 4 * m)) {
    // The best m in order (ties by index: the order is total, so these are the m a full sort
    // puts first).
    const auto mid = order.begin() + static_cast<std::ptrdiff_t>(m);
    if (mid != order.end()) std::nth_element(order.begin(), mid, order.end(), better);
    std::sort(order.begin(), mid, better);
    out.clear();
    for (std::size_t r = 0; r < m && out.size() < keep; ++r) {
      const Scored s{scores[order[r]], pose_of(order[r])};
      bool near = false;
      for (const Scored& o : out) {
        if (std::hypot(s.pose.x - o.pose.x, s.pose.y - o.pose.y) < dxy &&
            std::abs(normalize_angle(s.pose.theta - o.pose.theta)) < dtheta) {
          near = true;
          break;
        }
      }
      if (!near) out.push_back(s);
    }
    if (out.size() >= keep || m == order.size()) return out;
  }
}

}  // namespace esfleet::coarse_grid
