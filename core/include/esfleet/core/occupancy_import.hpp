#pragma once
// A ROS occupancy map (ros_map_reader.hpp: cells -1 unknown, 0..100) as an esfleet GridMap of
// hit/err counters, e.g. to serve a map made by another SLAM (esfleet-leader --map map.yaml).
//
// Counters: a cell of value v in 0..100 gets hit = round(v / 20) (halves up) and
// err = kOccupancyCounts - hit, so its map value hit / (hit + err) is v / 100 as near as five
// counts allow: 100 -> (5, 0) occupied, 0 -> (0, 5) free, 50 -> (3, 2). An unknown cell (-1)
// stays empty (0, 0). Through ros_cell_value (default thresholds) the classes come back as
// they went in: 100 -> 100, 0 -> 0, -1 -> -1 (a value in between reads back as p = hit / 5).
//
// Placement: the cell size is the image's resolution. Pixel (col, row_from_bottom) has its
// centre at world (origin_x + (col + 0.5) * res, origin_y + (row + 0.5) * res) and becomes the
// cell containing that centre (GridMap::cell_of). When the origin is a whole number of cells
// every pixel is exactly one cell; otherwise the map moves by less than half a cell (`shift`),
// the same for every pixel (the cell of pixel (0, 0) is computed once and the others are
// counted from it, so no two pixels ever share a cell). The origin's yaw is not applied (as
// most ROS tools do): the caller may say so.

#include <cstdint>
#include <utility>

#include "esfleet/core/grid_map.hpp"
#include "esfleet/core/ros_map_reader.hpp"

namespace esfleet {

/// The counts a known imported cell holds: hit + err.
inline constexpr std::uint32_t kOccupancyCounts = 5;

/// The counters (hit, err) of a cell of ROS occupancy value `v`: (round(v / 20), 5 - hit) for
/// v in 0..100, (0, 0) for a negative (unknown) value. Throws std::invalid_argument for v > 100.
std::pair<std::uint32_t, std::uint32_t> occupancy_counters(int v);

/// Where an image's pixels land on a grid of cells of its resolution.
struct OccupancyPlacement {
  CellIndex first;  ///< the cell of pixel (0, 0), bottom-left; pixel (c, r) is first + (c, r)
  /// How far the map moves (metres): the centre of `first` minus the centre of pixel (0, 0),
  /// in (-res / 2, res / 2]; 0 (up to rounding) when the origin is a whole number of cells.
  double shift_x = 0.0;
  double shift_y = 0.0;
  double cell_size = 0.0;  ///< the image's resolution
  /// True when |shift| is within 1e-6 cells on both axes.
  bool aligned() const;
};

/// The placement of `image` (see the file comment). Throws std::invalid_argument for a
/// resolution that is not finite and > 0 or an origin that is not finite.
OccupancyPlacement occupancy_placement(const OccupancyImage& image);

/// The image as counters (see the file comment): `config` with cell_size = image.resolution
/// (its tile edge, tile range and pyramid as given). Only tiles with a known cell are created,
/// each at version 1, not marked dirty. Throws std::invalid_argument when the image's cells do
/// not number width * height, a cell value is above 100, the config is invalid, or a known
/// pixel lands outside the allowed tile range (naming the pixel).
GridMap grid_from_occupancy(const OccupancyImage& image, GridMapConfig config);

}  // namespace esfleet
