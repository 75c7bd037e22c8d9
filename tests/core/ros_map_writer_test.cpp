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

/// The class map_server should give a cell after a save/load round trip (trinary).
int expected_class(const GridMap& map, CellIndex c, const OccupancyThresholds& th) {
  const double h = map.hit(c), e = map.err(c);
  if (h + e == 0) return -1;
  const double p = h / (h + e);
  if (p >= th.occupied) return 100;
  if (p <= th.free) return 0;
  return -1;
}

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

// --- save_ros_map ------------------------------------------------------------------------------

TEST_F(RosMapWriterTest, PgmHasExactHeaderAndPixels) {
  const GridMap map = make_test_map();
  save_ros_map(map, dir_.string());
  const PgmImage pgm = split_pgm(slurp(path("map.pgm")));
  EXPECT_EQ(pgm.header, "P5\n14 12\n255\n");
  ASSERT_EQ(pgm.pixels.size(), 14u * 12u);
  // Pixel (col, row from top) of cell (x, y): (x + 9, 5 - y).
  EXPECT_EQ(pgm.at(0, 0), 0);      // (-9, 5) occupied
  EXPECT_EQ(pgm.at(0, 11), 0);     // (-9, -6) p = 0.65
  EXPECT_EQ(pgm.at(13, 11), 254);  // (4, -6) free
  EXPECT_EQ(pgm.at(13, 0), 254);   // (4, 5) p = 0.196
  EXPECT_EQ(pgm.at(9, 5), 128);    // (0, 0) p = 0.5
  EXPECT_EQ(pgm.at(11, 2), 90);    // (2, 3) clamped off the occupied levels
  EXPECT_EQ(pgm.at(8, 6), 204);    // (-1, -1) kept off the unknown level
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
  EXPECT_EQ(img.at(13, 0), 0);    // (4, -6)
  EXPECT_EQ(img.at(11, 9), -1);   // (2, 3): p = 0.6495 is not occupied
  EXPECT_EQ(img.at(10, 7), -1);   // (1, 1) unknown
  EXPECT_EQ(img.at(-1, 0), -1);   // outside
  EXPECT_EQ(img.at(0, 12), -1);
  const OccupancyThresholds th;
  for (int y = -6; y <= 5; ++y) {
    for (int x = -9; x <= 4; ++x) {
      ASSERT_EQ(img.at(x + 9, y + 6), expected_class(map, {x, y}, th)) << "cell " << x << "," << y;
    }
  }
}

TEST_F(RosMapWriterTest, CustomThresholdsMoveTheUnknownLevelAndStillRoundTrip) {
  const GridMap map = make_test_map();
  // 205 reads as free under free_thresh 0.3, so unknown must move into 52..178 (51 reads
  // exactly 0.8: too close to call).
  const OccupancyThresholds th{.occupied = 0.8, .free = 0.3};
  save_ros_map(map, dir_.string(), "map", th);
  const PgmImage pgm = split_pgm(slurp(path("map.pgm")));
  EXPECT_EQ(pgm.at(10, 4), 178);  // (1, 1) unknown
  const OccupancyImage img = load_ros_map(path("map.yaml"));
  for (int y = -6; y <= 5; ++y) {
    for (int x = -9; x <= 4; ++x) {
      ASSERT_EQ(img.at(x + 9, y + 6), expected_class(map, {x, y}, th)) << "cell " << x << "," << y;
    }
  }
}

TEST_F(RosMapWriterTest, RejectsBadThresholdsAndNames) {
  const GridMap map = make_test_map();
  EXPECT_THROW(save_ros_map(map, dir_.string(), "map", {.occupied = 0.3, .free = 0.5}),
               std::invalid_argument);
  EXPECT_THROW(save_ros_map(map, dir_.string(), "map", {.occupied = 1.0, .free = 0.2}),
               std::invalid_argument);
  EXPECT_THROW(save_ros_map(map, dir_.string(), "map",
                            {.occupied = 0.65, .free = std::numeric_limits<double>::quiet_NaN()}),
               std::invalid_argument);
  // No grey level x has 0.5 <= 1 - x / 255 <= 0.501.
  EXPECT_THROW(save_ros_map(map, dir_.string(), "map", {.occupied = 0.501, .free = 0.5}),
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
