// libFuzzer target: the ROS map_server loader (parse_ros_map, the in-memory twin of
// load_ros_map) over an arbitrary YAML document and image. The input is the YAML text, a NUL
// byte, then the image bytes (PGM or PNG); without a NUL it is all YAML and the image is empty.
// Every input must load into a consistent OccupancyImage or throw std::runtime_error; anything
// else (a crash, a sanitizer report, another exception, an inconsistent image) is a finding.
// The CRCs of a PNG's chunks are recomputed before loading (the loader refuses a bad CRC), so
// that mutated chunk contents reach libpng instead of stopping at the CRC check.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <string_view>

#include <zlib.h>

#include "esfleet/core/ros_map_reader.hpp"
#include "fuzz_check.hpp"

using esfleet::fuzz::check;

namespace {

std::uint32_t be32(const std::string& d, std::size_t at) {
  std::uint32_t v = 0;
  for (std::size_t i = 0; i < 4; ++i) v = (v << 8) | static_cast<unsigned char>(d[at + i]);
  return v;
}

/// Rewrites the CRC of every whole chunk of a PNG (signature, then length, type, data, CRC).
void fix_png_crcs(std::string& d) {
  if (d.size() < 8 || d.compare(1, 3, "PNG") != 0) return;
  for (std::size_t pos = 8; d.size() - pos >= 12;) {
    const std::uint64_t len = be32(d, pos);
    if (len > d.size() - pos - 12) return;
    const uLong crc =
        crc32(crc32(0L, Z_NULL, 0), reinterpret_cast<const Bytef*>(d.data() + pos + 4),
              static_cast<uInt>(len + 4));
    for (std::size_t i = 0; i < 4; ++i) {
      d[pos + 8 + len + i] = static_cast<char>((crc >> (24 - 8 * i)) & 0xFFu);
    }
    pos += 12 + len;
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  const std::size_t nul = input.find('\0');
  const std::string_view yaml = input.substr(0, nul);
  std::string image(nul == std::string_view::npos ? "" : input.substr(nul + 1));
  fix_png_crcs(image);
  try {
    const esfleet::OccupancyImage img = esfleet::parse_ros_map(yaml, image, "fuzz.yaml");
    check(img.width > 0 && img.height > 0, "image not empty");
    check(img.cells.size() ==
              static_cast<std::size_t>(img.width) * static_cast<std::size_t>(img.height),
          "cells == width * height");
    for (const std::int8_t c : img.cells) check(c >= -1 && c <= 100, "cell in -1..100");
    check(std::isfinite(img.resolution) && img.resolution > 0.0, "resolution finite and > 0");
    check(std::isfinite(img.origin_x) && std::isfinite(img.origin_y) &&
              std::isfinite(img.origin_theta),
          "origin finite");
  } catch (const std::runtime_error& e) {
    check(std::strlen(e.what()) > 0, "error has a message");
  }
  return 0;
}
