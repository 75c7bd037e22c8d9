#include "map_publisher.hpp"

#include "esfleet/core/clock.hpp"
#include "esfleet/dds/to_msg.hpp"

namespace esfleet::leader {

MapPublisher::MapPublisher(dds::Node& node, mapshare::MapIdentity id, std::string robot_id,
                           TileEncoding encoding, mapshare::DeltaPolicy policy)
    : robot_id_(std::move(robot_id)),
      sender_(std::move(id), encoding, policy),
      tiles_(node),
      deltas_(node),
      meta_(node),
      pose_(node, robot_id_) {}

void MapPublisher::publish(GridMap& map, const TimedPose& pose, float fitness, bool complete,
                           std::uint32_t scans, const std::string& params_json) {
  publish_map(map, pose.stamp, complete, scans, params_json);
  pose_.write(dds::pose_to_msg(robot_id_, pose, fitness, msg::kStatusMapping));
  count_bytes();
}

void MapPublisher::publish_map(GridMap& map, double stamp, bool complete, std::uint32_t scans,
                               const std::string& params_json) {
  // A follower that joined since the last publish holds the whole copies (transient-local),
  // which may be up to full_period old, and cannot apply deltas against newer versions.
  const int readers = tiles_.matched_readers();
  const bool joined = readers > tile_readers_;
  tile_readers_ = readers;
  const auto now = static_cast<std::uint64_t>(realtime_ns());
  mapshare::Publication out =
      sender_.publish(map, stamp, complete, joined, scans, params_json, now);
  // Each tile and delta in parts that fit in one RTPS message (dds::kTilePartBytes): Fast DDS
  // never fragments them (docs/faults.md, "Fragmented tiles and the Fast DDS GAP bug").
  const auto write_parts = [](auto& writer, auto parts) {
    bool ok = true;
    for (const auto& part : parts) ok = writer.write(part) && ok;
    return ok;
  };
  for (mapshare::TileMessage& t : out.tiles) {
    if (t.is_delta()) {
      if (write_parts(deltas_, dds::delta_to_msgs(std::move(t)))) ++stats_.deltas;
    } else if (write_parts(tiles_, dds::tile_to_msgs(std::move(t)))) {
      ++stats_.tiles;
    }
  }
  meta_.write(dds::meta_to_msg(out.meta));
  ++stats_.publishes;
  if (out.joiner_refresh) ++stats_.joiner_refreshes;
  count_bytes();
  const GridMap::Bounds b = map.known_bounds();
  if (!b.empty) {
    const auto cells = static_cast<std::uint64_t>(b.max.x - b.min.x + 1) *
                       static_cast<std::uint64_t>(b.max.y - b.min.y + 1);
    stats_.full_map_bytes += cells + 100;
  }
}

void MapPublisher::count_bytes() {
  stats_.tile_bytes = tiles_.bytes_written();
  stats_.delta_bytes = deltas_.bytes_written();
  stats_.meta_bytes = meta_.bytes_written();
  stats_.pose_bytes = pose_.bytes_written();
  stats_.write_failures = tiles_.write_failures() + deltas_.write_failures() +
                          meta_.write_failures() + pose_.write_failures();
}

bool MapPublisher::flush(std::chrono::milliseconds timeout) {
  return tiles_.wait_for_acknowledgments(timeout) && deltas_.wait_for_acknowledgments(timeout) &&
         meta_.wait_for_acknowledgments(timeout);
}

}  // namespace esfleet::leader
