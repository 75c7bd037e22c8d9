#include "esfleet/core/window_search.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <vector>

namespace esfleet {

Pose2 window_pose(const SearchWindow& w, std::size_t index) {
  const int side = 2 * w.n_xy + 1;
  const auto n = static_cast<int>(index);
  const int it = n / (side * side) - w.n_theta, iy = (n / side) % side - w.n_xy,
            ix = n % side - w.n_xy;
  return {w.centre.x + ix * w.step_xy, w.centre.y + iy * w.step_xy,
          normalize_angle(w.centre.theta + it * w.step_theta)};
}

namespace {

/// A bound computed in float from values >= the scored ones may still round below a score
/// it bounds in real numbers: blocks are pruned only below bound * (1 + kSlack).
constexpr float kSlack = 1e-4f;

/// Pooled copies of the scorer's level: at level h, cell (x, y) holds, over the cells
/// [x, x + w_h) x [y, y + w_h) (w_h the cells a block of 2^h positions can put one end point
/// on), the largest non-negative score and whether every cell has err > 0; padded by
/// `pad` >= w_h cells on every side (0 there: unknown). One float a cell (the search's largest
/// allocation): its magnitude is the score, its sign bit clear when every cell has err > 0.
class BoundGrids {
 public:
  BoundGrids(const HeadingScorer& scorer, double cells_per_step, int levels, bool use_penalty)
      : use_penalty_(use_penalty) {
    const std::int32_t w0 = scorer.width(), h0 = scorer.height();
    std::vector<int> widths{1};
    for (int h = 1; h <= levels; ++h) {
      const double span = static_cast<double>((1 << h) - 1) * cells_per_step;
      widths.push_back(static_cast<int>(std::floor(span + 0.01)) + 2);
    }
    pad_ = widths.back();
    stride_ = w0 + 2 * pad_;
    rows_ = h0 + 2 * pad_;
    const std::size_t size = static_cast<std::size_t>(stride_) * static_cast<std::size_t>(rows_);
    std::vector<float> cur(size, cell(0.0f, false));
    for (std::int32_t y = 0; y < h0; ++y) {
      for (std::int32_t x = 0; x < w0; ++x) {
        const float v = scorer.cells()[static_cast<std::size_t>(y) * w0 + x];
        // The scorer's terms: sum of max(v, 0), n_hit v > 0, n_err 0 <= v < 1.
        cur[index(x, y)] = cell(std::max(v, 0.0f), (v >= 0.0f) & (v < 1.0f));
      }
    }
    grids_.emplace_back();  // level 0 is scored exactly
    int width = 1;
    auto pool = [](float& a, float b) {
      a = cell(std::max(std::abs(a), std::abs(b)), err(a) && err(b));
    };
    for (int h = 1; h <= levels; ++h) {
      // Widen [x, x + width) to [x, x + widths[h]) along x, then along y, by steps that at
      // most double it.
      while (width < widths[h]) {
        const int add = std::min(width, widths[h] - width);
        const std::size_t down = static_cast<std::size_t>(add) * stride_;
        for (std::size_t i = 0; i + down < size; ++i) pool(cur[i], cur[i + down]);
        for (std::int32_t y = 0; y < rows_; ++y) {
          float* row = cur.data() + static_cast<std::size_t>(y) * stride_;
          for (std::int32_t x = 0; x + add < stride_; ++x) pool(row[x], row[x + add]);
        }
        width += add;
      }
      grids_.push_back(cur);
    }
  }

  /// An upper bound of the fitness of every candidate of a level-h block whose first
  /// candidate puts end point j on column cols[j], row rows[j] of the scorer's level:
  /// sum <= the sum of the largest values; n_hit <= hits (a cell scores > 0 iff hit > 0);
  /// n_err >= errs; p_occ = n_hit / (n_hit + n_err) <= hits / (hits + errs).
  float bound(int h, const std::int32_t* cols, const std::int32_t* rows, std::size_t n) const {
    const float* grid = grids_[static_cast<std::size_t>(h)].data();
    // Beyond the padding every window is unknown, as at the padding's outer edge (pad >= w_h).
    const std::int32_t x_hi = stride_ - 1 - pad_, y_hi = rows_ - 1 - pad_;
    float sum = 0.0f, errs = 0.0f;
    std::int32_t hits = 0;
    for (std::size_t j = 0; j < n; ++j) {
      const std::int32_t x = std::clamp(cols[j], -pad_, x_hi) + pad_;
      const std::int32_t y = std::clamp(rows[j], -pad_, y_hi) + pad_;
      const float c = grid[static_cast<std::size_t>(y) * stride_ + static_cast<std::size_t>(x)];
      const float value = std::abs(c);
      sum += value;
      hits += value > 0.0f;
      errs += err(c) ? 1.0f : 0.0f;
    }
    if (!use_penalty_) return sum;
    const auto h_f = static_cast<float>(hits);
    return h_f + errs > 0.0f ? sum * h_f / (h_f + errs) : 0.0f;
  }

 private:
  /// `value` >= 0 with the sign bit set when not every cell has err > 0 (-0.0f included).
  static float cell(float value, bool every_err) { return every_err ? value : -value; }
  static bool err(float c) { return !std::signbit(c); }

  std::size_t index(std::int32_t x, std::int32_t y) const {
    return static_cast<std::size_t>(y + pad_) * stride_ + static_cast<std::size_t>(x + pad_);
  }
  bool use_penalty_;
  std::int32_t pad_ = 0, stride_ = 0, rows_ = 0;
  std::vector<std::vector<float>> grids_;
};

struct Block {
  float bound;
  int it, ix, iy, level;  ///< heading step, first position steps, 2^level positions per side
};

class Searcher {
 public:
  Searcher(HeadingScorer& scorer, const SearchWindow& w, double cells_per_step, int levels,
           double rival_distance, double rival_ratio, bool use_penalty)
      : scorer_(scorer),
        w_(w),
        side_(2 * w.n_xy + 1),
        grids_(scorer, cells_per_step, levels, use_penalty),
        levels_(levels),
        rival_distance_(rival_distance),
        rival_ratio_(rival_ratio),
        cols_(scorer.size()),
        rows_(scorer.size()) {}

  /// The best candidate (lowest index among equal scores); nullopt if none scores > 0.
  std::optional<WindowMatch> run() {
    std::vector<Block> roots = root_blocks();
    // The centre's position at every heading first (a loop closure's estimate is mostly near
    // the match): a high best early prunes more. The result is the same: blocks bounded at the
    // best are still searched, so a tie of lower index still wins.
    for (int it = -w_.n_theta; it <= w_.n_theta; ++it) {
      heading(it);
      leaf(Block{0.0f, it, 0, 0, 0}, false);
    }
    for (const Block& b : roots) {
      if (!(b.bound > 0.0f) || !may_hold_best(b)) continue;
      heading(b.it);
      descend(b, false);
    }
    if (!found_) return std::nullopt;
    WindowMatch m;
    m.score = best_;
    m.index = best_index_;
    m.pose = window_pose(w_, best_index_);
    best_pose_ = m.pose;
    for (const Block& b : roots) {
      if (rival_beyond_ratio()) break;
      if (!may_hold_rival(b)) continue;
      heading(b.it);
      descend(b, true);
    }
    m.rival = rival_;
    m.scored = scored_;
    m.bounded = bounded_;
    return m;
  }

 private:
  void heading(int it) {
    if (it == heading_) return;
    heading_ = it;
    scorer_.set_heading(normalize_angle(w_.centre.theta + it * w_.step_theta));
  }

  std::vector<Block> root_blocks() {
    std::vector<Block> roots;
    const int size = 1 << levels_;
    for (int it = -w_.n_theta; it <= w_.n_theta; ++it) {
      heading(it);
      for (int iy = -w_.n_xy; iy <= w_.n_xy; iy += size) {
        for (int ix = -w_.n_xy; ix <= w_.n_xy; ix += size) {
          Block b{0.0f, it, ix, iy, levels_};
          b.bound = bound(b);
          roots.push_back(b);
        }
      }
    }
    // Highest bound first; equal bounds in index order (the order does not change the result,
    // only how much is pruned).
    std::stable_sort(roots.begin(), roots.end(),
                     [](const Block& a, const Block& b) { return a.bound > b.bound; });
    return roots;
  }

  float bound(const Block& b) {
    ++bounded_;
    scorer_.columns(w_.centre.x + b.ix * w_.step_xy, cols_.data());
    scorer_.rows(w_.centre.y + b.iy * w_.step_xy, rows_.data());
    return grids_.bound(b.level, cols_.data(), rows_.data(), cols_.size());
  }

  std::size_t index_of(int it, int ix, int iy) const {
    return static_cast<std::size_t>(((it + w_.n_theta) * side_ + iy + w_.n_xy) * side_ + ix +
                                    w_.n_xy);
  }

  /// Whether block b may hold the best: a candidate scoring at least the best so far (a tie
  /// may have a lower index), or nothing found yet.
  bool may_hold_best(const Block& b) const {
    return !found_ || !(b.bound * (1.0f + kSlack) < best_);
  }

  /// A rival beyond rival_ratio_ decides the caller's question: the search for it stops.
  bool rival_beyond_ratio() const {
    return static_cast<double>(rival_) / static_cast<double>(best_) > rival_ratio_;
  }

  /// Whether block b may hold a candidate the rival's search needs: one outside the disk
  /// around the best, scoring above the rival so far and, with a finite rival_ratio_, beyond
  /// that ratio of the best (below it, the rival's exact value does not change the answer).
  bool may_hold_rival(const Block& b) const {
    const float upper = b.bound * (1.0f + kSlack);
    if (!(upper > rival_)) return false;
    if (rival_ratio_ < std::numeric_limits<double>::infinity() &&
        static_cast<double>(upper) / static_cast<double>(best_) <= rival_ratio_) {
      return false;
    }
    return !inside_rival_disk(b);
  }

  bool inside_rival_disk(const Block& b) const {
    const int last = (1 << b.level) - 1;
    const double x0 = w_.centre.x + b.ix * w_.step_xy - best_pose_.x;
    const double x1 = w_.centre.x + std::min(b.ix + last, w_.n_xy) * w_.step_xy - best_pose_.x;
    const double y0 = w_.centre.y + b.iy * w_.step_xy - best_pose_.y;
    const double y1 = w_.centre.y + std::min(b.iy + last, w_.n_xy) * w_.step_xy - best_pose_.y;
    const double far_x = std::max(std::abs(x0), std::abs(x1));
    const double far_y = std::max(std::abs(y0), std::abs(y1));
    // Every position closer than rival_distance (with a margin for rounding).
    return std::hypot(far_x, far_y) < rival_distance_ - 1e-9;
  }

  void leaf(const Block& b, bool rival) {
    ++scored_;
    const float score =
        scorer_.evaluate(w_.centre.x + b.ix * w_.step_xy, w_.centre.y + b.iy * w_.step_xy).fitness;
    const std::size_t i = index_of(b.it, b.ix, b.iy);
    if (rival) {
      const Pose2 c = window_pose(w_, i);
      if (std::hypot(c.x - best_pose_.x, c.y - best_pose_.y) > rival_distance_) {
        rival_ = std::max(rival_, score);
      }
      return;
    }
    if (!(score > 0.0f)) return;
    if (!found_ || score > best_ || (score == best_ && i < best_index_)) {
      found_ = true;
      best_ = score;
      best_index_ = i;
    }
  }

  void descend(const Block& b, bool rival) {
    if (b.level == 0) {
      leaf(b, rival);
      return;
    }
    const int half = 1 << (b.level - 1);
    Block children[4];
    int n = 0;
    for (const int dy : {0, half}) {
      for (const int dx : {0, half}) {
        if (b.ix + dx > w_.n_xy || b.iy + dy > w_.n_xy) continue;
        Block c{0.0f, b.it, b.ix + dx, b.iy + dy, b.level - 1};
        c.bound = c.level == 0 ? 0.0f : bound(c);
        children[n++] = c;
      }
    }
    if (b.level > 1) {
      std::stable_sort(children, children + n,
                       [](const Block& a, const Block& c) { return a.bound > c.bound; });
    }
    for (int k = 0; k < n; ++k) {
      const Block& c = children[k];
      if (rival && rival_beyond_ratio()) return;
      if (c.level > 0) {
        if (!(c.bound > 0.0f)) continue;
        if (!(rival ? may_hold_rival(c) : may_hold_best(c))) continue;
      }
      descend(c, rival);
    }
  }

  HeadingScorer& scorer_;
  SearchWindow w_;
  int side_;
  BoundGrids grids_;
  int levels_;
  double rival_distance_;
  double rival_ratio_;
  std::vector<std::int32_t> cols_, rows_;
  int heading_ = 0x7fffffff;
  bool found_ = false;
  float best_ = 0.0f;
  std::size_t best_index_ = 0;
  Pose2 best_pose_;
  float rival_ = 0.0f;
  std::size_t scored_ = 0, bounded_ = 0;
};

}  // namespace

std::optional<WindowMatch> search_window(const GridMap& map, const ScanPoints& points,
                                         const FitnessOptions& options, const SearchWindow& w,
                                         double rival_distance, double rival_ratio) {
  HeadingScorer scorer(map, points, options);
  const double cell = map.cell_size() * static_cast<double>(1 << options.level);
  // Root blocks of up to 32 x 32 positions; no larger than the window.
  int levels = 0;
  while (levels < 5 && (1 << levels) < 2 * w.n_xy + 1) ++levels;
  Searcher searcher(scorer, w, w.step_xy / cell, levels, rival_distance, rival_ratio,
                    options.use_penalty);
  return searcher.run();
}

}  // namespace esfleet
