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

}  // namespace esfleet
