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

/// The best positive scores offered, by score and then by index (lower first), in bounded
/// memory: once `capacity` are kept, a score that ranks below the worst kept is dropped, and
/// the kept ones are cut back to `capacity` whenever they reach twice that. What is kept is
/// always every offered score that ranks at or above the worst kept: a prefix of all of them
/// sorted.
class BestScores {
 public:
  struct Entry {
    float score;
    std::uint64_t index;
  };
  explicit BestScores(std::size_t capacity) : capacity_(std::max<std::size_t>(1, capacity)) {
    kept_.reserve(2 * capacity_);
  }
  /// Offers scores[k] with index first + k, k in [0, count), in any order of calls.
  void add(const float* scores, std::size_t count, std::uint64_t first) {
    for (std::size_t k = 0; k < count; ++k) {
      const float s = scores[k];
      if (!(s > bar_)) {
        if (!(s > 0.0f)) continue;
        if (!(s == bar_ && capped_ && first + k < bar_index_)) {
          dropped_ = true;
          continue;
        }
      }
      kept_.push_back({s, first + k});
      if (kept_.size() == 2 * capacity_) cut();
    }
  }
  /// How many are kept (less than twice the capacity).
  std::size_t size() const { return kept_.size(); }
  /// Whether a positive score offered is not kept.
  bool dropped() const { return dropped_; }
  /// The kept scores, best first.
  std::vector<Entry> sorted() const {
    std::vector<Entry> out = kept_;
    std::sort(out.begin(), out.end(), better);
    return out;
  }
  static bool better(const Entry& a, const Entry& b) {
    return a.score > b.score || (a.score == b.score && a.index < b.index);
  }

 private:
  void cut() {
    const auto last = kept_.begin() + static_cast<std::ptrdiff_t>(capacity_ - 1);
    std::nth_element(kept_.begin(), last, kept_.end(), better);
    bar_ = last->score;
    bar_index_ = last->index;
    kept_.resize(capacity_);
    capped_ = true;
    dropped_ = true;
  }

  std::size_t capacity_;
  std::vector<Entry> kept_;
  float bar_ = 0.0f;  ///< scores not above it are kept only when they rank above the worst kept
  std::uint64_t bar_index_ = 0;
  bool capped_ = false;
  bool dropped_ = false;
};

/// The `keep` best distinct poses of a scored grid (best first; ties by index): the greedy pass
/// over all positive scores sorted. A pose is distinct when no pose taken before lies within
/// `dxy` and `dtheta` of it. `score_all(BestScores&)` offers every score of the grid; it is
/// called again with 4 times the capacity while the best kept do not decide the pass (fewer
/// than `keep` distinct among them, and some dropped), so the memory follows how many decide
/// it, not the grid's size.
template <class ScoreAll, class PoseOf>
std::vector<Scored> best_distinct(ScoreAll score_all, std::size_t keep, double dxy, double dtheta,
                                  PoseOf pose_of, std::size_t capacity) {
  std::vector<Scored> out;
  for (;; capacity *= 4) {
    BestScores best(capacity);
    score_all(best);
    out.clear();
    for (const BestScores::Entry& e : best.sorted()) {
      if (out.size() >= keep) break;
      const Scored s{e.score, pose_of(e.index)};
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
    if (out.size() >= keep || !best.dropped()) return out;
  }
}

}  // namespace esfleet::coarse_grid
