#include "esfleet/core/fitness.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace esfleet {

namespace {

/// Every stride-th end point in cell units (the evaluators' copy of the scan).
void scale_points(const ScanPoints& points, double inv_cell, int stride, std::vector<float>& px,
                  std::vector<float>& py) {
  const auto step = static_cast<std::size_t>(std::max(stride, 1));
  px.reserve(points.size() / step + 1);
  py.reserve(points.size() / step + 1);
  for (std::size_t i = 0; i < points.size(); i += step) {
    px.push_back(static_cast<float>(points.x[i] * inv_cell));
    py.push_back(static_cast<float>(points.y[i] * inv_cell));
  }
}

inline std::int32_t fast_floor(float v) {
  const auto i = static_cast<std::int32_t>(v);
  return i - static_cast<std::int32_t>(v < static_cast<float>(i));
}

// Beams are processed in blocks: a vectorisable pass computes every cell address, a scalar
// pass loads the scores, a vectorisable pass accumulates. Keeps the dependent loads apart
// from the arithmetic so the CPU overlaps them.
constexpr std::size_t kBlock = 64;

/// The per-cell terms summed in four lanes by end point index modulo 4 (a fixed summation
/// order the compiler can vectorise), then the lanes in order.
struct Lanes {
  alignas(16) float sum[4] = {0, 0, 0, 0};
  alignas(16) std::int32_t hit[4] = {0, 0, 0, 0};
  alignas(16) std::int32_t err[4] = {0, 0, 0, 0};
  alignas(16) std::int32_t known[4] = {0, 0, 0, 0};

  /// Adds the scores value[0, m); value has room for m rounded up to 4: the padding is set to
  /// unknown cells, which add nothing.
  void add(float* value, std::size_t m) {
    const std::size_t m4 = (m + 3) & ~std::size_t{3};
    for (std::size_t j = m; j < m4; ++j) value[j] = kUnknownScore;
    for (std::size_t j = 0; j < m4; j += 4) {
      for (std::size_t l = 0; l < 4; ++l) {
        const float v = value[j + l];
        sum[l] += v > 0.0f ? v : 0.0f;
        hit[l] += v > 0.0f;
        err[l] += (v >= 0.0f) & (v < 1.0f);
        known[l] += v >= 0.0f;
      }
    }
  }
  /// Adds the lanes into the totals, lane 0 first.
  void total(float& s, std::int32_t& n_hit, std::int32_t& n_err, std::int32_t& n_known) const {
    for (std::size_t l = 0; l < 4; ++l) {
      s += sum[l];
      n_hit += hit[l];
      n_err += err[l];
      n_known += known[l];
    }
  }
};

/// The fitness terms from the totals over n end points.
void finish(FitnessValue& out, float sum, std::int32_t n_hit, std::int32_t n_err,
            std::int32_t n_known, std::size_t n, bool use_penalty) {
  out.sum_map = sum;
  out.n_hit = n_hit;
  out.n_err = n_err;
  out.n_known = n_known;
  out.n_points = static_cast<std::int32_t>(n);
  out.p_occ =
      n_hit + n_err > 0 ? static_cast<float>(n_hit) / static_cast<float>(n_hit + n_err) : 0.0f;
  out.fitness = use_penalty ? out.p_occ * sum : sum;
}

}  // namespace

FitnessEvaluator::FitnessEvaluator(const GridMap& map, const ScanPoints& points,
                                   FitnessOptions options)
    : lookup_(map.lookup(options.level)),
      inv_cell_(1.0 / (map.cell_size() * static_cast<double>(1 << options.level))),
      options_(options) {
  scale_points(points, inv_cell_, options.stride, px_, py_);
}

FitnessValue FitnessEvaluator::evaluate(const Pose2& pose) const {
  FitnessValue out;
  const double ox = pose.x * inv_cell_, oy = pose.y * inv_cell_;
  if (beyond_any_map(ox, oy) || !std::isfinite(pose.theta)) return out;
  const auto c = static_cast<float>(std::cos(pose.theta));
  const auto s = static_cast<float>(std::sin(pose.theta));
  const auto fx = static_cast<float>(ox), fy = static_cast<float>(oy);
  const float* px = px_.data();
  const float* py = py_.data();
  const std::size_t n = px_.size();
  const GridMap::Lookup::Addressing map = lookup_.addressing();
  const GridMap::Lookup& tiles = lookup_;

  alignas(32) std::int32_t slot[kBlock];
  alignas(32) std::int32_t offset[kBlock];
  alignas(32) std::int32_t cell_x[kBlock];
  alignas(32) std::int32_t cell_y[kBlock];
  alignas(32) float value[kBlock];
  alignas(32) float frac_x[kBlock];
  alignas(32) float frac_y[kBlock];
  alignas(32) float v00[kBlock], v10[kBlock], v01[kBlock], v11[kBlock];
  const std::int32_t edge = std::int32_t{1} << map.shift;
  float sum = 0.0f;
  std::int32_t n_hit = 0, n_err = 0, n_known = 0;
  Lanes lanes;

  for (std::size_t base = 0; base < n; base += kBlock) {
    const std::size_t m = std::min(kBlock, n - base);
    if (!options_.interpolate) {
      for (std::size_t j = 0; j < m; ++j) {
        const float wx = fx + c * px[base + j] - s * py[base + j];
        const float wy = fy + s * px[base + j] + c * py[base + j];
        const std::int32_t ix = fast_floor(wx), iy = fast_floor(wy);
        slot[j] = map.slot(ix, iy);
        offset[j] = map.offset(ix, iy);
      }
      for (std::size_t j = 0; j < m; ++j) value[j] = tiles.tile(slot[j])[offset[j]];
      lanes.add(value, m);
      continue;
    }
    // Bilinear: the four cells whose centres surround the point. The point's own cell (for
    // the penalty counts) is one of them. Unless the 2x2 block straddles a tile border (about
    // 3 % of the beams with 64-cell tiles), all four cells are in one tile: one directory
    // look-up and four loads from one address (q, q + 1, q + edge, q + edge + 1).
    for (std::size_t j = 0; j < m; ++j) {
      const float gx = fx + c * px[base + j] - s * py[base + j] - 0.5f;
      const float gy = fy + s * px[base + j] + c * py[base + j] - 0.5f;
      const std::int32_t x0 = fast_floor(gx), y0 = fast_floor(gy);
      frac_x[j] = gx - static_cast<float>(x0);
      frac_y[j] = gy - static_cast<float>(y0);
      cell_x[j] = x0;
      cell_y[j] = y0;
      const bool straddles = ((x0 & map.mask) == map.mask) | ((y0 & map.mask) == map.mask);
      slot[j] = straddles ? -1 : map.slot(x0, y0);
      offset[j] = map.offset(x0, y0);
    }
    for (std::size_t j = 0; j < m; ++j) {
      if (slot[j] >= 0) {
        const float* q = tiles.tile(slot[j]) + offset[j];
        v00[j] = q[0];
        v10[j] = q[1];
        v01[j] = q[edge];
        v11[j] = q[edge + 1];
      } else {
        const std::int32_t x0 = cell_x[j], y0 = cell_y[j];
        v00[j] = tiles.tile(map.slot(x0, y0))[map.offset(x0, y0)];
        v10[j] = tiles.tile(map.slot(x0 + 1, y0))[map.offset(x0 + 1, y0)];
        v01[j] = tiles.tile(map.slot(x0, y0 + 1))[map.offset(x0, y0 + 1)];
        v11[j] = tiles.tile(map.slot(x0 + 1, y0 + 1))[map.offset(x0 + 1, y0 + 1)];
      }
    }
    for (std::size_t j = 0; j < m; ++j) {
      const float ax = frac_x[j], ay = frac_y[j];
      const float a00 = std::max(v00[j], 0.0f), a10 = std::max(v10[j], 0.0f);
      const float a01 = std::max(v01[j], 0.0f), a11 = std::max(v11[j], 0.0f);
      value[j] = (1.0f - ay) * ((1.0f - ax) * a00 + ax * a10) + ay * ((1.0f - ax) * a01 + ax * a11);
      const float v = ay >= 0.5f ? (ax >= 0.5f ? v11[j] : v01[j]) : (ax >= 0.5f ? v10[j] : v00[j]);
      n_hit += v > 0.0f;
      n_err += (v >= 0.0f) & (v < 1.0f);
      n_known += v >= 0.0f;
    }
    // Summed in beam order, one at a time: the result does not depend on the block layout.
    for (std::size_t j = 0; j < m; ++j) sum += value[j];
  }
  lanes.total(sum, n_hit, n_err, n_known);
  finish(out, sum, n_hit, n_err, n_known, n, options_.use_penalty);
  return out;
}

HeadingScorer::HeadingScorer(const GridMap& map, const ScanPoints& points, FitnessOptions options)
    : options_(options),
      inv_cell_(1.0 / (map.cell_size() * static_cast<double>(1 << options.level))) {
  if (options.interpolate) {
    throw std::invalid_argument("HeadingScorer: interpolation is not supported");
  }
  const GridMap::Lookup lookup = map.lookup(options.level);  // throws for a level not kept
  const GridMap::Lookup::Addressing a = lookup.addressing();
  const std::int32_t edge = std::int32_t{1} << a.shift;
  x0_ = a.tx0 * edge;
  y0_ = a.ty0 * edge;
  width_ = a.width * edge;
  height_ = a.height * edge;
  // One more cell at the end: the unknown sentinel every end point outside reads.
  cells_.assign(static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_) + 1,
                kUnknownScore);
  for (std::int32_t ty = 0; ty < a.height; ++ty) {
    for (std::int32_t tx = 0; tx < a.width; ++tx) {
      const float* tile = lookup.tile((ty << a.stride_shift) + tx);
      for (std::int32_t ly = 0; ly < edge; ++ly) {
        float* row = cells_.data() + static_cast<std::size_t>(ty * edge + ly) * width_ + tx * edge;
        for (std::int32_t lx = 0; lx < edge; ++lx) row[lx] = tile[(ly << a.shift) | lx];
      }
    }
  }
  scale_points(points, inv_cell_, options.stride, px_, py_);
  cpx_.resize(px_.size());
  spy_.resize(px_.size());
  spx_.resize(px_.size());
  cpy_.resize(px_.size());
}

void HeadingScorer::set_heading(double theta) {
  heading_ok_ = std::isfinite(theta);
  if (!heading_ok_) return;
  // The products FitnessEvaluator::evaluate forms per end point, rounded to float the same way.
  const auto c = static_cast<float>(std::cos(theta));
  const auto s = static_cast<float>(std::sin(theta));
  for (std::size_t j = 0; j < px_.size(); ++j) {
    cpx_[j] = c * px_[j];
    spy_[j] = s * py_[j];
    spx_[j] = s * px_[j];
    cpy_[j] = c * py_[j];
  }
}

FitnessValue HeadingScorer::evaluate(double x, double y) const {
  FitnessValue out;
  const double ox = x * inv_cell_, oy = y * inv_cell_;
  if (beyond_any_map(ox, oy) || !heading_ok_) return out;
  const auto fx = static_cast<float>(ox), fy = static_cast<float>(oy);
  const std::size_t n = px_.size();
  const float* cells = cells_.data();
  const auto outside = static_cast<std::int32_t>(cells_.size() - 1);  // the unknown sentinel
  // The evaluator's blocks and summation order.
  alignas(32) std::int32_t index[kBlock];
  alignas(32) float value[kBlock];
  Lanes lanes;
  for (std::size_t base = 0; base < n; base += kBlock) {
    const std::size_t m = std::min(kBlock, n - base);
    for (std::size_t j = 0; j < m; ++j) {
      const float wx = fx + cpx_[base + j] - spy_[base + j];
      const float wy = fy + spx_[base + j] + cpy_[base + j];
      const std::int32_t ix = fast_floor(wx) - x0_, iy = fast_floor(wy) - y0_;
      const bool inside = (ix >= 0) & (ix < width_) & (iy >= 0) & (iy < height_);
      index[j] = inside ? iy * width_ + ix : outside;
    }
    for (std::size_t j = 0; j < m; ++j) value[j] = cells[index[j]];
    lanes.add(value, m);
  }
  float sum = 0.0f;
  std::int32_t n_hit = 0, n_err = 0, n_known = 0;
  lanes.total(sum, n_hit, n_err, n_known);
  finish(out, sum, n_hit, n_err, n_known, n, options_.use_penalty);
  return out;
}

void HeadingScorer::columns(double x, std::int32_t* out) const {
  const auto fx = static_cast<float>(x * inv_cell_);
  for (std::size_t j = 0; j < px_.size(); ++j) out[j] = fast_floor(fx + cpx_[j] - spy_[j]) - x0_;
}

void HeadingScorer::rows(double y, std::int32_t* out) const {
  const auto fy = static_cast<float>(y * inv_cell_);
  for (std::size_t j = 0; j < px_.size(); ++j) out[j] = fast_floor(fy + spx_[j] + cpy_[j]) - y0_;
}

Flattest flattest_direction(const FitnessEvaluator& eval, const Pose2& p, double f0, double step) {
  auto f = [&](double dx, double dy) {
    return static_cast<double>(eval.fitness({p.x + dx, p.y + dy, p.theta}));
  };
  const double h = step;
  // N = -Hessian = [[a, b], [b, d]]; its eigenvalues and the smaller one's eigenvector.
  const double a = -(f(h, 0) + f(-h, 0) - 2 * f0) / (h * h);
  const double d = -(f(0, h) + f(0, -h) - 2 * f0) / (h * h);
  const double b = -(f(h, h) - f(h, -h) - f(-h, h) + f(-h, -h)) / (4 * h * h);
  const double mean = (a + d) / 2, spread = std::hypot((a - d) / 2, b);
  const double lmin = mean - spread, lmax = mean + spread;
  Flattest out;
  out.curved = lmax > 0.0;
  out.ratio = lmax > 0.0 ? std::max(lmin, 0.0) / lmax : 0.0;
  double vx = lmin - d, vy = b;  // (N - lmin I) v = 0
  if (std::hypot(vx, vy) < 1e-12) {
    vx = a <= d ? 1.0 : 0.0;
    vy = a <= d ? 0.0 : 1.0;
  }
  const double n = std::hypot(vx, vy);
  out.vx = vx / n;
  out.vy = vy / n;
  return out;
}

}  // namespace esfleet
