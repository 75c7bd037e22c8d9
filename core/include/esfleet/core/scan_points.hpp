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

/// End points added between adjacent beams of a laser coarser than `max_step_deg`, so that a
/// surface is sampled about as densely as by a finer one: between two adjacent valid beams
/// whose ranges differ by at most `max_gap` metres (one surface, not an edge), points at
/// evenly spaced angles in between with linearly interpolated ranges, as many as bring the
/// spacing to at most max_step_deg. max_step_deg <= 0 = off; a laser at least that fine gets
/// nothing added.
struct BeamFill {
  double max_step_deg = 0.0;
  double max_gap = 0.0;
};

/// How many end points `fill` adds between two adjacent beams of `scan` (0: off, or the laser
/// is at least max_step_deg fine; at most 64).
int beam_fill_points(const LaserScan& scan, const BeamFill& fill);

/// The farthest reading taken as an end point, whatever the scan's max_range says (metres): no
/// 2D laser measures a kilometre, and the map update walks a beam cell by cell (20 000 cells
/// of 5 cm per km). A scan message may declare any finite max_range: a hostile or broken one
/// with readings of 10 000 km made one scan's map update walk hundreds of millions of cells.
inline constexpr float kMaxBeamRange = 1000.0f;

/// Valid beams are those with min_range <= r < min(scan.max_range, max_range); max_range <= 0
/// means no extra limit. Readings at or beyond scan.max_range, or kMaxBeamRange, are no-return
/// beams. Readings below min_range are dropped. The reader has already rejected NaN/inf/negative
/// ranges; any that remain are dropped here too. End points are in beam order, filled per `fill`.
ScanPoints prepare_scan(const LaserScan& scan, float min_range = 0.0f, float max_range = 0.0f,
                        const BeamFill& fill = {});

/// The end points in beam order, each kept only if it lies at least `min_spacing` metres from
/// the last one kept (the first is always kept); the no-return directions are copied as they
/// are. A point filter in scan order: where beams hit a near surface closer together than a
/// cell or two, most of them sample the same cells. min_spacing <= 0 keeps every point.
ScanPoints thin_scan(const ScanPoints& points, double min_spacing);

}  // namespace esfleet
