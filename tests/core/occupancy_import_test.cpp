#include "esfleet/core/occupancy_import.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "esfleet/core/ros_map_format.hpp"
#include "esfleet/core/ros_map_reader.hpp"
#include "esfleet/core/ros_map_writer.hpp"
#include "map_files_fixture.hpp"

namespace esfleet {
namespace {

using testing::make_test_map;
using OccupancyImportFiles = testing::MapFilesTest;

/// A width x height image at `origin`, resolution `res`, all cells `fill`.
OccupancyImage image(int width, int height, double res, double ox, double oy,
                     std::int8_t fill = -1) {
  OccupancyImage im;
  im.resolution = res;
  im.origin_x = ox;
  im.origin_y = oy;
  im.width = width;
  im.height = height;
  im.cells.assign(static_cast<std::size_t>(width) * static_cast<std::size_t>(height), fill);
  return im;
}

void set(OccupancyImage& im, int col, int row, std::int8_t v) {
  im.cells[static_cast<std::size_t>(row) * static_cast<std::size_t>(im.width) +
           static_cast<std::size_t>(col)] = v;
}

TEST(OccupancyCounters, FiveCountsRoundedHalfUp) {
  using P = std::pair<std::uint32_t, std::uint32_t>;
  EXPECT_EQ(occupancy_counters(-1), (P{0, 0}));
  EXPECT_EQ(occupancy_counters(-128), (P{0, 0}));
  EXPECT_EQ(occupancy_counters(0), (P{0, 5}));
  EXPECT_EQ(occupancy_counters(9), (P{0, 5}));
  EXPECT_EQ(occupancy_counters(10), (P{1, 4}));  // 0.5 rounds up
  EXPECT_EQ(occupancy_counters(29), (P{1, 4}));
  EXPECT_EQ(occupancy_counters(30), (P{2, 3}));
  EXPECT_EQ(occupancy_counters(50), (P{3, 2}));
  EXPECT_EQ(occupancy_counters(67), (P{3, 2}));
  EXPECT_EQ(occupancy_counters(70), (P{4, 1}));
  EXPECT_EQ(occupancy_counters(90), (P{5, 0}));
  EXPECT_EQ(occupancy_counters(100), (P{5, 0}));
  EXPECT_THROW(occupancy_counters(101), std::invalid_argument);
  // The map value is v / 100 within half a count (0.1).
  for (int v = 0; v <= 100; ++v) {
    const auto [hit, err] = occupancy_counters(v);
    EXPECT_EQ(hit + err, kOccupancyCounts);
    EXPECT_LE(std::abs(static_cast<double>(hit) / 5.0 - v / 100.0), 0.1 + 1e-12) << v;
  }
}

TEST(GridFromOccupancy, ValuesBecomeCountersAndClassesSurvive) {
  // 3 x 2 at the world origin, 10 cm: bottom row 0 100 -1, top row 50 -1 20.
  OccupancyImage im = image(3, 2, 0.1, 0.0, 0.0);
  set(im, 0, 0, 0);
  set(im, 1, 0, 100);
  set(im, 0, 1, 50);
  set(im, 2, 1, 20);
  const GridMap map = grid_from_occupancy(im, GridMapConfig{.tile_edge = 8});
  EXPECT_EQ(map.cell_size(), 0.1);
  EXPECT_EQ(map.tile_edge(), 8);
  ASSERT_EQ(map.tile_count(), 1u);
  EXPECT_EQ(map.find_tile({0, 0})->version, 1u);
  EXPECT_EQ(map.hit({0, 0}), 0u);
  EXPECT_EQ(map.err({0, 0}), 5u);
  EXPECT_EQ(map.hit({1, 0}), 5u);
  EXPECT_EQ(map.err({1, 0}), 0u);
  EXPECT_EQ(map.hit({2, 0}) + map.err({2, 0}), 0u);  // unknown stays empty
  EXPECT_EQ(map.hit({0, 1}), 3u);
  EXPECT_EQ(map.err({0, 1}), 2u);
  EXPECT_EQ(map.hit({2, 1}), 1u);
  EXPECT_EQ(map.err({2, 1}), 4u);
  EXPECT_FLOAT_EQ(map.value({0, 1}), 0.6f);
  EXPECT_EQ(ros_cell_value(map.hit({0, 0}), map.err({0, 0})), 0);
  EXPECT_EQ(ros_cell_value(map.hit({1, 0}), map.err({1, 0})), 100);
  EXPECT_EQ(ros_cell_value(map.hit({2, 0}), map.err({2, 0})), -1);
  const GridMap::Bounds b = map.known_bounds();
  EXPECT_EQ(b.min, (CellIndex{0, 0}));
  EXPECT_EQ(b.max, (CellIndex{2, 1}));
}

TEST(GridFromOccupancy, OnlyTilesWithKnownCellsAreCreated) {
  OccupancyImage im = image(40, 20, 0.05, 0.0, 0.0);  // 8-cell tiles: 5 x 3 of them
  set(im, 3, 2, 100);
  set(im, 39, 19, 0);
  const GridMap map = grid_from_occupancy(im, GridMapConfig{.tile_edge = 8});
  EXPECT_EQ(map.tile_keys(), (std::vector<TileKey>{{0, 0}, {4, 2}}));
  EXPECT_EQ(grid_from_occupancy(image(4, 4, 0.05, 0, 0), {}).tile_count(), 0u);
}

TEST(GridFromOccupancy, WholeCellOriginsPlacePixelsExactly) {
  // Negative origin, a whole number of cells: pixel (c, r) is cell (-20 + c, -7 + r).
  OccupancyImage im = image(30, 10, 0.05, -1.0, -0.35);
  set(im, 0, 0, 100);
  set(im, 29, 9, 100);
  set(im, 20, 7, 0);
  const OccupancyPlacement p = occupancy_placement(im);
  EXPECT_EQ(p.first, (CellIndex{-20, -7}));
  EXPECT_TRUE(p.aligned()) << p.shift_x << " " << p.shift_y;
  const GridMap map = grid_from_occupancy(im, GridMapConfig{.tile_edge = 8});
  EXPECT_EQ(map.hit({-20, -7}), 5u);
  EXPECT_EQ(map.hit({9, 2}), 5u);
  EXPECT_EQ(map.err({0, 0}), 5u);
  const GridMap::Bounds b = map.known_bounds();
  EXPECT_EQ(b.min, (CellIndex{-20, -7}));
  EXPECT_EQ(b.max, (CellIndex{9, 2}));
  // Each pixel's centre lies in its cell (GridMap::cell_of).
  for (int col : {0, 20, 29}) {
    for (int row : {0, 7, 9}) {
      const CellIndex c = map.cell_of(im.origin_x + (col + 0.5) * im.resolution,
                                      im.origin_y + (row + 0.5) * im.resolution);
      EXPECT_EQ(c, (CellIndex{-20 + col, -7 + row}));
    }
  }
}

TEST(GridFromOccupancy, OffGridOriginsShiftByLessThanHalfACell) {
  // origin x = 0.02 (0.4 cell): pixel 0's centre 0.045 lies in cell 0 (centre 0.025): -0.02.
  // origin y = -0.03 (-0.6 cell): centre -0.005 in cell -1 (centre -0.025): -0.02.
  const OccupancyImage im = image(2, 2, 0.05, 0.02, -0.03, 100);
  const OccupancyPlacement p = occupancy_placement(im);
  EXPECT_FALSE(p.aligned());
  EXPECT_EQ(p.first, (CellIndex{0, -1}));
  EXPECT_NEAR(p.shift_x, -0.02, 1e-12);
  EXPECT_NEAR(p.shift_y, -0.02, 1e-12);
  // 0.7 cell: the centre (1.2 cells) is in cell 1; the map moves +0.3 cell.
  const OccupancyPlacement q = occupancy_placement(image(1, 1, 0.1, 0.07, -0.07));
  EXPECT_EQ(q.first, (CellIndex{1, -1}));
  EXPECT_NEAR(q.shift_x, 0.03, 1e-12);
  EXPECT_NEAR(q.shift_y, -0.03, 1e-12);
  const GridMap map = grid_from_occupancy(im, GridMapConfig{.tile_edge = 8});
  EXPECT_EQ(map.known_bounds().min, (CellIndex{0, -1}));
  EXPECT_EQ(map.known_bounds().max, (CellIndex{1, 0}));
}

TEST(GridFromOccupancy, RefusesBadImages) {
  OccupancyImage short_cells = image(3, 3, 0.05, 0, 0);
  short_cells.cells.pop_back();
  EXPECT_THROW(grid_from_occupancy(short_cells, {}), std::invalid_argument);
  OccupancyImage too_high = image(1, 1, 0.05, 0, 0);
  too_high.cells[0] = 101;
  EXPECT_THROW(grid_from_occupancy(too_high, {}), std::invalid_argument);
  EXPECT_THROW(grid_from_occupancy(image(1, 1, 0.0, 0, 0), {}), std::invalid_argument);
  // 64-cell tiles of 5 cm, +-1024 tiles: +-3.3 km. A known pixel 10 km out is refused...
  try {
    grid_from_occupancy(image(1, 1, 0.05, 10000.0, 0.0, 0), {});
    ADD_FAILURE() << "no throw";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("pixel (0, 0"), std::string::npos) << e.what();
  }
  // ... an unknown one there is not a cell at all.
  EXPECT_EQ(grid_from_occupancy(image(1, 1, 0.05, 10000.0, 0.0), {}).tile_count(), 0u);
}

TEST_F(OccupancyImportFiles, RoundTripThroughSaveRosMapKeepsEveryClass) {
  const GridMap original = make_test_map();
  save_ros_map(original, dir_.string(), "map");
  const OccupancyImage im = load_ros_map(path("map.yaml"));
  EXPECT_TRUE(occupancy_placement(im).aligned());
  const GridMap back = grid_from_occupancy(im, GridMapConfig{.tile_edge = 8});
  EXPECT_EQ(back.cell_size(), original.cell_size());
  const GridMap::Bounds b = original.known_bounds();
  int compared = 0;
  for (std::int32_t y = b.min.y - 2; y <= b.max.y + 2; ++y) {
    for (std::int32_t x = b.min.x - 2; x <= b.max.x + 2; ++x) {
      const CellIndex c{x, y};
      EXPECT_EQ(ros_cell_value(back.hit(c), back.err(c)),
                ros_cell_value(original.hit(c), original.err(c)))
          << "cell " << x << ", " << y;
      ++compared;
    }
  }
  EXPECT_EQ(compared, 18 * 16);
}

}  // namespace
}  // namespace esfleet
