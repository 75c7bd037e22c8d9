#include "esfleet/core/scan_points.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace esfleet {

int beam_fill_points(const LaserScan& scan, const BeamFill& fill) {
  const double step = std::abs(static_cast<double>(scan.angle_increment));
  const double max_step = fill.max_step_deg * std::numbers::pi / 180.0;
  // Relative tolerances: a 0.5 deg laser's increment, stored as a float, can be a hair over
  // 0.5 deg, and a 1 deg one a hair over twice it.
  if (!(max_step > 0.0) || !(step > max_step * (1.0 + 1e-6)) || !std::isfinite(step)) return 0;
  const double n = std::ceil(step / max_step - 1e-6) - 1.0;
  return static_cast<int>(std::clamp(n, 0.0, 64.0));
}

ScanPoints prepare_scan(const LaserScan& scan, float min_range, float max_range,
                        const BeamFill& fill) {
  ScanPoints p;
  const std::size_t n = scan.ranges.size();
  const int added = beam_fill_points(scan, fill);
  const std::size_t capacity = n * static_cast<std::size_t>(added + 1);
  p.x.reserve(capacity);
  p.y.reserve(capacity);
  p.range.reserve(capacity);
  auto add = [&p](float r, float a) {
    p.x.push_back(r * std::cos(a));
    p.y.push_back(r * std::sin(a));
    p.range.push_back(r);
  };
  const float no_return = std::min(scan.max_range, kMaxBeamRange);
  const float limit = max_range > 0.0f ? std::min(max_range, no_return) : no_return;
  bool previous_valid = false;  // beam i - 1 gave an end point
  for (std::size_t i = 0; i < n; ++i) {
    const bool was_valid = previous_valid;
    previous_valid = false;
    const float r = scan.ranges[i];
    if (!std::isfinite(r) || r < 0.0f) continue;
    const float a = scan.angle(i);
    if (r >= no_return) {
      p.no_return_angles.push_back(a);
      continue;
    }
    if (r < min_range || r >= limit) continue;
    if (added > 0 && was_valid) {
      const float r0 = scan.ranges[i - 1];
      if (std::abs(r - r0) <= fill.max_gap) {
        const float a0 = scan.angle(i - 1);
        for (int k = 1; k <= added; ++k) {
          const float f = static_cast<float>(k) / static_cast<float>(added + 1);
          add(r0 + f * (r - r0), a0 + f * (a - a0));
        }
      }
    }
    add(r, a);
    previous_valid = true;
  }
  return p;
}

ScanPoints thin_scan(const ScanPoints& points, double min_spacing) {
  if (!(min_spacing > 0.0)) return points;
  ScanPoints p;
  p.no_return_angles = points.no_return_angles;
  const double d2 = min_spacing * min_spacing;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!p.x.empty()) {
      const double dx = points.x[i] - p.x.back(), dy = points.y[i] - p.y.back();
      if (dx * dx + dy * dy < d2) continue;
    }
    p.x.push_back(points.x[i]);
    p.y.push_back(points.y[i]);
    p.range.push_back(points.range[i]);
  }
  return p;
}

}  // namespace esfleet
