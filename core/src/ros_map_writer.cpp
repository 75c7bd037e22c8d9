#include "esfleet/core/ros_map_writer.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <stdexcept>
#include <system_error>

#include "esfleet/core/file_io.hpp"
#include "map_raster.hpp"

namespace esfleet {
namespace {

namespace fs = std::filesystem;
using detail::Raster;

/// Shortest text that reads back as exactly `v`, always with a '.' in the mantissa so YAML 1.1
/// readers (PyYAML) also see a float: "0.05", "-0.45", "1.0e-05", "3.0".
std::string format_double(double v) {
  char buf[64];
  const auto [end, ec] = std::to_chars(buf, buf + sizeof buf, v);
  std::string s(buf, ec == std::errc() ? end : buf);
  if (!std::isfinite(v) || s.find('.') != std::string::npos) return s;
  const std::size_t e = s.find('e');
  if (e == std::string::npos) return s + ".0";
  s.insert(e, ".0");
  return s;
}

bool valid_map_name(const std::string& name) {
  if (name.empty()) return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' ||
           c == '_' || c == '-';
  });
}

/// The grey level of a cell's class (see ros_map_format.hpp).
std::uint8_t level_of(std::int8_t value) {
  if (value == 100) return kOccupiedLevel;
  if (value == 0) return kFreeLevel;
  return kUnknownLevel;
}

}  // namespace

void OccupancyThresholds::validate() const {
  const auto fail = [](const std::string& field, double v, const std::string& need) {
    throw std::invalid_argument("occupancy threshold " + field + " " + format_double(v) +
                                ": need " + need);
  };
  if (!(occupied >= 0.0 && occupied < 1.0)) fail("occupied", occupied, "0 <= occupied < 1");
  if (min_hits < 1) fail("min_hits", static_cast<double>(min_hits), "min_hits >= 1");
  if (!(free >= 0.0 && free <= occupied)) fail("free", free, "0 <= free <= occupied");
}

std::int8_t ros_cell_value(std::uint64_t hit, std::uint64_t err, const OccupancyThresholds& th) {
  if (hit + err == 0) return -1;
  const double p = static_cast<double>(hit) / static_cast<double>(hit + err);
  if (hit >= th.min_hits && p > th.occupied) return 100;
  if (p <= th.free) return 0;
  return -1;
}

namespace detail {

Raster render(const GridMap& map, const OccupancyThresholds& th, const std::string& path) {
  th.validate();
  Raster r;
  const GridMap::Bounds b = map.known_bounds();
  if (!b.empty) {
    const std::int64_t w = std::int64_t{b.max.x} - b.min.x + 1;
    const std::int64_t h = std::int64_t{b.max.y} - b.min.y + 1;
    if (static_cast<std::uint64_t>(w * h) > kMaxMapImagePixels) {
      throw std::runtime_error("cannot write '" + path + "': the map's known cells span " +
                               std::to_string(w) + "x" + std::to_string(h) +
                               " cells, more than the " + std::to_string(kMaxMapImagePixels) +
                               " pixels a map image may have");
    }
    r.width = static_cast<int>(w);
    r.height = static_cast<int>(h);
    r.min = b.min;
    r.max_y = b.max.y;
  }
  const auto n = static_cast<std::size_t>(r.width) * static_cast<std::size_t>(r.height);
  r.grey.assign(n, kUnknownLevel);
  r.known.assign(n, 0);
  if (b.empty) return r;
  const std::int32_t edge = map.tile_edge();
  for (const TileKey& key : map.tile_keys()) {
    const Tile* tile = map.find_tile(key);
    for (std::int32_t ly = 0; ly < edge; ++ly) {
      const std::int64_t row = std::int64_t{r.max_y} - (std::int64_t{key.ty} * edge + ly);
      if (row < 0 || row >= r.height) continue;
      for (std::int32_t lx = 0; lx < edge; ++lx) {
        const auto i = static_cast<std::size_t>(ly * edge + lx);
        const std::uint64_t h = tile->hit[i], e = tile->err[i];
        if (h + e == 0) continue;
        const std::int64_t col = std::int64_t{key.tx} * edge + lx - r.min.x;
        if (col < 0 || col >= r.width) continue;
        const auto j = static_cast<std::size_t>(row * r.width + col);
        r.grey[j] = level_of(ros_cell_value(h, e, th));
        r.known[j] = 1;
      }
    }
  }
  return r;
}

}  // namespace detail

void save_ros_map(const GridMap& map, const std::string& dir, const std::string& name,
                  const OccupancyThresholds& th) {
  if (!valid_map_name(name)) {
    throw std::invalid_argument("map name '" + name +
                                "' must be non-empty and use only [A-Za-z0-9._-]");
  }
  const fs::path base = fs::path(dir);
  const std::string pgm_path = (base / (name + ".pgm")).string();
  const std::string yaml_path = (base / (name + ".yaml")).string();
  const Raster r = detail::render(map, th, pgm_path);

  if (!dir.empty()) {
    std::error_code ec;
    fs::create_directories(base, ec);
    if (ec) throw std::runtime_error("cannot create directory '" + dir + "': " + ec.message());
  }

  // Header, then the raster straight from memory (no copy of the image in a string).
  AtomicFile pgm(pgm_path);
  pgm.write("P5\n" + std::to_string(r.width) + " " + std::to_string(r.height) + "\n255\n");
  pgm.write({reinterpret_cast<const char*>(r.grey.data()), r.grey.size()});
  pgm.commit();

  const double cs = map.cell_size();
  std::string yaml;
  yaml += "image: " + name + ".pgm\n";
  yaml += "mode: trinary\n";
  yaml += "resolution: " + format_double(cs) + "\n";
  yaml +=
      "origin: [" + format_double(r.min.x * cs) + ", " + format_double(r.min.y * cs) + ", 0.0]\n";
  yaml += "negate: 0\n";
  yaml += "occupied_thresh: " + format_double(kRosOccupiedThresh) + "\n";
  yaml += "free_thresh: " + format_double(kRosFreeThresh) + "\n";
  write_file_atomically(yaml_path, yaml);
}

}  // namespace esfleet
