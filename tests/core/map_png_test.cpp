#include "esfleet/core/map_png.hpp"

#include <gtest/gtest.h>
#include <zlib.h>  // linked through esfleet_core (static, zlib private): decodes the test PNGs

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <string>
#include <vector>

#include "esfleet/core/ros_map_reader.hpp"
#include "esfleet/core/ros_map_writer.hpp"
#include "map_files_fixture.hpp"

namespace esfleet {
namespace {

using testing::add;
using testing::make_test_map;
using MapPngTest = testing::MapFilesTest;
namespace fs = std::filesystem;

// --- A minimal PNG reader for 8-bit RGB, non-interlaced (what save_map_png writes) ---

std::uint32_t be32(const std::string& d, std::size_t at) {
  std::uint32_t v = 0;
  for (std::size_t i = 0; i < 4; ++i) v = (v << 8) | static_cast<unsigned char>(d[at + i]);
  return v;
}

struct RgbImage {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;
  std::array<int, 3> at(int col, int row) const {
    const auto i = (static_cast<std::size_t>(row) * static_cast<std::size_t>(width) +
                    static_cast<std::size_t>(col)) *
                   3;
    return {rgb[i], rgb[i + 1], rgb[i + 2]};
  }
};

int paeth(int a, int b, int c) {
  const int p = a + b - c, pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
  if (pa <= pb && pa <= pc) return a;
  return pb <= pc ? b : c;
}

/// Decodes an RGB PNG; fails the test (and returns an empty image) on anything else.
RgbImage decode_rgb_png(const std::string& bytes) {
  RgbImage img;
  const std::string signature("\x89PNG\r\n\x1a\n", 8);
  EXPECT_EQ(bytes.substr(0, 8), signature);
  std::string idat;
  std::size_t pos = 8;
  while (pos + 12 <= bytes.size()) {
    const std::uint32_t len = be32(bytes, pos);
    const std::string type = bytes.substr(pos + 4, 4);
    if (type == "IHDR") {
      img.width = static_cast<int>(be32(bytes, pos + 8));
      img.height = static_cast<int>(be32(bytes, pos + 12));
      EXPECT_EQ(bytes[pos + 16], 8) << "bit depth";
      EXPECT_EQ(bytes[pos + 17], 2) << "colour type RGB";
      EXPECT_EQ(bytes[pos + 20], 0) << "interlace";
    } else if (type == "IDAT") {
      idat += bytes.substr(pos + 8, len);
    } else if (type == "IEND") {
      break;
    }
    pos += 12 + len;
  }
  const std::size_t stride = static_cast<std::size_t>(img.width) * 3;
  std::vector<Bytef> raw((stride + 1) * static_cast<std::size_t>(img.height));
  uLongf raw_len = static_cast<uLongf>(raw.size());
  const int z = uncompress(raw.data(), &raw_len, reinterpret_cast<const Bytef*>(idat.data()),
                           static_cast<uLong>(idat.size()));
  if (z != Z_OK || raw_len != raw.size()) {
    ADD_FAILURE() << "PNG data does not inflate to " << raw.size() << " bytes";
    return {};
  }
  img.rgb.assign(stride * static_cast<std::size_t>(img.height), 0);
  for (std::size_t r = 0; r < static_cast<std::size_t>(img.height); ++r) {
    const int filter = raw[r * (stride + 1)];
    const Bytef* in = &raw[r * (stride + 1) + 1];
    std::uint8_t* out = &img.rgb[r * stride];
    const std::uint8_t* up = r > 0 ? &img.rgb[(r - 1) * stride] : nullptr;
    for (std::size_t i = 0; i < stride; ++i) {
      const int a = i >= 3 ? out[i - 3] : 0;
      const int b = up ? up[i] : 0;
      const int c = (up && i >= 3) ? up[i - 3] : 0;
      int pred = 0;
      switch (filter) {
        case 0:
          pred = 0;
          break;
        case 1:
          pred = a;
          break;
        case 2:
          pred = b;
          break;
        case 3:
          pred = (a + b) / 2;
          break;
        case 4:
          pred = paeth(a, b, c);
          break;
        default:
          ADD_FAILURE() << "bad PNG filter " << filter;
          return {};
      }
      out[i] = static_cast<std::uint8_t>((in[i] + pred) & 0xff);
    }
  }
  return img;
}

// --- save_map_png ------------------------------------------------------------------------------

/// 20 x 10 cells of 0.1 m at x 0..19, y 0..9: free, column x = 19 occupied (two hits each),
/// (5, 8) unknown.
GridMap make_room() {
  GridMap map(GridMapConfig{.cell_size = 0.1, .tile_edge = 8});
  for (int y = 0; y <= 9; ++y) {
    for (int x = 0; x <= 19; ++x) {
      if (x == 5 && y == 8) continue;
      if (x == 19) {
        map.add_hit({x, y});
        map.add_hit({x, y});
      } else {
        map.add_err({x, y});
      }
    }
  }
  return map;
}

TimedPose at(double t, double x, double y) { return {t, {x, y, 0.0}}; }

using Rgb = std::array<int, 3>;
constexpr Rgb kRed{255, 0, 0}, kGreen{0, 255, 0}, kBlue{0, 0, 255};

TEST_F(MapPngTest, PngShowsMapTrajectoryAndMarkers) {
  const GridMap map = make_room();
  // Cells (2, 2) -> (12, 2) -> (12, 8); pixel (col, row) = (x, 9 - y).
  const std::vector<TimedPose> traj = {at(0, 0.25, 0.25), at(1, 1.25, 0.25), at(2, 1.25, 0.85)};
  save_map_png(map, traj, path("map.png"));
  const std::string bytes = slurp(path("map.png"));
  ASSERT_GT(bytes.size(), 33u);
  EXPECT_EQ(bytes.substr(12, 4), "IHDR");
  EXPECT_EQ(be32(bytes, 16), 20u);
  EXPECT_EQ(be32(bytes, 20), 10u);
  const RgbImage img = decode_rgb_png(bytes);
  ASSERT_EQ(img.width, 20);
  ASSERT_EQ(img.height, 10);
  EXPECT_EQ(img.at(15, 8), (Rgb{254, 254, 254}));  // free
  EXPECT_EQ(img.at(19, 5), (Rgb{0, 0, 0}));        // occupied
  EXPECT_EQ(img.at(5, 1), (Rgb{190, 205, 220}));   // unknown tint
  EXPECT_EQ(img.at(7, 7), kRed);                   // first segment, away from the markers
  EXPECT_EQ(img.at(12, 7), kRed);                  // the corner
  EXPECT_EQ(img.at(12, 5), kRed);                  // second segment
  EXPECT_EQ(img.at(7, 6), (Rgb{254, 254, 254}));   // beside the line: 1 px wide
  EXPECT_EQ(img.at(2, 7), kGreen);                 // start
  EXPECT_EQ(img.at(2, 5), kGreen);
  EXPECT_EQ(img.at(12, 1), kBlue);  // end
  EXPECT_EQ(img.at(12, 3), kBlue);
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()), 1);
}

TEST_F(MapPngTest, PngClipsPosesOutsideTheImage) {
  const GridMap map = make_room();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  // From cell (12, 8) far to the right: row 1 from col 12 to the right edge, no end marker.
  const std::vector<TimedPose> traj = {at(0, 1.25, 0.85), at(1, 50.0, 0.85), at(2, nan, 0.0),
                                       at(3, 1e300, -1e300), at(4, 1e9, 0.85)};
  save_map_png(map, traj, path("clip.png"));
  const RgbImage img = decode_rgb_png(slurp(path("clip.png")));
  ASSERT_EQ(img.width, 20);
  EXPECT_EQ(img.at(12, 1), kGreen);
  EXPECT_EQ(img.at(16, 1), kRed);
  EXPECT_EQ(img.at(19, 1), kRed);
  for (std::size_t i = 0; i < img.rgb.size(); i += 3) {
    ASSERT_FALSE(img.rgb[i] == 0 && img.rgb[i + 1] == 0 && img.rgb[i + 2] == 255) << "blue pixel";
  }
}

TEST_F(MapPngTest, PngLoadsInMapServerWithThePgmClasses) {
  // The unknown tint's channel mean is the unknown level, so without a trajectory the PNG
  // itself reads back like the PGM.
  const GridMap map = make_test_map();
  save_ros_map(map, dir_.string());
  save_map_png(map, {}, path("map.png"));
  write_bytes("png.yaml",
              "image: map.png\nnegate: 0\nresolution: 0.05\norigin: [0, 0, 0]\n"
              "occupied_thresh: 0.65\nfree_thresh: 0.196\n");
  const OccupancyImage from_pgm = load_ros_map(path("map.yaml"));
  const OccupancyImage from_png = load_ros_map(path("png.yaml"));
  EXPECT_EQ(from_png.width, from_pgm.width);
  EXPECT_EQ(from_png.height, from_pgm.height);
  EXPECT_EQ(from_png.cells, from_pgm.cells);
}

TEST_F(MapPngTest, PngIntoMissingDirectoryThrowsNamingPath) {
  const std::string target = path("no/such/dir/map.png");
  try {
    save_map_png(make_room(), {}, target);
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(target), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace esfleet
