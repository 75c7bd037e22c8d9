#include "esfleet/core/ros_map_reader.hpp"

#include <cmath>
#include <filesystem>
#include <stdexcept>

#include <yaml-cpp/yaml.h>

#include "esfleet/core/file_io.hpp"
#include "image_decoder.hpp"

namespace esfleet {
namespace {

namespace fs = std::filesystem;
using detail::Pixels;

constexpr std::uintmax_t kMaxYamlBytes = 1u << 20;
// A P2 file of kMaxMapImagePixels 3-digit samples fits; a PNG of that size is far smaller.
constexpr std::uintmax_t kMaxImageBytes = std::uintmax_t{512} << 20;

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
  return occupancy_image(m, detail::decode_image(image, data));
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
  return occupancy_image(m, detail::decode_image(image, std::string(image_bytes)));
}

}  // namespace esfleet
