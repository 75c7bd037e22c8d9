#include "map_publisher.hpp"

namespace esfleet::leader {

MapPublisher::MapPublisher(dds::Node& node, dds::MapIdentity id, std::string robot_id,
                           TileEncoding encoding)
    : id_(std::move(id)),
      robot_id_(std::move(robot_id)),
      encoding_(encoding),
      tiles_(node),
      meta_(node),
      pose_(node) {}

void MapPublisher::publish(GridMap& map, const TimedPose& pose, float fitness, bool complete,
                           std::uint32_t scans, const std::string& params_json) {
  const std::int64_t now = dds::realtime_ns();
  for (const TileKey k : map.take_dirty()) {
    if (map.find_tile(k) == nullptr) continue;
    if (tiles_.write(dds::tile_to_msg(map, k, id_, encoding_, now))) ++stats_.tiles;
  }
  meta_.write(dds::meta_to_msg(map, id_, complete, scans, params_json, now));
  pose_.write(dds::pose_to_msg(robot_id_, pose, fitness, msg::kStatusMapping));
  ++stats_.publishes;
  stats_.tile_bytes = tiles_.bytes_written();
  stats_.meta_bytes = meta_.bytes_written();
  stats_.pose_bytes = pose_.bytes_written();
  stats_.write_failures = tiles_.write_failures() + meta_.write_failures() + pose_.write_failures();
  const GridMap::Bounds b = map.known_bounds();
  if (!b.empty) {
    const auto cells = static_cast<std::uint64_t>(b.max.x - b.min.x + 1) *
                       static_cast<std::uint64_t>(b.max.y - b.min.y + 1);
    stats_.full_map_bytes += cells + 100;
  }
}

bool MapPublisher::flush(std::chrono::milliseconds timeout) {
  return tiles_.wait_for_acknowledgments(timeout) && meta_.wait_for_acknowledgments(timeout);
}

}  // namespace esfleet::leader
