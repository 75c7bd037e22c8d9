#include "ros_map_output.hpp"

#include <vector>

#include "esfleet/core/clock.hpp"

namespace esfleet::leader {

nlohmann::json RosMapStats::json() const {
  return {{"maps", maps},
          {"map_bytes", map_bytes},
          {"updates", updates},
          {"update_bytes", update_bytes},
          {"maps_because_grown", grown},
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

void RosMapOutput::publish(const GridMap& map, double stamp, bool whole) {
  const double cpu0 = thread_cpu_seconds();
  std::vector<TileKey> changed;
  for (const TileKey& key : map.tile_keys()) {
    const std::uint64_t v = map.find_tile(key)->version;
    auto [it, added] = sent_versions_.try_emplace(key, v);
    if (added || it->second != v) changed.push_back(key);
    it->second = v;
  }
  const dds::RosGridWindow rect = dds::tiles_window(map, changed);
  const bool grown = sent_any_ && !changed.empty() && !window_.contains(rect);
  const bool due = !sent_any_ || whole || grown || stamp - last_map_stamp_ >= period_s_;
  if (due) {
    stats_.grown += grown ? 1 : 0;
    send_map(map, stamp);
  }
  // With a whole /map of the same window the update still goes out (same stamp), so that a
  // reader that keeps its first /map and applies updates misses nothing.
  if (!changed.empty() && (!due || !grown) && sent_any_ && window_.contains(rect)) {
    const std::uint64_t before = updates_.bytes_written();
    updates_.write(dds::update_to_ros(map, window_, rect, thresholds_, stamp, frame_));
    stats_.update_bytes += updates_.bytes_written() - before;
    ++stats_.updates;
  }
  // The same /map message at every publish: header + metadata + one byte per cell.
  stats_.whole_every_publish_bytes +=
      static_cast<std::uint64_t>(window_.width) * static_cast<std::uint64_t>(window_.height) + 120 +
      frame_.size();
  stats_.cpu_s += thread_cpu_seconds() - cpu0;
}

}  // namespace esfleet::leader
