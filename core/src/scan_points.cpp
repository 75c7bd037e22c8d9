#include "esfleet/core/scan_points.hpp"

#include <cmath>
#include <limits>

namespace esfleet {

ScanPoints prepare_scan(const LaserScan& scan, float min_range, float max_range) {
  ScanPoints p;
  const std::size_t n = scan.ranges.size();
  p.x.reserve(n);
  p.y.reserve(n);
  p.range.reserve(n);
  const float limit = max_range > 0.0f ? std::min(max_range, scan.max_range) : scan.max_range;
  for (std::size_t i = 0; i < n; ++i) {
    const float r = scan.ranges[i];
    if (!std::isfinite(r) || r < 0.0f) continue;
    const float a = scan.angle(i);
    if (r >= scan.max_range) {
      p.no_return_angles.push_back(a);
      continue;
    }
    if (r < min_range || r >= limit) continue;
    p.x.push_back(r * std::cos(a));
    p.y.push_back(r * std::sin(a));
    p.range.push_back(r);
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
