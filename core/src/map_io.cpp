#include "esfleet/core/map_io.hpp"

#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <stdexcept>
#include <string_view>
#include <system_error>

#include <yaml-cpp/yaml.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace esfleet {
namespace {

namespace fs = std::filesystem;

// ---------------------------------------------------------------------------------------------
// Grey levels (writing)

/// Margin on the thresholds when choosing levels: map_server implementations compute the
/// occupancy of a level as (255 - x) / 255 or 1 - x / 255 (possibly via 16-bit quanta), which
/// may differ in the last bit.
constexpr double kThresholdMargin = 1e-9;
constexpr int kPreferredUnknownLevel = 205;  // what ROS map_saver writes for unknown

double occupancy_of_level(int x) { return 1.0 - static_cast<double>(x) / 255.0; }

struct GreyLevels {
  std::uint8_t occupied = 0;
  std::uint8_t free = 254;
  std::uint8_t unknown = 205;
  int between_lo = 90;  ///< levels [between_lo, between_hi] read back as unknown
  int between_hi = 205;
};

std::string format_double(double v);

GreyLevels grey_levels(const OccupancyThresholds& th) {
  if (!std::isfinite(th.free) || !std::isfinite(th.occupied) || !(th.free > 0.0) ||
      !(th.free < th.occupied) || !(th.occupied < 1.0)) {
    throw std::invalid_argument("occupancy thresholds need 0 < free < occupied < 1, got free " +
                                format_double(th.free) + ", occupied " +
                                format_double(th.occupied));
  }
  const double occ_hi = th.occupied + kThresholdMargin, occ_lo = th.occupied - kThresholdMargin;
  const double free_lo = th.free - kThresholdMargin, free_hi = th.free + kThresholdMargin;
  GreyLevels g;
  if (!(occupancy_of_level(0) > occ_hi)) {
    throw std::invalid_argument("occupancy threshold occupied " + format_double(th.occupied) +
                                " is too close to 1: no grey level reads as occupied");
  }
  g.occupied = 0;
  if (occupancy_of_level(254) < free_lo) {
    g.free = 254;
  } else if (occupancy_of_level(255) < free_lo) {
    g.free = 255;
  } else {
    throw std::invalid_argument("occupancy threshold free " + format_double(th.free) +
                                " is too close to 0: no grey level reads as free");
  }
  g.between_lo = -1;
  for (int x = 0; x <= 255; ++x) {
    const double o = occupancy_of_level(x);
    if (o >= free_hi && o <= occ_lo) {
      if (g.between_lo < 0) g.between_lo = x;
      g.between_hi = x;
    }
  }
  if (g.between_lo < 0) {
    throw std::invalid_argument("occupancy thresholds free " + format_double(th.free) +
                                " and occupied " + format_double(th.occupied) +
                                " leave no grey level that reads as unknown");
  }
  g.unknown =
      static_cast<std::uint8_t>(std::clamp(kPreferredUnknownLevel, g.between_lo, g.between_hi));
  return g;
}

/// The grey level of a known cell (hit + err > 0); see save_ros_map.
std::uint8_t level_of(std::uint64_t hit, std::uint64_t err, const OccupancyThresholds& th,
                      const GreyLevels& g) {
  const double p = static_cast<double>(hit) / static_cast<double>(hit + err);
  if (p >= th.occupied) return g.occupied;
  if (p <= th.free) return g.free;
  int x = static_cast<int>(std::lround(255.0 * (1.0 - p)));
  x = std::clamp(x, g.between_lo, g.between_hi);
  if (x == g.unknown) {
    if (x - 1 >= g.between_lo) {
      --x;
    } else if (x + 1 <= g.between_hi) {
      ++x;
    }
  }
  return static_cast<std::uint8_t>(x);
}

/// The map cropped to its known cells, one grey byte per cell, row 0 = the top (largest y).
struct Raster {
  int width = 1;
  int height = 1;
  CellIndex min{0, 0};  ///< cell of the bottom-left pixel
  std::int32_t max_y = 0;
  std::vector<std::uint8_t> grey;
  std::vector<std::uint8_t> known;  ///< 1 where hit + err > 0
};

Raster render(const GridMap& map, const OccupancyThresholds& th, const GreyLevels& g,
              const std::string& path) {
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
  r.grey.assign(n, g.unknown);
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
        r.grey[j] = level_of(h, e, th, g);
        r.known[j] = 1;
      }
    }
  }
  return r;
}

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

// ---------------------------------------------------------------------------------------------
// Reading files

constexpr std::uintmax_t kMaxYamlBytes = 1u << 20;
// A P2 file of kMaxMapImagePixels 3-digit samples fits; a PNG of that size is far smaller.
constexpr std::uintmax_t kMaxImageBytes = std::uintmax_t{512} << 20;

std::string errno_text(int err) { return std::error_code(err, std::generic_category()).message(); }

/// The whole of a regular file of at most `max_bytes`. `what` names it in errors ("map file").
std::string read_whole_file(const std::string& path, std::uintmax_t max_bytes,
                            const std::string& what, const std::string& context = {}) {
  const std::string prefix = path + ": cannot read " + what + context + ": ";
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (ec) throw std::runtime_error(prefix + ec.message());
  if (!fs::is_regular_file(st)) throw std::runtime_error(prefix + "not a regular file");
  const std::uintmax_t size = fs::file_size(path, ec);
  if (ec) throw std::runtime_error(prefix + ec.message());
  if (size > max_bytes) {
    throw std::runtime_error(prefix + "file is " + std::to_string(size) + " bytes, more than the " +
                             std::to_string(max_bytes) + " allowed");
  }
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) throw std::runtime_error(prefix + errno_text(errno));
  std::string data(static_cast<std::size_t>(size), '\0');
  const std::size_t got = data.empty() ? 0 : std::fread(data.data(), 1, data.size(), f);
  const bool failed = std::ferror(f) != 0;
  std::fclose(f);
  if (failed) throw std::runtime_error(prefix + "read error");
  data.resize(got);  // the file may have shrunk meanwhile
  return data;
}

// ---------------------------------------------------------------------------------------------
// YAML

std::string location(const std::string& path, const YAML::Mark& mark) {
  if (mark.is_null() || mark.line < 0) return path + ": ";
  return path + ":" + std::to_string(mark.line + 1) + ": ";
}

/// Reads the fields of one map YAML document, with errors naming the file, line and field.
class MapYaml {
 public:
  MapYaml(std::string path, YAML::Node root) : path_(std::move(path)), root_(std::move(root)) {}

  YAML::Node required(const std::string& key) const {
    const YAML::Node& root = root_;
    YAML::Node n = root[key];
    if (!n.IsDefined()) throw std::runtime_error(path_ + ": field '" + key + "' missing");
    if (n.IsNull()) fail(n, key, "is empty");
    return n;
  }

  [[noreturn]] void fail(const YAML::Node& n, const std::string& key,
                         const std::string& what) const {
    throw std::runtime_error(location(path_, n.Mark()) + "field '" + key + "' " + what);
  }

  double number(const YAML::Node& n, const std::string& key) const {
    if (!n.IsScalar()) fail(n, key, "must be a number");
    double v = 0.0;
    try {
      v = n.as<double>();
    } catch (const YAML::Exception&) {
      fail(n, key, "must be a number, got '" + n.Scalar() + "'");
    }
    if (!std::isfinite(v)) fail(n, key, "must be finite, got '" + n.Scalar() + "'");
    return v;
  }

  double number(const std::string& key) const { return number(required(key), key); }

  std::string text(const std::string& key) const {
    const YAML::Node n = required(key);
    if (!n.IsScalar()) fail(n, key, "must be a string");
    return n.Scalar();
  }

 private:
  std::string path_;
  YAML::Node root_;
};

enum class MapMode { kTrinary, kScale, kRaw };

struct MapMeta {
  fs::path image;
  double resolution = 0.0;
  double origin[3] = {0.0, 0.0, 0.0};
  bool negate = false;
  double occupied = 0.65;
  double free = 0.196;
  MapMode mode = MapMode::kTrinary;
};

/// The map YAML document `text`; `yaml_path` names it in errors and anchors a relative image.
MapMeta parse_map_yaml(const std::string& text, const std::string& yaml_path) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(location(yaml_path, e.mark) + "yaml parse error: " + e.msg);
  }
  if (!root.IsMap()) {
    throw std::runtime_error(yaml_path + ": expected a YAML mapping with the fields image, " +
                             "resolution, origin, negate, occupied_thresh, free_thresh");
  }
  const MapYaml y(yaml_path, root);
  MapMeta m;
  try {
    const std::string image = y.text("image");
    if (image.empty()) y.fail(y.required("image"), "image", "is empty");
    m.image = fs::path(image);
    if (m.image.is_relative()) m.image = fs::path(yaml_path).parent_path() / m.image;

    const YAML::Node res = y.required("resolution");
    m.resolution = y.number(res, "resolution");
    if (!(m.resolution > 0.0)) {
      y.fail(res, "resolution", "must be > 0, got " + res.Scalar());
    }

    const YAML::Node origin = y.required("origin");
    if (!origin.IsSequence() || origin.size() != 3) {
      y.fail(origin, "origin", "must be a list of 3 numbers [x, y, yaw]");
    }
    for (std::size_t i = 0; i < 3; ++i) m.origin[i] = y.number(origin[i], "origin");

    const YAML::Node negate = y.required("negate");
    if (!negate.IsScalar()) y.fail(negate, "negate", "must be 0, 1, true or false");
    try {
      m.negate = negate.as<int>() != 0;
    } catch (const YAML::Exception&) {
      try {
        m.negate = negate.as<bool>();
      } catch (const YAML::Exception&) {
        y.fail(negate, "negate", "must be 0, 1, true or false, got '" + negate.Scalar() + "'");
      }
    }

    m.occupied = y.number("occupied_thresh");
    m.free = y.number("free_thresh");
    if (m.occupied > 1.0) {
      y.fail(y.required("occupied_thresh"), "occupied_thresh", "must be <= 1");
    }
    if (m.free < 0.0) y.fail(y.required("free_thresh"), "free_thresh", "must be >= 0");
    if (!(m.free < m.occupied)) {
      y.fail(y.required("free_thresh"), "free_thresh", "must be < occupied_thresh");
    }

    const YAML::Node& const_root = root;
    const YAML::Node mode = const_root["mode"];
    if (mode.IsDefined() && !mode.IsNull()) {
      const std::string s = mode.IsScalar() ? mode.Scalar() : std::string();
      if (s == "trinary") {
        m.mode = MapMode::kTrinary;
      } else if (s == "scale") {
        m.mode = MapMode::kScale;
      } else if (s == "raw") {
        m.mode = MapMode::kRaw;
      } else {
        y.fail(mode, "mode", "must be trinary, scale or raw, got '" + s + "'");
      }
    }
  } catch (const YAML::Exception& e) {  // defensive: yaml-cpp misuse on odd documents
    throw std::runtime_error(location(yaml_path, e.mark) + "invalid map file: " + e.msg);
  }
  return m;
}

// ---------------------------------------------------------------------------------------------
// Images

/// A decoded image, 8 bits per sample, interleaved, rows from the top. Channel orders: 1 grey,
/// 2 grey+alpha, 3 BGR, 4 BGRA (OpenCV's).
struct Pixels {
  int width = 0;
  int height = 0;
  int channels = 1;
  std::vector<std::uint8_t> data;
};

void check_dimensions(const std::string& path, std::uint64_t w, std::uint64_t h) {
  if (w == 0 || h == 0) {
    throw std::runtime_error(path + ": image has zero width or height (" + std::to_string(w) + "x" +
                             std::to_string(h) + ")");
  }
  // w, h < 2^32 here, so the product cannot overflow.
  if (w > kMaxMapImagePixels || h > kMaxMapImagePixels || w * h > kMaxMapImagePixels) {
    throw std::runtime_error(path + ": image is " + std::to_string(w) + "x" + std::to_string(h) +
                             " pixels, more than the " + std::to_string(kMaxMapImagePixels) +
                             " allowed");
  }
}

bool is_pnm_space(char c) {
  return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f';
}

/// Netpbm grey map, P5 (binary) or P2 (ascii).
class PgmParser {
 public:
  PgmParser(const std::string& path, std::string_view data) : path_(path), d_(data) {}

  Pixels parse() {
    const bool binary = d_[1] == '5';
    pos_ = 2;
    const std::uint64_t w = header_number("width");
    const std::uint64_t h = header_number("height");
    const std::uint64_t maxval = header_number("maxval");
    if (maxval == 0 || maxval > 65535) {
      fail("maxval must be in 1..65535, got " + std::to_string(maxval));
    }
    check_dimensions(path_, w, h);
    if (pos_ >= d_.size() || !is_pnm_space(d_[pos_])) fail("truncated header");
    ++pos_;  // the single whitespace character before the raster
    const std::size_t n = static_cast<std::size_t>(w * h);
    const std::size_t bytes_per_sample = maxval > 255 ? 2 : 1;
    // Check the data can hold the raster before allocating it: binary samples take 1 or 2
    // bytes, ascii ones at least a digit and a separator.
    const std::size_t left = d_.size() - pos_;
    const std::size_t need = binary ? n * bytes_per_sample : 2 * n - 1;
    if (left < need) {
      fail("truncated: " + std::to_string(left) + " bytes of pixel data, " + std::to_string(w) +
           "x" + std::to_string(h) + " needs " + (binary ? "" : "at least ") +
           std::to_string(need));
    }
    Pixels px;
    px.width = static_cast<int>(w);
    px.height = static_cast<int>(h);
    px.data.resize(n);
    if (binary) {
      for (std::size_t i = 0; i < n; ++i) {
        std::uint64_t v = static_cast<unsigned char>(d_[pos_ + i * bytes_per_sample]);
        if (bytes_per_sample == 2) {
          v = (v << 8) | static_cast<unsigned char>(d_[pos_ + i * 2 + 1]);
        }
        px.data[i] = scale(v, maxval, i);
      }
    } else {
      for (std::size_t i = 0; i < n; ++i) {
        while (pos_ < d_.size() && is_pnm_space(d_[pos_])) ++pos_;
        if (pos_ >= d_.size()) {
          fail("truncated: " + std::to_string(i) + " samples, " + std::to_string(w) + "x" +
               std::to_string(h) + " needs " + std::to_string(n));
        }
        px.data[i] = scale(number("sample " + std::to_string(i)), maxval, i);
      }
    }
    return px;
  }

 private:
  [[noreturn]] void fail(const std::string& what) const {
    throw std::runtime_error(path_ + ": bad PGM image: " + what);
  }

  std::uint8_t scale(std::uint64_t v, std::uint64_t maxval, std::size_t i) const {
    if (v > maxval) {
      fail("sample " + std::to_string(i) + " is " + std::to_string(v) + ", above maxval " +
           std::to_string(maxval));
    }
    if (maxval == 255) return static_cast<std::uint8_t>(v);
    return static_cast<std::uint8_t>((v * 255 + maxval / 2) / maxval);
  }

  /// A decimal number at pos_ (no sign), at most 10 digits.
  std::uint64_t number(const std::string& what) {
    std::uint64_t v = 0;
    std::size_t digits = 0;
    while (pos_ < d_.size() && d_[pos_] >= '0' && d_[pos_] <= '9') {
      if (++digits > 10) fail(what + " has too many digits");
      v = v * 10 + static_cast<std::uint64_t>(d_[pos_] - '0');
      ++pos_;
    }
    if (digits == 0) fail(what + " is not a number");
    return v;
  }

  /// Skips whitespace and '#' comments, then reads a number.
  std::uint64_t header_number(const std::string& what) {
    for (;;) {
      while (pos_ < d_.size() && is_pnm_space(d_[pos_])) ++pos_;
      if (pos_ < d_.size() && d_[pos_] == '#') {
        while (pos_ < d_.size() && d_[pos_] != '\n' && d_[pos_] != '\r') ++pos_;
        continue;
      }
      break;
    }
    if (pos_ >= d_.size()) fail("truncated header (no " + what + ")");
    return number(what);
  }

  const std::string& path_;
  std::string_view d_;
  std::size_t pos_ = 0;
};

constexpr unsigned char kPngSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};

std::uint64_t be32(std::string_view d, std::size_t at) {
  std::uint64_t v = 0;
  for (std::size_t i = 0; i < 4; ++i) v = (v << 8) | static_cast<unsigned char>(d[at + i]);
  return v;
}

/// Checks a PNG's chunk structure (lengths, CRCs, IHDR fields, IDAT and IEND present) and
/// that the file could hold its raster, so that libpng, which prints its complaints to stderr,
/// only ever sees well-formed files and OpenCV never allocates for a lying header.
void check_png(const std::string& path, std::string_view data) {
  const auto bad = [&](const std::string& what) {
    return std::runtime_error(path + ": bad PNG image: " + what);
  };
  if (data.size() < 33 || data.compare(12, 4, "IHDR") != 0 || be32(data, 8) != 13) {
    throw bad("no IHDR header");
  }
  const std::uint64_t w = be32(data, 16), h = be32(data, 20);
  check_dimensions(path, w, h);
  const auto depth = static_cast<unsigned char>(data[24]);
  const auto colour = static_cast<unsigned char>(data[25]);
  std::uint64_t samples = 0;
  bool depth_ok = false;
  switch (colour) {
    case 0:  // grey
      samples = 1;
      depth_ok = depth == 1 || depth == 2 || depth == 4 || depth == 8 || depth == 16;
      break;
    case 3:  // palette
      samples = 1;
      depth_ok = depth == 1 || depth == 2 || depth == 4 || depth == 8;
      break;
    case 2:  // RGB
    case 4:  // grey + alpha
    case 6:  // RGBA
      samples = colour == 2 ? 3 : colour == 4 ? 2 : 4;
      depth_ok = depth == 8 || depth == 16;
      break;
    default:
      break;
  }
  if (!depth_ok || data[26] != 0 || data[27] != 0 || (data[28] != 0 && data[28] != 1)) {
    throw bad("invalid IHDR (bit depth " + std::to_string(depth) + ", colour type " +
              std::to_string(colour) + ")");
  }
  std::size_t pos = 8;
  std::uint64_t idat_bytes = 0;
  bool have_palette = false, have_end = false;
  while (!have_end) {
    if (data.size() - pos < 12) throw bad("truncated (no IEND chunk)");
    const std::uint64_t len = be32(data, pos);
    if (len > data.size() - pos - 12) throw bad("truncated chunk at byte " + std::to_string(pos));
    const std::string_view type = data.substr(pos + 4, 4);
    uLong crc = crc32(0L, Z_NULL, 0);
    crc = crc32(crc, reinterpret_cast<const Bytef*>(data.data() + pos + 4),
                static_cast<uInt>(len + 4));
    if (crc != be32(data, pos + 8 + len)) {
      throw bad("CRC error in chunk '" + std::string(type) + "' at byte " + std::to_string(pos));
    }
    if (type == "IDAT") idat_bytes += len;
    if (type == "PLTE") have_palette = true;
    if (type == "IEND") have_end = true;
    pos += 12 + len;
  }
  if (idat_bytes == 0) throw bad("no image data");
  if (colour == 3 && !have_palette) throw bad("palette image without a palette");
  // Deflate expands at most ~1032:1: compressed data much smaller than the raster (one filter
  // byte per row plus the packed samples) cannot hold it.
  const std::uint64_t raster = h * (1 + (w * samples * depth + 7) / 8);
  if (idat_bytes * 1100 < raster) {
    throw bad(std::to_string(idat_bytes) + " bytes of image data cannot hold " + std::to_string(w) +
              "x" + std::to_string(h) + " pixels");
  }
}

Pixels decode_png(const std::string& path, const std::string& data) {
  check_png(path, data);
  const std::uint64_t w = be32(data, 16), h = be32(data, 20);
  cv::Mat img;
  try {
    const cv::Mat buf(
        1, static_cast<int>(std::min<std::size_t>(data.size(), std::numeric_limits<int>::max())),
        CV_8UC1, const_cast<char*>(data.data()));
    img = cv::imdecode(buf, cv::IMREAD_UNCHANGED);
    if (!img.empty() && img.depth() == CV_16U) {
      cv::Mat eight;
      img.convertTo(eight, CV_8U, 1.0 / 257.0);
      img = eight;
    }
  } catch (const cv::Exception& e) {
    throw std::runtime_error(path + ": cannot decode PNG image: " + e.what());
  }
  if (img.empty()) throw std::runtime_error(path + ": cannot decode PNG image");
  if (img.depth() != CV_8U || img.channels() < 1 || img.channels() > 4) {
    throw std::runtime_error(path + ": unsupported PNG sample format");
  }
  if (static_cast<std::uint64_t>(img.cols) != w || static_cast<std::uint64_t>(img.rows) != h) {
    throw std::runtime_error(path + ": PNG decoded to a size other than its header's");
  }
  Pixels px;
  px.width = img.cols;
  px.height = img.rows;
  px.channels = img.channels();
  const std::size_t row_bytes = static_cast<std::size_t>(img.cols) * px.channels;
  px.data.resize(row_bytes * static_cast<std::size_t>(img.rows));
  for (int r = 0; r < img.rows; ++r) {
    std::copy_n(img.ptr<std::uint8_t>(r), row_bytes, px.data.data() + row_bytes * r);
  }
  return px;
}

/// The image file contents `data` (PGM or PNG, told apart by their magic bytes); `path` names
/// it in errors.
Pixels decode_image(const std::string& path, const std::string& data) {
  if (data.size() >= 2 && data[0] == 'P' && (data[1] == '5' || data[1] == '2')) {
    return PgmParser(path, data).parse();
  }
  if (data.size() >= 8 &&
      std::equal(kPngSignature, kPngSignature + 8, data.begin(),
                 [](unsigned char a, char b) { return a == static_cast<unsigned char>(b); })) {
    return decode_png(path, data);
  }
  throw std::runtime_error(path + ": cannot read image: not a PGM (P5/P2) or PNG file");
}

/// nav2_map_server's pixel-to-cell rule (see load_ros_map).
std::int8_t cell_value(const std::uint8_t* p, int channels, const MapMeta& m) {
  int sum = 0, n = 3;
  int alpha = 255;
  switch (channels) {
    case 1:
      sum = 3 * p[0];
      break;
    case 2:
      sum = 3 * p[0];
      alpha = p[1];
      break;
    case 3:
      sum = p[0] + p[1] + p[2];
      break;
    default:
      sum = p[0] + p[1] + p[2];
      alpha = p[3];
      break;
  }
  const bool has_alpha = channels == 2 || channels == 4;
  if (m.mode == MapMode::kTrinary && has_alpha) {
    sum += alpha;
    n = 4;
  }
  const double shade = static_cast<double>(sum) / n / 255.0;
  const double occ = m.negate ? shade : 1.0 - shade;
  switch (m.mode) {
    case MapMode::kTrinary:
      if (m.occupied < occ) return 100;
      if (occ < m.free) return 0;
      return -1;
    case MapMode::kScale:
      if (alpha != 255) return -1;
      if (m.occupied < occ) return 100;
      if (occ < m.free) return 0;
      return static_cast<std::int8_t>(std::rint((occ - m.free) / (m.occupied - m.free) * 100.0));
    case MapMode::kRaw: {
      const double percent = std::round(shade * 255.0);
      return percent >= 0.0 && percent <= 100.0 ? static_cast<std::int8_t>(percent) : -1;
    }
  }
  return -1;
}

// ---------------------------------------------------------------------------------------------
// Drawing

/// Clips the segment a-b to the rectangle [0, w] x [0, h] (Liang-Barsky); false if it misses.
bool clip_segment(cv::Point2d& a, cv::Point2d& b, double w, double h) {
  const double dx = b.x - a.x, dy = b.y - a.y;
  double t0 = 0.0, t1 = 1.0;
  const double p[4] = {-dx, dx, -dy, dy};
  const double q[4] = {a.x, w - a.x, a.y, h - a.y};
  for (int i = 0; i < 4; ++i) {
    if (p[i] == 0.0) {
      if (q[i] < 0.0) return false;
      continue;
    }
    const double t = q[i] / p[i];
    if (p[i] < 0.0) {
      t0 = std::max(t0, t);
    } else {
      t1 = std::min(t1, t);
    }
    if (t0 > t1) return false;
  }
  const cv::Point2d a0 = a;
  a = a0 + t0 * (b - a0);
  b = a0 + t1 * (b - a0);
  // Poses near the double range can overflow on the way: drop such segments.
  return std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(b.x) && std::isfinite(b.y);
}

cv::Mat draw_map(const GridMap& map, const std::vector<TimedPose>& trajectory,
                 const OccupancyThresholds& th, const std::string& path) {
  const GreyLevels g = grey_levels(th);
  const Raster r = render(map, th, g, path);
  cv::Mat img(r.height, r.width, CV_8UC3);
  const int u = g.unknown;
  const cv::Vec3b tint(static_cast<std::uint8_t>(std::min(u + 15, 255)),
                       static_cast<std::uint8_t>(u),
                       static_cast<std::uint8_t>(std::max(u - 15, 0)));  // BGR
  for (int row = 0; row < r.height; ++row) {
    auto* out = img.ptr<cv::Vec3b>(row);
    for (int col = 0; col < r.width; ++col) {
      const auto j = static_cast<std::size_t>(row) * r.width + col;
      const std::uint8_t x = r.grey[j];
      out[col] = r.known[j] ? cv::Vec3b(x, x, x) : tint;
    }
  }

  // Continuous image coordinates of a pose: pixel (c, r) covers [c, c+1) x [r, r+1).
  const double cs = map.cell_size();
  const auto to_image = [&](const Pose2& p) {
    return cv::Point2d(p.x / cs - r.min.x, (r.max_y + 1.0) - p.y / cs);
  };
  const auto finite = [](const cv::Point2d& p) { return std::isfinite(p.x) && std::isfinite(p.y); };
  const auto pixel = [&](const cv::Point2d& p) {
    return cv::Point(std::clamp(static_cast<int>(std::floor(p.x)), 0, r.width - 1),
                     std::clamp(static_cast<int>(std::floor(p.y)), 0, r.height - 1));
  };
  const auto inside = [&](const cv::Point2d& p) {
    return p.x >= 0.0 && p.x < r.width && p.y >= 0.0 && p.y < r.height;
  };
  const double w = r.width, h = r.height;
  const cv::Scalar red(0, 0, 255), green(0, 255, 0), blue(255, 0, 0);
  bool have_prev = false, have_first = false;
  cv::Point2d prev, first, last;
  for (const TimedPose& tp : trajectory) {
    const cv::Point2d p = to_image(tp.pose);
    if (!finite(p)) {
      have_prev = false;
      continue;
    }
    if (!have_first) {
      first = p;
      have_first = true;
    }
    last = p;
    cv::Point2d a = have_prev ? prev : p, b = p;
    if (clip_segment(a, b, w, h)) cv::line(img, pixel(a), pixel(b), red, 1, cv::LINE_8);
    prev = p;
    have_prev = true;
  }
  if (have_first && inside(first)) cv::circle(img, pixel(first), 3, green, cv::FILLED, cv::LINE_8);
  if (have_first && inside(last)) cv::circle(img, pixel(last), 3, blue, cv::FILLED, cv::LINE_8);
  return img;
}

}  // namespace

// -----------------------------------------------------------------------------------------------

void write_file_atomically(const std::string& path, const std::string& contents) {
  static std::atomic<std::uint64_t> counter{0};
  const std::string tmp =
      path + ".tmp." + std::to_string(::getpid()) + "." + std::to_string(counter++);
  const std::string prefix = "cannot write '" + path + "': ";
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (f == nullptr) {
    throw std::runtime_error(prefix + "cannot create '" + tmp + "': " + errno_text(errno));
  }
  int err = 0;
  if (!contents.empty() && std::fwrite(contents.data(), 1, contents.size(), f) != contents.size()) {
    err = errno != 0 ? errno : EIO;
  }
  if (std::fflush(f) != 0 && err == 0) err = errno != 0 ? errno : EIO;
  if (std::fclose(f) != 0 && err == 0) err = errno != 0 ? errno : EIO;
  if (err == 0 && std::rename(tmp.c_str(), path.c_str()) != 0) err = errno != 0 ? errno : EIO;
  if (err != 0) {
    std::remove(tmp.c_str());
    throw std::runtime_error(prefix + errno_text(err));
  }
}

void save_ros_map(const GridMap& map, const std::string& dir, const std::string& name,
                  const OccupancyThresholds& th) {
  if (!valid_map_name(name)) {
    throw std::invalid_argument("map name '" + name +
                                "' must be non-empty and use only [A-Za-z0-9._-]");
  }
  const GreyLevels g = grey_levels(th);
  const fs::path base = fs::path(dir);
  const std::string pgm_path = (base / (name + ".pgm")).string();
  const std::string yaml_path = (base / (name + ".yaml")).string();
  const Raster r = render(map, th, g, pgm_path);

  if (!dir.empty()) {
    std::error_code ec;
    fs::create_directories(base, ec);
    if (ec) throw std::runtime_error("cannot create directory '" + dir + "': " + ec.message());
  }

  std::string pgm = "P5\n" + std::to_string(r.width) + " " + std::to_string(r.height) + "\n255\n";
  pgm.append(r.grey.begin(), r.grey.end());
  write_file_atomically(pgm_path, pgm);

  const double cs = map.cell_size();
  std::string yaml;
  yaml += "image: " + name + ".pgm\n";
  yaml += "mode: trinary\n";
  yaml += "resolution: " + format_double(cs) + "\n";
  yaml +=
      "origin: [" + format_double(r.min.x * cs) + ", " + format_double(r.min.y * cs) + ", 0.0]\n";
  yaml += "negate: 0\n";
  yaml += "occupied_thresh: " + format_double(th.occupied) + "\n";
  yaml += "free_thresh: " + format_double(th.free) + "\n";
  write_file_atomically(yaml_path, yaml);
}

namespace {

/// The cells of a map from its parsed YAML and decoded image (load_ros_map's last step).
OccupancyImage occupancy_image(const MapMeta& m, const Pixels& px) {
  OccupancyImage out;
  out.resolution = m.resolution;
  out.origin_x = m.origin[0];
  out.origin_y = m.origin[1];
  out.origin_theta = m.origin[2];
  out.width = px.width;
  out.height = px.height;
  out.cells.resize(static_cast<std::size_t>(px.width) * static_cast<std::size_t>(px.height));
  const auto w = static_cast<std::size_t>(px.width);
  const auto ch = static_cast<std::size_t>(px.channels);
  for (std::size_t row = 0; row < static_cast<std::size_t>(px.height); ++row) {
    const std::uint8_t* in = px.data.data() + row * w * ch;
    std::int8_t* cells = out.cells.data() + (static_cast<std::size_t>(px.height) - 1 - row) * w;
    for (std::size_t col = 0; col < w; ++col)
      cells[col] = cell_value(in + col * ch, px.channels, m);
  }
  return out;
}

}  // namespace

OccupancyImage load_ros_map(const std::string& yaml_path) {
  const MapMeta m =
      parse_map_yaml(read_whole_file(yaml_path, kMaxYamlBytes, "map file"), yaml_path);
  const std::string image = m.image.string();
  const std::string data =
      read_whole_file(image, kMaxImageBytes, "image", " named in " + yaml_path);
  return occupancy_image(m, decode_image(image, data));
}

OccupancyImage parse_ros_map(std::string_view yaml_text, std::string_view image_bytes,
                             const std::string& yaml_name) {
  if (yaml_text.size() > kMaxYamlBytes) {
    throw std::runtime_error(yaml_name +
                             ": cannot read map file: " + std::to_string(yaml_text.size()) +
                             " bytes, more than the " + std::to_string(kMaxYamlBytes) + " allowed");
  }
  const MapMeta m = parse_map_yaml(std::string(yaml_text), yaml_name);
  const std::string image = m.image.string();
  if (image_bytes.size() > kMaxImageBytes) {
    throw std::runtime_error(image + ": cannot read image named in " + yaml_name + ": " +
                             std::to_string(image_bytes.size()) + " bytes, more than the " +
                             std::to_string(kMaxImageBytes) + " allowed");
  }
  return occupancy_image(m, decode_image(image, std::string(image_bytes)));
}

void save_map_png(const GridMap& map, const std::vector<TimedPose>& trajectory,
                  const std::string& path, const OccupancyThresholds& th) {
  const cv::Mat img = draw_map(map, trajectory, th, path);
  std::vector<std::uint8_t> png;
  try {
    if (!cv::imencode(".png", img, png)) {
      throw std::runtime_error("cannot write '" + path + "': PNG encoding failed");
    }
  } catch (const cv::Exception& e) {
    throw std::runtime_error("cannot write '" + path + "': PNG encoding failed: " + e.what());
  }
  write_file_atomically(path, std::string(png.begin(), png.end()));
}

}  // namespace esfleet
