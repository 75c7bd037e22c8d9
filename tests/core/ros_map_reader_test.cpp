#include "esfleet/core/ros_map_reader.hpp"

#include <gtest/gtest.h>
#include <zlib.h>  // linked through esfleet_core (static, zlib private): builds the test PNGs

#include <cstdint>
#include <random>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "esfleet/core/map_png.hpp"
#include "esfleet/core/ros_map_writer.hpp"
#include "map_files_fixture.hpp"

namespace esfleet {
namespace {

using testing::add;
using testing::make_test_map;
using RosMapReaderTest = testing::MapFilesTest;
namespace fs = std::filesystem;

// --- load_ros_map ------------------------------------------------------------------------------

constexpr const char* kYamlTail =
    "resolution: 0.1\n"
    "origin: [-1.5, 2.0, 0.25]\n"
    "occupied_thresh: 0.65\n"
    "free_thresh: 0.196\n";

TEST_F(RosMapReaderTest, LoadsAsciiPgmWithCommentsInEveryMode) {
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

TEST_F(RosMapReaderTest, ScalesSixteenBitAndSmallMaxvalSamples) {
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

TEST_F(RosMapReaderTest, LoadsRgbaPngWithNav2AlphaRules) {
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

TEST_F(RosMapReaderTest, ImagePathIsRelativeToTheYamlUnlessAbsolute) {
  fs::create_directories(dir_ / "maps" / "img");
  write_bytes("maps/img/a.pgm", std::string("P5\n1 1\n255\n\x00", 12));
  write_bytes("maps/rel.yaml", "image: img/a.pgm\nnegate: 0\n" + std::string(kYamlTail));
  write_bytes("abs.yaml",
              "image: " + path("maps/img/a.pgm") + "\nnegate: 0\n" + std::string(kYamlTail));
  EXPECT_EQ(load_ros_map(path("maps/rel.yaml")).at(0, 0), 100);
  EXPECT_EQ(load_ros_map(path("abs.yaml")).at(0, 0), 100);
}

TEST_F(RosMapReaderTest, LoadErrorsNameTheFileAndTheField) {
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

TEST_F(RosMapReaderTest, ImageErrorsNameTheImage) {
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

TEST_F(RosMapReaderTest, MutatedFilesThrowRuntimeErrorOrLoadButNeverCrash) {
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

// --- parse_ros_map (in memory) -----------------------------------------------------------------

TEST_F(RosMapReaderTest, ParseFromMemoryEqualsLoadingTheFiles) {
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

TEST_F(RosMapReaderTest, ParseFromMemoryErrorsNameTheGivenNames) {
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
TEST_F(RosMapReaderTest, FuzzSeedsLoad) {
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
