#include "ros_map_output.hpp"

#include <vector>

#include "esfleet/core/clock.hpp"

namespace esfleet::leader {
namespace {

/// Updates per publish at most (the /map_updates writer keeps 16); more rows of changed tiles go
/// as one rectangle around them all.
constexpr std::size_t kMaxUpdatesPerPublish = 12;

/// The ROS values of a tile's cells, row-major as the tile stores them.
std::vector<std::int8_t> tile_values(const Tile& tile, const OccupancyThresholds& th) {
  std::vector<std::int8_t> v(tile.hit.size());
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = ros_cell_value(tile.hit[i], tile.err[i], th);
  return v;
}

}  // namespace

nlohmann::json RosMapStats::json() const {
  return {{"maps", maps},
          {"map_bytes", map_bytes},
          {"updates", updates},
          {"update_bytes", update_bytes},
          {"maps_because_grown", grown},
          {"maps_for_joiners", for_joiners},
          {"changed_tile_cells", changed_tile_cells},
          {"bytes_total", map_bytes + update_bytes},
          {"whole_map_every_publish_bytes", whole_every_publish_bytes},
          {"cpu_s", cpu_s}};
}

RosMapOutput::RosMapOutput(dds::Node& node, std::string frame, double map_period_s,
                           OccupancyThresholds thresholds)
    : frame_(std::move(frame)),
      period_s_(map_period_s),
      thresholds_(thresholds),
      map_(node, dds::ros_map_endpoint()),
      updates_(node, dds::ros_map_updates_endpoint()) {}

void RosMapOutput::send_map(const GridMap& map, double stamp) {
  window_ = dds::map_window(map);
  const std::uint64_t before = map_.bytes_written();
  map_.write(dds::grid_to_ros(map, window_, thresholds_, stamp, frame_));
  stats_.map_bytes += map_.bytes_written() - before;
  ++stats_.maps;
  last_map_stamp_ = stamp;
  sent_any_ = true;
}

void RosMapOutput::send_update(const GridMap& map, const dds::RosGridWindow& rect, double stamp) {
  const std::uint64_t before = updates_.bytes_written();
  updates_.write(dds::update_to_ros(map, window_, rect, thresholds_, stamp, frame_));
  stats_.update_bytes += updates_.bytes_written() - before;
  ++stats_.updates;
}

std::vector<TileKey> RosMapOutput::changed_tiles(const GridMap& map) {
  std::vector<TileKey> changed;
  for (const TileKey& key : map.tile_keys()) {
    const Tile& tile = *map.find_tile(key);
    auto [it, added] = sent_.try_emplace(key);
    if (!added && it->second.version == tile.version) continue;
    it->second.version = tile.version;
    std::vector<std::int8_t> values = tile_values(tile, thresholds_);
    if (added || values != it->second.values) {
      it->second.values = std::move(values);
      changed.push_back(key);
    }
  }
  return changed;
}

void RosMapOutput::publish(const GridMap& map, double stamp, bool whole) {
  const double cpu0 = thread_cpu_seconds();
  const std::vector<TileKey> changed = changed_tiles(map);
  const dds::RosGridWindow rect = dds::tiles_window(map, changed);
  const bool grown = sent_any_ && !changed.empty() && !window_.contains(rect);
  const int readers = map_.matched_readers();
  const bool joined = readers > readers_;
  readers_ = readers;
  const bool due = !sent_any_ || whole || grown || joined || stamp - last_map_stamp_ >= period_s_;
  if (due) {
    stats_.grown += grown ? 1 : 0;
    stats_.for_joiners += joined && !grown ? 1 : 0;
    send_map(map, stamp);
  }
  // Alongside a whole /map of the same window the update still goes out (same stamp), so that
  // a reader that keeps its first /map and applies updates misses nothing.
  if (!changed.empty() && !grown && window_.contains(rect)) {
    stats_.changed_tile_cells +=
        changed.size() * static_cast<std::uint64_t>(map.tile_edge()) * map.tile_edge();
    // One update per row of tiles (from the row's first changed tile to its last): few
    // messages, few unchanged cells; one rectangle around all when the rows are many.
    std::map<std::int32_t, std::vector<TileKey>> rows;
    for (const TileKey& key : changed) rows[key.ty].push_back(key);
    if (rows.size() > kMaxUpdatesPerPublish) {
      send_update(map, rect, stamp);
    } else {
      for (const auto& [ty, keys] : rows) send_update(map, dds::tiles_window(map, keys), stamp);
    }
  }
  // The same /map message at every publish: header + metadata + one byte per cell.
  stats_.whole_every_publish_bytes +=
      static_cast<std::uint64_t>(window_.width) * static_cast<std::uint64_t>(window_.height) + 120 +
      frame_.size();
  stats_.cpu_s += thread_cpu_seconds() - cpu0;
}

}  // namespace esfleet::leader
