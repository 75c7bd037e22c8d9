#include "esfleet/core/occupancy_import.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <vector>

namespace esfleet {
namespace {

/// floor(v / res) as GridMap::cell_of computes it (clamped the same way).
std::int64_t cell_coord(double v, double res) {
  constexpr double kLimit = 1e9;
  return static_cast<std::int64_t>(std::clamp(std::floor(v / res), -kLimit, kLimit));
}

/// The tile's counters while the image is read.
struct TileBuffer {
  std::vector<std::uint32_t> hit;
  std::vector<std::uint32_t> err;
};

}  // namespace

std::pair<std::uint32_t, std::uint32_t> occupancy_counters(int v) {
  if (v < 0) return {0, 0};
  if (v > 100) {
    throw std::invalid_argument("occupancy value " + std::to_string(v) + " is above 100");
  }
  const auto hit = static_cast<std::uint32_t>((v + 10) / 20);  // round(v / 20), halves up
  return {hit, kOccupancyCounts - hit};
}

bool OccupancyPlacement::aligned() const {
  const double tolerance = 1e-6 * cell_size;
  return std::abs(shift_x) <= tolerance && std::abs(shift_y) <= tolerance;
}

OccupancyPlacement occupancy_placement(const OccupancyImage& image) {
  const double res = image.resolution;
  if (!std::isfinite(res) || !(res > 0.0)) {
    throw std::invalid_argument("resolution must be finite and > 0, got " + std::to_string(res));
  }
  if (!std::isfinite(image.origin_x) || !std::isfinite(image.origin_y)) {
    throw std::invalid_argument("origin must be finite");
  }
  const double cx = image.origin_x + 0.5 * res;  // centre of pixel (0, 0)
  const double cy = image.origin_y + 0.5 * res;
  OccupancyPlacement p;
  const std::int64_t x = cell_coord(cx, res);
  const std::int64_t y = cell_coord(cy, res);
  p.first = {static_cast<std::int32_t>(x), static_cast<std::int32_t>(y)};
  p.shift_x = (static_cast<double>(x) + 0.5) * res - cx;
  p.shift_y = (static_cast<double>(y) + 0.5) * res - cy;
  p.cell_size = res;
  return p;
}

GridMap grid_from_occupancy(const OccupancyImage& image, GridMapConfig config) {
  if (image.width < 0 || image.height < 0 ||
      image.cells.size() !=
          static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height)) {
    throw std::invalid_argument("occupancy image of " + std::to_string(image.width) + "x" +
                                std::to_string(image.height) + " pixels has " +
                                std::to_string(image.cells.size()) + " cells");
  }
  const OccupancyPlacement place = occupancy_placement(image);
  config.cell_size = image.resolution;
  config.validate();
  GridMap map(config);
  const std::int32_t edge = config.tile_edge;
  const int shift = std::countr_zero(static_cast<unsigned>(edge));
  std::unordered_map<TileKey, TileBuffer, TileKeyHash> tiles;
  TileKey last_key{};
  TileBuffer* last = nullptr;
  for (int row = 0; row < image.height; ++row) {
    for (int col = 0; col < image.width; ++col) {
      const std::int8_t v =
          image.cells[static_cast<std::size_t>(row) * static_cast<std::size_t>(image.width) +
                      static_cast<std::size_t>(col)];
      if (v < 0) continue;
      const auto [hit, err] = occupancy_counters(v);
      const std::int64_t x = std::int64_t{place.first.x} + col;
      const std::int64_t y = std::int64_t{place.first.y} + row;
      const std::int64_t limit = std::int64_t{config.max_tile_coord + 1} * edge;
      if (x < -limit || x >= limit || y < -limit || y >= limit ||
          !map.key_in_range(TileKey{static_cast<std::int32_t>(x >> shift),
                                    static_cast<std::int32_t>(y >> shift)})) {
        throw std::invalid_argument("pixel (" + std::to_string(col) + ", " + std::to_string(row) +
                                    " from the bottom) lands in cell (" + std::to_string(x) + ", " +
                                    std::to_string(y) + "), outside the map's +-" +
                                    std::to_string(config.max_tile_coord) + " tiles of " +
                                    std::to_string(edge) + " cells (origin too far from 0?)");
      }
      const CellIndex c{static_cast<std::int32_t>(x), static_cast<std::int32_t>(y)};
      const TileKey key = map.tile_of(c);
      if (last == nullptr || !(key == last_key)) {
        auto [it, added] = tiles.try_emplace(key);
        if (added) {
          it->second.hit.assign(map.cells_per_tile(), 0);
          it->second.err.assign(map.cells_per_tile(), 0);
        }
        last = &it->second;
        last_key = key;
      }
      const auto i = static_cast<std::size_t>((c.y & (edge - 1)) * edge + (c.x & (edge - 1)));
      last->hit[i] = hit;
      last->err[i] = err;
    }
  }
  for (const auto& [key, t] : tiles) map.set_tile(key, 1, t.hit, t.err);
  return map;
}

}  // namespace esfleet
