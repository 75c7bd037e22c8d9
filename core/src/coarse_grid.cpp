#include "coarse_grid.hpp"

#include <algorithm>
#include <cmath>

namespace esfleet::coarse_grid {

PooledWindow::PooledWindow(const GridMap& map, std::int32_t x_min, std::int32_t y_min,
                           std::int32_t x_max, std::int32_t y_max, std::int32_t factor,
                           float free_penalty)
    : lookup_(map.lookup(0)), free_penalty_(free_penalty), factor_(factor) {
  const std::int32_t bx0 = floor_div(x_min, factor);
  const std::int32_t by0 = floor_div(y_min, factor);
  bw_ = floor_div(x_max, factor) - bx0 + 1;
  bh_ = floor_div(y_max, factor) - by0 + 1;
  x0_ = bx0 * factor;
  y0_ = by0 * factor;
  coarse_.assign(static_cast<std::size_t>(bw_) * static_cast<std::size_t>(bh_) + 1, -free_penalty);
  coarse_.back() = 0.0f;  // outside the window: unknown
  const std::int32_t w = bw_ * factor, h = bh_ * factor;
  const GridMap::Lookup::Addressing a = lookup_.addressing();
  for (std::int32_t y = 0; y < h; ++y) {
    float* brow = coarse_.data() + static_cast<std::size_t>(y / factor) * bw_;
    // A row of the window is read a tile row at a time.
    for (std::int32_t x = 0; x < w;) {
      const std::int32_t cx = x0_ + x, cy = y0_ + y;
      const std::int32_t span = std::min(a.mask + 1 - (cx & a.mask), w - x);
      const float* cells = lookup_.tile(a.slot(cx, cy)) + a.offset(cx, cy);
      for (std::int32_t k = 0; k < span; ++k, ++x) {
        const float score = cells[k];
        float& b = brow[x / factor];
        b = std::max(b, value(score));
        known_ |= score > 0.0f;
      }
    }
  }
}

void PooledWindow::add_fine_row(std::int32_t cx, std::int32_t cy, std::size_t count,
                                float* acc) const {
  const GridMap::Lookup::Addressing a = lookup_.addressing();
  if (static_cast<std::size_t>(cx & a.mask) + count <= static_cast<std::size_t>(a.mask) + 1) {
    // Within one tile row: contiguous.
    const float* cells = lookup_.tile(a.slot(cx, cy)) + a.offset(cx, cy);
    for (std::size_t k = 0; k < count; ++k) acc[k] += value(cells[k]);
  } else {
    for (std::size_t k = 0; k < count; ++k) acc[k] += fine(cx + static_cast<std::int32_t>(k), cy);
  }
}

void fine_sums(const PooledWindow& window, double cx, double cy, const float* px, const float* py,
               std::size_t count, int n, float* out) {
  const auto side = static_cast<std::size_t>(2 * n + 1);
  std::fill(out, out + side * side, 0.0f);
  for (std::size_t j = 0; j < count; ++j) {
    const auto x = static_cast<std::int32_t>(std::floor(cx + px[j])) - n;
    const auto y = static_cast<std::int32_t>(std::floor(cy + py[j])) - n;
    for (std::size_t iy = 0; iy < side; ++iy) {
      window.add_fine_row(x, y + static_cast<std::int32_t>(iy), side, out + iy * side);
    }
  }
}

GridScorer::GridScorer(const PooledWindow& window, double cx, double cy, int n)
    : window_(window), cx_(cx), cy_(cy), n_(n), side_(static_cast<std::size_t>(2 * n + 1)) {
  // An end point's run of 2n + 1 half-blocks that meets the window (half-blocks [0, 2 bw))
  // lies within it and 2n around it.
  const std::int32_t pad = 2 * n;
  u_lo_ = -pad;
  u_hi_ = 2 * window.blocks_x() - 1 + pad;
  v_lo_ = -pad;
  v_hi_ = 2 * window.blocks_y() - 1 + pad;
  b_lo_ = floor_div(v_lo_, 2);
  const std::int32_t b_hi = floor_div(v_hi_, 2);
  width_ = static_cast<std::size_t>(u_hi_ - u_lo_ + 1);
  rows_.resize(static_cast<std::size_t>(b_hi - b_lo_ + 1) * width_);
  float* out = rows_.data();
  for (std::int32_t b = b_lo_; b <= b_hi; ++b) {
    for (std::int32_t u = u_lo_; u <= u_hi_; ++u) *out++ = window.block(floor_div(u, 2), b);
  }
}

void GridScorer::score(const float* px, const float* py, std::size_t count, float* out) const {
  const std::size_t side = side_;
  std::fill(out, out + side * side, 0.0f);
  for (std::size_t j = 0; j < count; ++j) {
    // The half-block under end point j at grid position (-n, -n); grid step (ix, iy) moves it
    // by (ix, iy) half-blocks, and half-block (u, v) lies in block (u / 2, v / 2).
    const double ax = (cx_ + px[j] - window_.x0()) / (0.5 * window_.factor());
    const double ay = (cy_ + py[j] - window_.y0()) / (0.5 * window_.factor());
    // A run that stays outside the window (or a coordinate too large for an int): only 0s.
    if (!(ax >= u_lo_ + n_ && ax < u_hi_ - n_ + 1.0 && ay >= v_lo_ + n_ && ay < v_hi_ - n_ + 1.0)) {
      continue;
    }
    const std::int32_t hx = static_cast<std::int32_t>(std::floor(ax)) - n_;
    const std::int32_t hy = static_cast<std::int32_t>(std::floor(ay)) - n_;
    const float* first = rows_.data() + static_cast<std::size_t>(hx - u_lo_);
    for (std::size_t iy = 0; iy < side; ++iy) {
      const std::int32_t b = floor_div(hy + static_cast<std::int32_t>(iy), 2) - b_lo_;
      const float* row = first + static_cast<std::size_t>(b) * width_;
      float* acc = out + iy * side;
      for (std::size_t k = 0; k < side; ++k) acc[k] += row[k];
    }
  }
}

}  // namespace esfleet::coarse_grid
