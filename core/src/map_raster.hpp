#pragma once
// Private to core: the map as the map images draw it (the grey level of each cell's class, the
// crop to the known cells). save_ros_map writes it as the PGM, save_map_png colours it; both are
// in ros_map_writer.cpp's terms, which defines these.

#include <cstdint>
#include <string>
#include <vector>

#include "esfleet/core/grid_map.hpp"
#include "esfleet/core/ros_map_format.hpp"

namespace esfleet::detail {

/// The map cropped to its known cells, one grey byte per cell, row 0 = the top (largest y).
struct Raster {
  int width = 1;
  int height = 1;
  CellIndex min{0, 0};  ///< cell of the bottom-left pixel
  std::int32_t max_y = 0;
  std::vector<std::uint8_t> grey;
  std::vector<std::uint8_t> known;  ///< 1 where hit + err > 0
};

/// `map` as a Raster, each cell in the level of its ros_cell_value under `th` (an empty map: one
/// unknown pixel). Throws std::invalid_argument for invalid thresholds
/// (OccupancyThresholds::validate) and std::runtime_error naming `path` (the file it is for)
/// when the crop exceeds kMaxMapImagePixels.
Raster render(const GridMap& map, const OccupancyThresholds& th, const std::string& path);

}  // namespace esfleet::detail
