#include "served_map.hpp"

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <system_error>
#include <type_traits>

#include <nlohmann/json.hpp>

#include "esfleet/core/ros_map_format.hpp"
#include "esfleet/core/ros_map_reader.hpp"

namespace esfleet::leader {

namespace fs = std::filesystem;

namespace {

/// `path` without a trailing separator ("out/" -> "out"), so that parent_path() is the parent.
fs::path trimmed(const std::string& path) {
  fs::path p(path);
  if (!p.has_filename() && p.has_parent_path()) p = p.parent_path();
  return p;
}

/// The map layout the checkpoint's manifest records in its parameters (cell_size, tile_edge),
/// over `config`. A manifest that cannot be read is left to read_checkpoint to report.
void adopt_checkpoint_layout(const fs::path& manifest, GridMapConfig& config) {
  std::ifstream in(manifest, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  const nlohmann::json m = nlohmann::json::parse(text.str(), nullptr, false);
  if (m.is_discarded() || !m.is_object() || !m.contains("parameters")) return;
  const nlohmann::json& p = m["parameters"];
  auto number = [&](const char* name, auto& field) {
    if (!p.is_object() || !p.contains(name) || !p[name].is_string()) return;
    const std::string v = p[name].get<std::string>();
    try {
      std::size_t used = 0;
      if constexpr (std::is_same_v<std::remove_reference_t<decltype(field)>, int>) {
        field = std::stoi(v, &used);
      } else {
        field = std::stod(v, &used);
      }
      if (used != v.size()) throw std::invalid_argument("trailing characters");
    } catch (const std::exception&) {
      throw std::runtime_error(manifest.string() + ": field 'parameters." + name + "' is '" + v +
                               "', not a number");
    }
  };
  number("cell_size", config.cell_size);
  number("tile_edge", config.tile_edge);
}

ServedMap load_checkpoint_map(const std::string& path, const fs::path& checkpoint_dir,
                              SlamConfig slam) {
  ServedMap s;
  s.kind = ServedMapKind::kCheckpoint;
  s.path = path;
  s.file = (checkpoint_dir / "manifest.json").string();
  const fs::path parent =
      checkpoint_dir.parent_path().empty() ? fs::path(".") : checkpoint_dir.parent_path();
  s.dirs = {checkpoint_dir.string(), parent.string()};
  adopt_checkpoint_layout(checkpoint_dir / "manifest.json", slam.map);
  slam.loop.enabled = false;  // nothing is mapped; the saved state is restored but not used
  try {
    slam.map.validate();
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(s.file + ": " + e.what());
  }
  Slam loaded(slam);
  const Resumed r = read_checkpoint(checkpoint_dir.string(), loaded);
  s.checkpoint = r.info;
  s.map = std::move(loaded.map());
  return s;
}

ServedMap load_yaml_map(const std::string& path, const SlamConfig& slam) {
  ServedMap s;
  s.kind = ServedMapKind::kRosYaml;
  s.path = path;
  s.file = path;
  const fs::path dir = trimmed(path).parent_path();
  s.dirs = {dir.empty() ? std::string(".") : dir.string()};
  const OccupancyImage image = load_ros_map(path);
  try {
    s.placement = occupancy_placement(image);
    s.origin_theta = image.origin_theta;
    s.map = grid_from_occupancy(image, slam.map);
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(path + ": " + e.what());
  }
  return s;
}

}  // namespace

const char* to_string(ServedMapKind kind) {
  return kind == ServedMapKind::kCheckpoint ? "checkpoint" : "ros_yaml";
}

ServedMap load_served_map(const std::string& path, SlamConfig slam) {
  std::error_code ec;
  const fs::path p = trimmed(path);
  const fs::file_status st = fs::status(p, ec);
  if (!fs::exists(st)) throw std::runtime_error(path + ": no such file or directory");
  if (!fs::is_directory(st)) return load_yaml_map(path, slam);
  if (fs::exists(p / "checkpoint" / "manifest.json", ec)) {
    return load_checkpoint_map(path, p / "checkpoint", slam);
  }
  if (fs::exists(p / "manifest.json", ec)) return load_checkpoint_map(path, p, slam);
  std::string hint;
  if (fs::exists(p / "map.yaml", ec)) {
    hint = "; to serve its ROS map give " + (p / "map.yaml").string();
  }
  throw std::runtime_error(path + ": no checkpoint in this directory (neither " +
                           (p / "checkpoint" / "manifest.json").string() + " nor " +
                           (p / "manifest.json").string() + " exists)" + hint);
}

CellClasses cell_classes(const GridMap& map) {
  CellClasses c;
  const GridMap::Bounds b = map.known_bounds();
  if (b.empty) return c;
  for (const TileKey& key : map.tile_keys()) {
    const Tile* tile = map.find_tile(key);
    for (std::size_t i = 0; i < tile->hit.size(); ++i) {
      const std::int8_t v = ros_cell_value(tile->hit[i], tile->err[i]);
      if (v == 100) ++c.occupied;
      if (v == 0) ++c.free;
    }
  }
  const auto box = static_cast<std::uint64_t>(std::int64_t{b.max.x} - b.min.x + 1) *
                   static_cast<std::uint64_t>(std::int64_t{b.max.y} - b.min.y + 1);
  c.unknown = box - c.occupied - c.free;
  return c;
}

}  // namespace esfleet::leader
