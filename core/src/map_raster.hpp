#pragma once
// Private to core: the map as the map images draw it (grey levels per occupancy thresholds, the
// crop to the known cells). save_ros_map writes it as the PGM, save_map_png colours it; both are
// in ros_map_writer.cpp's terms, which defines these.

#include <cstdint>
#include <string>
#include <vector>

#include "esfleet/core/grid_map.hpp"
#include "esfleet/core/ros_map_format.hpp"

namespace esfleet::detail {

/// The grey levels of the classes under given thresholds (see save_ros_map).
struct GreyLevels {
  std::uint8_t occupied = 0;
  std::uint8_t free = 254;
  std::uint8_t unknown = 205;
  int between_lo = 90;  ///< levels [between_lo, between_hi] read back as unknown
  int between_hi = 205;
};

/// The levels for `th`. Throws std::invalid_argument when the thresholds are not
/// 0 < free < occupied < 1 or leave no level for a class.
GreyLevels grey_levels(const OccupancyThresholds& th);

/// The map cropped to its known cells, one grey byte per cell, row 0 = the top (largest y).
struct Raster {
  int width = 1;
  int height = 1;
  CellIndex min{0, 0};  ///< cell of the bottom-left pixel
  std::int32_t max_y = 0;
  std::vector<std::uint8_t> grey;
  std::vector<std::uint8_t> known;  ///< 1 where hit + err > 0
};

/// `map` as a Raster in the levels `g` of `th` (an empty map: one unknown pixel). Throws
/// std::runtime_error naming `path` (the file it is for) when the crop exceeds
/// kMaxMapImagePixels.
Raster render(const GridMap& map, const OccupancyThresholds& th, const GreyLevels& g,
              const std::string& path);

}  // namespace esfleet::detail
