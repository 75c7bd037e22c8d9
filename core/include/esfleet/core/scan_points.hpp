#pragma once
// A laser scan prepared for matching and mapping: the end points of the valid beams in the
// sensor frame, plus the directions of the no-return beams.

#include <vector>

#include "esfleet/core/laser_scan.hpp"

namespace esfleet {

struct ScanPoints {
  std::vector<float> x;  ///< valid beam end points, sensor frame, metres (x forward)
  std::vector<float> y;
  std::vector<float> range;             ///< range of each valid beam
  std::vector<float> no_return_angles;  ///< directions of no-return beams (radians)
  std::size_t size() const { return x.size(); }
};

/// Valid beams are those with min_range <= r < min(scan.max_range, max_range); max_range <= 0
/// means no extra limit. Readings at or beyond scan.max_range are no-return beams. Readings
/// below min_range are dropped. The reader has already rejected NaN/inf/negative ranges; any
/// that remain are dropped here too.
ScanPoints prepare_scan(const LaserScan& scan, float min_range = 0.0f, float max_range = 0.0f);

/// The end points in beam order, each kept only if it lies at least `min_spacing` metres from
/// the last one kept (the first is always kept); the no-return directions are copied as they
/// are. A point filter in scan order: where beams hit a near surface closer together than a
/// cell or two, most of them sample the same cells. min_spacing <= 0 keeps every point.
ScanPoints thin_scan(const ScanPoints& points, double min_spacing);

}  // namespace esfleet
