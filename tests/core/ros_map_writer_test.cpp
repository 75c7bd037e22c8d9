#include "esfleet/core/ros_map_writer.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "esfleet/core/ros_map_reader.hpp"
#include "map_files_fixture.hpp"

namespace esfleet {
namespace {

using testing::add;
using testing::make_test_map;
using RosMapWriterTest = testing::MapFilesTest;
namespace fs = std::filesystem;

/// key -> raw value text of a flat "key: value" YAML file.
std::map<std::string, std::string> yaml_fields(const std::string& text) {
  std::map<std::string, std::string> out;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    const auto colon = line.find(": ");
    if (colon != std::string::npos) out[line.substr(0, colon)] = line.substr(colon + 2);
  }
  return out;
}

/// Parses "[a, b, c]".
std::vector<double> parse_list(const std::string& s) {
  std::vector<double> v;
  if (s.empty() || s.front() != '[' || s.back() != ']') return v;
  std::istringstream in(s.substr(1, s.size() - 2));
  std::string item;
  while (std::getline(in, item, ',')) v.push_back(std::strtod(item.c_str(), nullptr));
  return v;
}

struct PgmImage {
  std::string header;
  int width = 0, height = 0;
  std::string pixels;
  int at(int col, int row_from_top) const {
    return static_cast<unsigned char>(pixels[static_cast<std::size_t>(row_from_top * width + col)]);
  }
};

/// Splits a "P5\n<w> <h>\n255\n" file (the exact header save_ros_map writes).
PgmImage split_pgm(const std::string& bytes) {
  PgmImage img;
  std::istringstream in(bytes);
  std::string magic;
  int maxval = 0;
  in >> magic >> img.width >> img.height >> maxval;
  const auto raster = static_cast<std::size_t>(in.tellg()) + 1;
  img.header = bytes.substr(0, raster);
  img.pixels = bytes.substr(raster);
  return img;
}

/// Every (hit, err) pair of `pairs` in its own cell of a map: cell (i % 64, i / 64).
GridMap map_of_pairs(const std::vector<std::pair<int, int>>& pairs) {
  GridMap map(GridMapConfig{.cell_size = 0.05, .tile_edge = 16});
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    add(map, {static_cast<std::int32_t>(i % 64), static_cast<std::int32_t>(i / 64)}, pairs[i].first,
        pairs[i].second);
  }
  map.commit_update();
  return map;
}

/// hit and err 0..40 each, and a few large counts near the default thresholds.
std::vector<std::pair<int, int>> many_pairs() {
  std::vector<std::pair<int, int>> pairs;
  for (int h = 0; h <= 40; ++h) {
    for (int e = 0; e <= 40; ++e) pairs.emplace_back(h, e);
  }
  for (const auto& pe : {std::pair{49, 201},
                         {98, 402},
                         {1000, 4102},
                         {1000, 4103},
                         {2, 1000},
                         {3000, 1},
                         {1, 3000}}) {
    pairs.push_back(pe);
  }
  return pairs;
}

// --- ros_cell_value ----------------------------------------------------------------------------

TEST(RosCellValue, DefaultsMakeCellsThatStoppedBeamsRepeatedlyOccupied) {
  struct Case {
    std::uint64_t hit, err;
    int value;
  };
  const Case cases[] = {
      {0, 0, -1},         // never observed
      {0, 1, 0},          // a beam passed through
      {0, 1000, 0},       //
      {1, 0, -1},         // one return only: not a wall yet, not free
      {1, 1, -1},         // p = 0.5, one hit
      {1, 4, -1},         // p = 0.2, one hit
      {1, 5, 0},          // p = 0.167: free
      {2, 0, 100},        // two returns, nothing passed
      {2, 8, 100},        // p = 0.2: a grazed wall
      {2, 9, 0},          // p = 0.18: free
      {49, 201, 0},       // p = 0.196 exactly: free
      {50, 150, 100},     // p = 0.25 (the old rule: unknown)
      {13, 7, 100},       // p = 0.65
      {1000, 4102, 100},  // p = 0.19600157
      {1000, 4103, 0},    // p = 0.19596
  };
  for (const Case& c : cases) {
    EXPECT_EQ(ros_cell_value(c.hit, c.err), c.value) << "hit " << c.hit << " err " << c.err;
  }
}

TEST(RosCellValue, ThresholdsAreConfigurable) {
  const OccupancyThresholds th{.occupied = 0.5, .min_hits = 1, .free = 0.1};
  EXPECT_EQ(ros_cell_value(1, 0, th), 100);
  EXPECT_EQ(ros_cell_value(1, 1, th), -1);  // p = 0.5 is not above 0.5
  EXPECT_EQ(ros_cell_value(2, 1, th), 100);
  EXPECT_EQ(ros_cell_value(1, 8, th), -1);  // p = 0.111
  EXPECT_EQ(ros_cell_value(1, 9, th), 0);   // p = 0.1
  EXPECT_EQ(ros_cell_value(0, 0, th), -1);
  const OccupancyThresholds three{.min_hits = 3};
  EXPECT_EQ(ros_cell_value(2, 0, three), -1);
  EXPECT_EQ(ros_cell_value(3, 0, three), 100);
}

TEST(RosCellValue, ValidateNamesTheBadField) {
  const auto message = [](const OccupancyThresholds& th) {
    try {
      th.validate();
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no exception");
  };
  EXPECT_NO_THROW(OccupancyThresholds{}.validate());
  EXPECT_NE(message({.occupied = 1.0}).find("occupied"), std::string::npos);
  EXPECT_NE(message({.occupied = -0.1, .free = 0.0}).find("occupied"), std::string::npos);
  EXPECT_NE(message({.min_hits = 0}).find("min_hits"), std::string::npos);
  EXPECT_NE(message({.occupied = 0.3, .free = 0.5}).find("free"), std::string::npos);
  EXPECT_NE(message({.free = std::numeric_limits<double>::quiet_NaN()}).find("free"),
            std::string::npos);
}

// --- save_ros_map ------------------------------------------------------------------------------

TEST_F(RosMapWriterTest, PgmHasExactHeaderAndPixels) {
  const GridMap map = make_test_map();
  save_ros_map(map, dir_.string());
  const PgmImage pgm = split_pgm(slurp(path("map.pgm")));
  EXPECT_EQ(pgm.header, "P5\n14 12\n255\n");
  ASSERT_EQ(pgm.pixels.size(), 14u * 12u);
  // Pixel (col, row from top) of cell (x, y): (x + 9, 5 - y).
  EXPECT_EQ(pgm.at(0, 0), 0);      // (-9, 5) occupied
  EXPECT_EQ(pgm.at(0, 11), 0);     // (-9, -6) p = 0.2, two hits
  EXPECT_EQ(pgm.at(13, 11), 254);  // (4, -6) free
  EXPECT_EQ(pgm.at(13, 0), 254);   // (4, 5) p = 0.196
  EXPECT_EQ(pgm.at(9, 5), 205);    // (0, 0) p = 0.5, one hit
  EXPECT_EQ(pgm.at(11, 2), 205);   // (2, 3) p = 1, one hit
  EXPECT_EQ(pgm.at(8, 6), 254);    // (-1, -1) p = 0.1
  EXPECT_EQ(pgm.at(12, 3), 0);     // (3, 2) p = 0.25
  EXPECT_EQ(pgm.at(10, 4), 205);   // (1, 1) never observed
  EXPECT_EQ(pgm.at(6, 9), 254);    // (-3, -4) on the free row
  EXPECT_EQ(pgm.at(5, 9), 205);    // (-4, -4) just left of it
}

TEST_F(RosMapWriterTest, YamlHasMapServerFields) {
  const GridMap map = make_test_map();
  save_ros_map(map, path("out/nested"), "floor_1");  // creates the directories
  const auto f = yaml_fields(slurp(path("out/nested/floor_1.yaml")));
  EXPECT_EQ(f.at("image"), "floor_1.pgm");
  EXPECT_EQ(f.at("mode"), "trinary");
  EXPECT_EQ(f.at("negate"), "0");
  EXPECT_EQ(std::strtod(f.at("resolution").c_str(), nullptr), 0.05);
  EXPECT_EQ(std::strtod(f.at("occupied_thresh").c_str(), nullptr), 0.65);
  EXPECT_EQ(std::strtod(f.at("free_thresh").c_str(), nullptr), 0.196);
  const std::vector<double> origin = parse_list(f.at("origin"));
  ASSERT_EQ(origin.size(), 3u);
  // Lower-left corner of the bottom-left pixel, cell (-9, -6), to the last bit.
  EXPECT_EQ(origin[0], -9 * 0.05);
  EXPECT_EQ(origin[1], -6 * 0.05);
  EXPECT_EQ(origin[2], 0.0);
  EXPECT_TRUE(fs::exists(path("out/nested/floor_1.pgm")));
  // Only the two files: no temporary left behind.
  EXPECT_EQ(std::distance(fs::directory_iterator(path("out/nested")), fs::directory_iterator()), 2);
}

TEST_F(RosMapWriterTest, LoadReadsBackClassesOriginAndResolution) {
  const GridMap map = make_test_map();
  save_ros_map(map, dir_.string());
  const OccupancyImage img = load_ros_map(path("map.yaml"));
  ASSERT_EQ(img.width, 14);
  ASSERT_EQ(img.height, 12);
  EXPECT_EQ(img.resolution, 0.05);
  EXPECT_EQ(img.origin_x, -9 * 0.05);
  EXPECT_EQ(img.origin_y, -6 * 0.05);
  EXPECT_EQ(img.origin_theta, 0.0);
  EXPECT_EQ(img.at(0, 11), 100);  // (-9, 5): row_from_bottom = y + 6
  EXPECT_EQ(img.at(0, 0), 100);   // (-9, -6): p = 0.2, two hits
  EXPECT_EQ(img.at(13, 0), 0);    // (4, -6)
  EXPECT_EQ(img.at(9, 6), -1);    // (0, 0): one hit
  EXPECT_EQ(img.at(10, 7), -1);   // (1, 1) unknown
  EXPECT_EQ(img.at(-1, 0), -1);   // outside
  EXPECT_EQ(img.at(0, 12), -1);
  for (int y = -6; y <= 5; ++y) {
    for (int x = -9; x <= 4; ++x) {
      ASSERT_EQ(img.at(x + 9, y + 6), ros_cell_value(map.hit({x, y}), map.err({x, y})))
          << "cell " << x << "," << y;
    }
  }
}

class RosMapRoundTripTest : public testing::MapFilesTest {
 protected:
  /// Saves `pairs` under `th`, loads the map as map_server does and checks every cell reads back
  /// as ros_cell_value, in one of the three levels, with the ROS-standard YAML thresholds.
  void expect_round_trip(const std::string& dir, const std::vector<std::pair<int, int>>& pairs,
                         const OccupancyThresholds& th) {
    const GridMap map = map_of_pairs(pairs);
    save_ros_map(map, dir, "map", th);
    const OccupancyImage img = load_ros_map(dir + "/map.yaml");
    const PgmImage pgm = split_pgm(slurp(dir + "/map.pgm"));
    std::map<int, int> seen;  // value -> count
    for (std::size_t i = 0; i < pairs.size(); ++i) {
      const CellIndex c{static_cast<std::int32_t>(i % 64), static_cast<std::int32_t>(i / 64)};
      const auto [h, e] = pairs[i];
      const int want =
          ros_cell_value(static_cast<std::uint64_t>(h), static_cast<std::uint64_t>(e), th);
      // Pixel of cell (x, y): column x - min.x, row from the bottom y - min.y; min = (0, 0).
      ASSERT_EQ(img.at(c.x, c.y), want) << "hit " << h << " err " << e;
      const int level = pgm.at(c.x, img.height - 1 - c.y);
      ASSERT_EQ(level, want == 100 ? 0 : want == 0 ? 254 : 205) << "hit " << h << " err " << e;
      ++seen[want];
    }
    EXPECT_EQ(seen.size(), 3u);  // all three classes were exercised
  }
};

TEST_F(RosMapRoundTripTest, EveryLevelReadsBackAsRosCellValue) {
  expect_round_trip(path("default"), many_pairs(), {});
  expect_round_trip(path("custom"), many_pairs(), {.occupied = 0.5, .min_hits = 1, .free = 0.1});
  expect_round_trip(path("strict"), many_pairs(), {.occupied = 0.65, .min_hits = 5, .free = 0.0});
  // Whatever the thresholds, the YAML keeps map_server's defaults.
  const auto f = yaml_fields(slurp(path("custom/map.yaml")));
  EXPECT_EQ(std::strtod(f.at("occupied_thresh").c_str(), nullptr), 0.65);
  EXPECT_EQ(std::strtod(f.at("free_thresh").c_str(), nullptr), 0.196);
}

TEST_F(RosMapWriterTest, RejectsBadThresholdsAndNames) {
  const GridMap map = make_test_map();
  EXPECT_THROW(save_ros_map(map, dir_.string(), "map", {.occupied = 0.3, .free = 0.5}),
               std::invalid_argument);
  EXPECT_THROW(save_ros_map(map, dir_.string(), "map", {.occupied = 1.0, .free = 0.2}),
               std::invalid_argument);
  EXPECT_THROW(save_ros_map(map, dir_.string(), "map", {.min_hits = 0}), std::invalid_argument);
  EXPECT_THROW(save_ros_map(map, dir_.string(), "map",
                            {.occupied = 0.65, .free = std::numeric_limits<double>::quiet_NaN()}),
               std::invalid_argument);
  EXPECT_THROW(save_ros_map(map, dir_.string(), ""), std::invalid_argument);
  EXPECT_THROW(save_ros_map(map, dir_.string(), "a/b"), std::invalid_argument);
  EXPECT_THROW(save_ros_map(map, dir_.string(), "x: y"), std::invalid_argument);
  EXPECT_TRUE(fs::is_empty(dir_));
}

TEST_F(RosMapWriterTest, EmptyMapSavesOneUnknownPixel) {
  const GridMap map;
  save_ros_map(map, dir_.string());
  EXPECT_EQ(slurp(path("map.pgm")), std::string("P5\n1 1\n255\n\xcd", 12));  // 0xcd = 205
  const OccupancyImage img = load_ros_map(path("map.yaml"));
  ASSERT_EQ(img.width, 1);
  ASSERT_EQ(img.height, 1);
  EXPECT_EQ(img.at(0, 0), -1);
  EXPECT_EQ(img.origin_x, 0.0);
  EXPECT_EQ(img.origin_y, 0.0);
}

TEST_F(RosMapWriterTest, SaveIntoAFileInsteadOfADirectoryThrowsNamingIt) {
  write_bytes("blocker", "x");
  try {
    save_ros_map(make_test_map(), path("blocker"));
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(path("blocker")), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace esfleet
