#include "esfleet/core/fitness.hpp"

#include <algorithm>
#include <cmath>

namespace esfleet {

FitnessEvaluator::FitnessEvaluator(const GridMap& map, const ScanPoints& points, bool use_penalty,
                                   int level, int stride, bool interpolate)
    : lookup_(map.lookup(level)),
      inv_cell_(1.0 / (map.cell_size() * static_cast<double>(1 << level))),
      use_penalty_(use_penalty),
      interpolate_(interpolate) {
  const auto step = static_cast<std::size_t>(std::max(stride, 1));
  px_.reserve(points.size() / step + 1);
  py_.reserve(points.size() / step + 1);
  for (std::size_t i = 0; i < points.size(); i += step) {
    px_.push_back(static_cast<float>(points.x[i] * inv_cell_));
    py_.push_back(static_cast<float>(points.y[i] * inv_cell_));
  }
}

namespace {
inline std::int32_t fast_floor(float v) {
  const auto i = static_cast<std::int32_t>(v);
  return i - static_cast<std::int32_t>(v < static_cast<float>(i));
}
}  // namespace

FitnessValue FitnessEvaluator::evaluate(const Pose2& pose) const {
  FitnessValue out;
  const double ox = pose.x * inv_cell_, oy = pose.y * inv_cell_;
  // A candidate far outside any possible map (or not finite) scores zero rather than
  // overflowing the cell index conversion.
  constexpr double kFar = 1e8;
  if (!(std::abs(ox) < kFar && std::abs(oy) < kFar && std::isfinite(pose.theta))) return out;
  const auto c = static_cast<float>(std::cos(pose.theta));
  const auto s = static_cast<float>(std::sin(pose.theta));
  const auto fx = static_cast<float>(ox), fy = static_cast<float>(oy);
  float sum = 0.0f;
  std::int32_t n_hit = 0, n_err = 0;
  const std::size_t n = px_.size();
  for (std::size_t i = 0; i < n; ++i) {
    const float wx = fx + c * px_[i] - s * py_[i];
    const float wy = fy + s * px_[i] + c * py_[i];
    const std::int32_t ix = fast_floor(wx), iy = fast_floor(wy);
    const float v = lookup_.score(ix, iy);
    if (interpolate_) {
      // Bilinear over the four cell centres around the point (map values, unknown = 0).
      const float gx = wx - 0.5f, gy = wy - 0.5f;
      const std::int32_t x0 = fast_floor(gx), y0 = fast_floor(gy);
      const float ax = gx - static_cast<float>(x0), ay = gy - static_cast<float>(y0);
      auto val = [&](std::int32_t x, std::int32_t y) { return std::max(lookup_.score(x, y), 0.0f); };
      sum += (1 - ay) * ((1 - ax) * val(x0, y0) + ax * val(x0 + 1, y0)) +
             ay * ((1 - ax) * val(x0, y0 + 1) + ax * val(x0 + 1, y0 + 1));
    } else {
      sum += v > 0.0f ? v : 0.0f;
    }
    n_hit += v > 0.0f;
    n_err += (v >= 0.0f) & (v < 1.0f);
  }
  out.sum_map = sum;
  out.n_hit = n_hit;
  out.n_err = n_err;
  out.n_points = static_cast<std::int32_t>(n);
  out.p_occ = n_hit + n_err > 0 ? static_cast<float>(n_hit) / static_cast<float>(n_hit + n_err)
                                : 0.0f;
  out.fitness = use_penalty_ ? out.p_occ * sum : sum;
  return out;
}

}  // namespace esfleet
