#include "esfleet/core/map_io.hpp"

#include <gtest/gtest.h>
#include <unistd.h>
#include <zlib.h>  // linked through esfleet_core (static, zlib private): decodes the test PNGs

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace esfleet {
namespace {

namespace fs = std::filesystem;

/// A fresh directory per test (tests may run in parallel processes under CTest).
class MapIoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::path(::testing::TempDir()) /
           ("esfleet_map_io_" + std::string(info->name()) + "_" + std::to_string(getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string path(const std::string& name) const { return (dir_ / name).string(); }

  void write_bytes(const std::string& name, const std::string& bytes) const {
    std::ofstream(path(name), std::ios::binary) << bytes;
  }

  static std::string slurp(const std::string& file) {
    std::ifstream in(file, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
  }

  /// The message of the std::runtime_error that load_ros_map throws on `yaml`.
  static std::string load_error(const std::string& yaml) {
    try {
      load_ros_map(yaml);
    } catch (const std::runtime_error& e) {
      return e.what();
    } catch (const std::exception& e) {
      ADD_FAILURE() << "load_ros_map(" << yaml << ") threw a non-runtime_error: " << e.what();
      return {};
    }
    ADD_FAILURE() << "load_ros_map(" << yaml << ") did not throw";
    return {};
  }

  fs::path dir_;
};

void add(GridMap& map, CellIndex c, int hits, int errs) {
  for (int i = 0; i < hits; ++i) ASSERT_TRUE(map.add_hit(c));
  for (int i = 0; i < errs; ++i) ASSERT_TRUE(map.add_err(c));
}

/// The class map_server should give a cell after a save/load round trip (trinary).
int expected_class(const GridMap& map, CellIndex c, const OccupancyThresholds& th) {
  const double h = map.hit(c), e = map.err(c);
  if (h + e == 0) return -1;
  const double p = h / (h + e);
  if (p >= th.occupied) return 100;
  if (p <= th.free) return 0;
  return -1;
}

/// The test map: 14 x 12 cells (x -9..4, y -6..5) over four 8-cell tiles, with cells chosen
/// at and around the thresholds.
GridMap make_test_map() {
  GridMap map(GridMapConfig{.cell_size = 0.05, .tile_edge = 8});
  add(map, {-9, 5}, 3, 0);       // occupied, top-left pixel
  add(map, {-9, -6}, 13, 7);     // p = 0.65 exactly: occupied (threshold inclusive)
  add(map, {4, -6}, 0, 2);       // free, bottom-right pixel
  add(map, {4, 5}, 49, 201);     // p = 0.196 exactly: free (threshold inclusive)
  add(map, {0, 0}, 1, 1);        // p = 0.5: grey 128
  add(map, {2, 3}, 1299, 701);   // p = 0.6495: 89.4 would read occupied, clamped to 90
  add(map, {-1, -1}, 197, 803);  // p = 0.197: 204.8 rounds to 205 (unknown), moved to 204
  for (int x = -3; x <= 3; ++x) add(map, {x, -4}, 0, 1);  // a free row
  map.commit_update();
  return map;
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

// --- A minimal PNG reader for 8-bit RGB, non-interlaced (what OpenCV writes for CV_8UC3) ---

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

// --- save_ros_map ------------------------------------------------------------------------------

TEST_F(MapIoTest, PgmHasExactHeaderAndPixels) {
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

TEST_F(MapIoTest, YamlHasMapServerFields) {
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

TEST_F(MapIoTest, LoadReadsBackClassesOriginAndResolution) {
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

TEST_F(MapIoTest, CustomThresholdsMoveTheUnknownLevelAndStillRoundTrip) {
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

TEST_F(MapIoTest, RejectsBadThresholdsAndNames) {
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

TEST_F(MapIoTest, EmptyMapSavesOneUnknownPixel) {
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

TEST_F(MapIoTest, SaveIntoAFileInsteadOfADirectoryThrowsNamingIt) {
  write_bytes("blocker", "x");
  try {
    save_ros_map(make_test_map(), path("blocker"));
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(path("blocker")), std::string::npos) << e.what();
  }
}

// --- load_ros_map ------------------------------------------------------------------------------

constexpr const char* kYamlTail =
    "resolution: 0.1\n"
    "origin: [-1.5, 2.0, 0.25]\n"
    "occupied_thresh: 0.65\n"
    "free_thresh: 0.196\n";

TEST_F(MapIoTest, LoadsAsciiPgmWithCommentsInEveryMode) {
  // A 3x2 image: top row 0 254 100, bottom row 205 128 50; cells list the bottom row first.
  write_bytes("img.pgm", "P2\n# CREATOR: hand\n3 2\n# maxval next\n255\n0 254 100\n205 128 50\n");
  const auto load = [&](const std::string& extra) {
    write_bytes("m.yaml", "image: img.pgm\n" + std::string(kYamlTail) + extra);
    return load_ros_map(path("m.yaml"));
  };
  const OccupancyImage tri = load("negate: 0\n");
  ASSERT_EQ(tri.width, 3);
  ASSERT_EQ(tri.height, 2);
  EXPECT_EQ(tri.origin_x, -1.5);
  EXPECT_EQ(tri.origin_y, 2.0);
  EXPECT_EQ(tri.origin_theta, 0.25);
  EXPECT_EQ(tri.resolution, 0.1);
  EXPECT_EQ(tri.cells, (std::vector<std::int8_t>{-1, -1, 100, 100, 0, -1}));

  const OccupancyImage neg = load("negate: true\nmode: trinary\n");
  EXPECT_EQ(neg.cells, (std::vector<std::int8_t>{100, -1, -1, 0, 100, -1}));

  // scale: in between -> rint(100 * (occ - 0.196) / (0.65 - 0.196)); 205 -> 0, 128 -> 67,
  // 100 -> 91.
  const OccupancyImage scale = load("negate: 0\nmode: scale\n");
  EXPECT_EQ(scale.cells, (std::vector<std::int8_t>{0, 67, 100, 100, 0, 91}));

  // raw: the grey level itself if in 0..100, else unknown.
  const OccupancyImage raw = load("negate: 0\nmode: raw\n");
  EXPECT_EQ(raw.cells, (std::vector<std::int8_t>{-1, -1, 50, 0, -1, 100}));
}

TEST_F(MapIoTest, ScalesSixteenBitAndSmallMaxvalSamples) {
  const auto load = [&](const std::string& image) {
    write_bytes("img.pgm", image);
    write_bytes("m.yaml", "image: img.pgm\nnegate: 0\nmode: raw\n" + std::string(kYamlTail));
    return load_ros_map(path("m.yaml")).cells;
  };
  // raw mode shows the 8-bit level: 65535 -> 255 (unknown), 0x2828 = 10280 -> 40, 0 -> 0.
  EXPECT_EQ(load(std::string("P5\n3 1\n65535\n\xff\xff\x28\x28\x00\x00", 19)),
            (std::vector<std::int8_t>{-1, 40, 0}));
  // maxval 15: 1 -> 17, 5 -> 85, 15 -> 255.
  EXPECT_EQ(load("P2 3 1 15 1 5 15"), (std::vector<std::int8_t>{17, 85, -1}));
}

/// A PNG chunk: length, type, data, CRC.
std::string png_chunk(const std::string& type, const std::string& data) {
  std::string out;
  for (int shift = 24; shift >= 0; shift -= 8) {
    out += static_cast<char>((data.size() >> shift) & 0xff);
  }
  const std::string body = type + data;
  out += body;
  const uLong crc = crc32(crc32(0L, Z_NULL, 0), reinterpret_cast<const Bytef*>(body.data()),
                          static_cast<uInt>(body.size()));
  for (int shift = 24; shift >= 0; shift -= 8) out += static_cast<char>((crc >> shift) & 0xff);
  return out;
}

TEST_F(MapIoTest, LoadsRgbaPngWithNav2AlphaRules) {
  // One row of RGBA pixels: white transparent, white opaque, black opaque.
  const std::string row = std::string(1, '\0') +  // filter: none
                          std::string("\xff\xff\xff\x00\xff\xff\xff\xff\x00\x00\x00\xff", 12);
  std::vector<Bytef> z(compressBound(static_cast<uLong>(row.size())));
  uLongf z_len = static_cast<uLongf>(z.size());
  ASSERT_EQ(compress(z.data(), &z_len, reinterpret_cast<const Bytef*>(row.data()),
                     static_cast<uLong>(row.size())),
            Z_OK);
  const std::string png =
      std::string("\x89PNG\r\n\x1a\n", 8) +
      png_chunk("IHDR", std::string("\0\0\0\x03\0\0\0\x01\x08\x06\0\0\0", 13)) +
      png_chunk("IDAT", std::string(reinterpret_cast<const char*>(z.data()), z_len)) +
      png_chunk("IEND", "");
  write_bytes("img.png", png);
  const auto load = [&](const std::string& mode) {
    write_bytes("m.yaml", "image: img.png\nnegate: 0\nmode: " + mode + "\n" + kYamlTail);
    return load_ros_map(path("m.yaml")).cells;
  };
  // trinary averages alpha in: white transparent -> 191.25 -> occ 0.25 -> unknown.
  EXPECT_EQ(load("trinary"), (std::vector<std::int8_t>{-1, 0, 100}));
  // scale: anything not opaque is unknown, else by the colour mean.
  EXPECT_EQ(load("scale"), (std::vector<std::int8_t>{-1, 0, 100}));
  // raw: colour mean only: 255 -> unknown, 0 -> 0.
  EXPECT_EQ(load("raw"), (std::vector<std::int8_t>{-1, -1, 0}));
}

TEST_F(MapIoTest, ImagePathIsRelativeToTheYamlUnlessAbsolute) {
  fs::create_directories(dir_ / "maps" / "img");
  write_bytes("maps/img/a.pgm", std::string("P5\n1 1\n255\n\x00", 12));
  write_bytes("maps/rel.yaml", "image: img/a.pgm\nnegate: 0\n" + std::string(kYamlTail));
  write_bytes("abs.yaml",
              "image: " + path("maps/img/a.pgm") + "\nnegate: 0\n" + std::string(kYamlTail));
  EXPECT_EQ(load_ros_map(path("maps/rel.yaml")).at(0, 0), 100);
  EXPECT_EQ(load_ros_map(path("abs.yaml")).at(0, 0), 100);
}

TEST_F(MapIoTest, LoadErrorsNameTheFileAndTheField) {
  const std::string yaml = path("m.yaml");
  const std::string good_head = "image: img.pgm\nnegate: 0\n";
  write_bytes("img.pgm", std::string("P5\n2 2\n255\n\x00\xfe\xcd\x80", 15));
  struct Case {
    std::string yaml_text;
    std::string expect;  // besides the YAML path
  };
  const std::vector<Case> cases = {
      {"image: img.pgm\nnegate: 0\norigin: [0, 0, 0]\noccupied_thresh: 0.65\nfree_thresh: 0.2\n",
       "field 'resolution' missing"},
      {good_head + "resolution: -0.05\norigin: [0, 0, 0]\noccupied_thresh: 0.65\n"
                   "free_thresh: 0.2\n",
       "'resolution' must be > 0"},
      {good_head + "resolution: .nan\norigin: [0, 0, 0]\noccupied_thresh: 0.65\n"
                   "free_thresh: 0.2\n",
       "'resolution' must be finite"},
      {good_head + "resolution: fine\norigin: [0, 0, 0]\noccupied_thresh: 0.65\n"
                   "free_thresh: 0.2\n",
       "'resolution' must be a number"},
      {good_head + "resolution: 0.05\norigin: [0, 0]\noccupied_thresh: 0.65\nfree_thresh: 0.2\n",
       "'origin' must be a list of 3"},
      {good_head + "resolution: 0.05\norigin: 7\noccupied_thresh: 0.65\nfree_thresh: 0.2\n",
       "'origin' must be a list of 3"},
      {good_head + "resolution: 0.05\norigin: [0, x, 0]\noccupied_thresh: 0.65\n"
                   "free_thresh: 0.2\n",
       "'origin' must be a number"},
      {"image: img.pgm\nresolution: 0.05\norigin: [0, 0, 0]\noccupied_thresh: 0.65\n"
       "free_thresh: 0.2\n",
       "field 'negate' missing"},
      {good_head + "resolution: 0.05\norigin: [0, 0, 0]\noccupied_thresh: 0.65\n"
                   "free_thresh: 0.7\n",
       "'free_thresh' must be < occupied_thresh"},
      {good_head + "resolution: 0.05\norigin: [0, 0, 0]\noccupied_thresh: 0.65\n"
                   "free_thresh: 0.2\nmode: fancy\n",
       "'mode' must be trinary, scale or raw"},
      {"negate: 0\nresolution: 0.05\norigin: [0, 0, 0]\noccupied_thresh: 0.65\n"
       "free_thresh: 0.2\n",
       "field 'image' missing"},
      {"image: img.pgm\nresolution: [0.05\norigin: [0, 0, 0]\n", "yaml parse error"},
      {"- image\n- img.pgm\n", "expected a YAML mapping"},
      {"", "expected a YAML mapping"},
  };
  for (const Case& c : cases) {
    write_bytes("m.yaml", c.yaml_text);
    const std::string msg = load_error(yaml);
    EXPECT_EQ(msg.rfind(yaml, 0), 0u) << "message does not start with the path: " << msg;
    EXPECT_NE(msg.find(c.expect), std::string::npos) << msg << "\n  for:\n" << c.yaml_text;
  }
  // Line numbers where the field is present.
  write_bytes("m.yaml", good_head +
                            "resolution: -1\norigin: [0, 0, 0]\noccupied_thresh: 0.65\n"
                            "free_thresh: 0.2\n");
  EXPECT_NE(load_error(yaml).find(yaml + ":3:"), std::string::npos) << load_error(yaml);

  const std::string missing = path("nope.yaml");
  EXPECT_NE(load_error(missing).find(missing), std::string::npos) << load_error(missing);
  fs::create_directories(dir_ / "dir.yaml");
  EXPECT_NE(load_error(path("dir.yaml")).find("not a regular file"), std::string::npos);
}

TEST_F(MapIoTest, ImageErrorsNameTheImage) {
  const std::string yaml = path("m.yaml");
  write_bytes("m.yaml", "image: img.pgm\nnegate: 0\n" + std::string(kYamlTail));
  const std::string image = path("img.pgm");
  std::mt19937 rng(7);
  std::string garbage(300, '\0');
  for (char& c : garbage) c = static_cast<char>(rng() % 256);
  garbage[0] = 'G';
  // IHDR of a 100000 x 100000 RGB PNG, then nothing.
  const std::string huge_png = std::string("\x89PNG\r\n\x1a\n\0\0\0\x0dIHDR", 16) +
                               std::string("\0\x01\x86\xa0\0\x01\x86\xa0\x08\x02\0\0\0", 13) +
                               std::string("\0\0\0\0", 4);
  struct Case {
    std::string bytes;  // empty: no file at all
    std::string expect;
  };
  const std::vector<Case> cases = {
      {"", "No such file"},
      {garbage, "not a PGM (P5/P2) or PNG"},
      {"P5" + garbage, "bad PGM"},
      {"P5\n4 4\n255\n12345", "truncated: 5 bytes of pixel data, 4x4 needs 16"},
      {"P5\n100000 100000\n255\n\x01\x02\x03", "100000x100000 pixels, more than"},
      {"P5\n99999999999 1\n255\n", "too many digits"},
      {"P5\n0 4\n255\n", "zero width or height"},
      {"P5\n1 1\n0\n\x00", "maxval"},
      {"P2\n2 1\n15\n3 16\n", "above maxval"},
      {"P2\n2 1\n255\n3\n", "truncated"},
      {"P5\n2 2", "truncated header"},
      {huge_png, "100000x100000 pixels, more than"},
      {std::string("\x89PNG\r\n\x1a\n", 8) + garbage, "PNG"},
  };
  for (const Case& c : cases) {
    fs::remove(image);
    if (!c.bytes.empty()) write_bytes("img.pgm", c.bytes);
    const std::string msg = load_error(yaml);
    EXPECT_EQ(msg.rfind(image, 0), 0u) << "message does not start with the image path: " << msg;
    EXPECT_NE(msg.find(c.expect), std::string::npos) << msg;
  }
}

TEST_F(MapIoTest, MutatedFilesThrowRuntimeErrorOrLoadButNeverCrash) {
  save_ros_map(make_test_map(), dir_.string());
  save_map_png(make_test_map(), {}, path("map.png"));
  const std::string yaml = slurp(path("map.yaml"));
  const std::string png_yaml = "image: map.png\nnegate: 0\n" + std::string(kYamlTail);
  const std::vector<std::pair<std::string, std::string>> files = {
      {"map.yaml", yaml}, {"map.pgm", slurp(path("map.pgm"))}, {"map.png", slurp(path("map.png"))}};
  std::mt19937 rng(2024);
  int loaded = 0, refused = 0;
  for (int iter = 0; iter < 300; ++iter) {
    const auto& [name, original] = files[static_cast<std::size_t>(iter) % files.size()];
    std::string bytes = original;
    if (rng() % 4 == 0) {
      bytes.resize(rng() % bytes.size());
    } else {
      const int flips = 1 + static_cast<int>(rng() % 4);
      // Mostly hit the header, where the structure is.
      const std::size_t span = std::min<std::size_t>(bytes.size(), rng() % 2 ? 40 : bytes.size());
      for (int k = 0; k < flips; ++k) bytes[rng() % span] = static_cast<char>(rng() % 256);
    }
    write_bytes(name, bytes);
    write_bytes("png.yaml", png_yaml);
    try {
      load_ros_map(path(name == "map.png" ? "png.yaml" : "map.yaml"));
      ++loaded;
    } catch (const std::runtime_error&) {
      ++refused;
    }
    write_bytes(name, original);
  }
  EXPECT_GT(refused, 0);
  EXPECT_GT(loaded, 0);
}

// --- save_map_png ------------------------------------------------------------------------------

/// 20 x 10 cells of 0.1 m at x 0..19, y 0..9: free, column x = 19 occupied, (5, 8) unknown.
GridMap make_room() {
  GridMap map(GridMapConfig{.cell_size = 0.1, .tile_edge = 8});
  for (int y = 0; y <= 9; ++y) {
    for (int x = 0; x <= 19; ++x) {
      if (x == 5 && y == 8) continue;
      if (x == 19) {
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

TEST_F(MapIoTest, PngShowsMapTrajectoryAndMarkers) {
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

TEST_F(MapIoTest, PngClipsPosesOutsideTheImage) {
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

TEST_F(MapIoTest, PngLoadsInMapServerWithThePgmClasses) {
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

TEST_F(MapIoTest, PngIntoMissingDirectoryThrowsNamingPath) {
  const std::string target = path("no/such/dir/map.png");
  try {
    save_map_png(make_room(), {}, target);
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(target), std::string::npos) << e.what();
  }
}

// --- write_file_atomically ---------------------------------------------------------------------

TEST_F(MapIoTest, AtomicWriteRoundTripsAndLeavesNoTemporary) {
  const std::string file = path("stats.json");
  const std::string binary("a\0b\nc\xff", 6);
  write_file_atomically(file, binary);
  EXPECT_EQ(slurp(file), binary);
  write_file_atomically(file, "second, shorter");
  EXPECT_EQ(slurp(file), "second, shorter");
  write_file_atomically(file, "");
  EXPECT_EQ(slurp(file), "");
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir_)) names.push_back(e.path().filename().string());
  EXPECT_EQ(names, std::vector<std::string>{"stats.json"});
}

TEST_F(MapIoTest, AtomicWriteIntoMissingDirectoryThrowsNamingPath) {
  const std::string file = path("missing/stats.json");
  try {
    write_file_atomically(file, "{}");
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(file), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(path("missing")));
}

TEST_F(MapIoTest, AtomicWriteOverADirectoryFailsAndCleansUp) {
  fs::create_directories(dir_ / "taken");
  EXPECT_THROW(write_file_atomically(path("taken"), "x"), std::runtime_error);
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()), 1);
}

// --- parse_ros_map (in memory) -----------------------------------------------------------------

TEST_F(MapIoTest, ParseFromMemoryEqualsLoadingTheFiles) {
  write_bytes("img.pgm", "P2\n# CREATOR: hand\n3 2\n# maxval next\n255\n0 254 100\n205 128 50\n");
  const std::string yaml = "image: img.pgm\nnegate: 0\nmode: scale\n" + std::string(kYamlTail);
  write_bytes("m.yaml", yaml);
  const OccupancyImage from_files = load_ros_map(path("m.yaml"));
  const OccupancyImage from_memory = parse_ros_map(yaml, slurp(path("img.pgm")), "m.yaml");
  EXPECT_EQ(from_memory.cells, from_files.cells);
  EXPECT_EQ(from_memory.width, 3);
  EXPECT_EQ(from_memory.height, 2);
  EXPECT_EQ(from_memory.origin_x, from_files.origin_x);
  EXPECT_EQ(from_memory.origin_theta, from_files.origin_theta);
  EXPECT_EQ(from_memory.resolution, from_files.resolution);
  // The image the YAML names is not opened: a name that exists nowhere loads the same.
  const std::string elsewhere =
      "image: /nonexistent/dir/x.pgm\nnegate: 0\nmode: scale\n" + std::string(kYamlTail);
  EXPECT_EQ(parse_ros_map(elsewhere, slurp(path("img.pgm"))).cells, from_files.cells);
}

TEST_F(MapIoTest, ParseFromMemoryErrorsNameTheGivenNames) {
  const auto error = [](std::string_view yaml, std::string_view image) -> std::string {
    try {
      parse_ros_map(yaml, image, "mem.yaml");
    } catch (const std::runtime_error& e) {
      return e.what();
    }
    return "(no error)";
  };
  EXPECT_EQ(error("", "").rfind("mem.yaml: expected a YAML mapping", 0), 0u) << error("", "");
  const std::string yaml = "image: img.pgm\nnegate: 0\n" + std::string(kYamlTail);
  EXPECT_EQ(error(yaml, ""), "img.pgm: cannot read image: not a PGM (P5/P2) or PNG file");
  EXPECT_EQ(error(yaml, "P5\n2 2\n255\n\x01"),
            "img.pgm: bad PGM image: truncated: 1 bytes of pixel data, 2x2 needs 4");
  EXPECT_NE(error("image: a.pgm\nresolution: [", "").find("mem.yaml:2: yaml parse error"),
            std::string::npos);
  EXPECT_NE(error(std::string((1u << 20) + 1, ' '), "").find("more than the 1048576 allowed"),
            std::string::npos);
}

// The committed seeds of fuzz/fuzz_map_loader (YAML, NUL, image; written by fuzz/make_seeds
// from save_ros_map / save_map_png) load: the fuzzer starts from valid maps.
TEST_F(MapIoTest, FuzzSeedsLoad) {
  const fs::path corpus = fs::path(ESFLEET_PROJECT_DIR) / "fuzz/corpus/fuzz_map_loader";
  int seeds = 0;
  for (const char* name : {"pgm-p5", "pgm-p2-scale", "png-rgb-raw", "png-rgb-negate"}) {
    const std::string input = slurp((corpus / name).string());
    const std::size_t nul = input.find('\0');
    ASSERT_NE(nul, std::string::npos) << name;
    const OccupancyImage img = parse_ros_map(std::string_view(input).substr(0, nul),
                                             std::string_view(input).substr(nul + 1), name);
    EXPECT_GT(img.width, 10) << name;
    EXPECT_EQ(img.cells.size(), static_cast<std::size_t>(img.width) * img.height) << name;
    ++seeds;
  }
  EXPECT_EQ(seeds, 4);
}

}  // namespace
}  // namespace esfleet
