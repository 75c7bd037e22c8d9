#include "map_publisher.hpp"

namespace esfleet::leader {

MapPublisher::MapPublisher(dds::Node& node, dds::MapIdentity id, std::string robot_id,
                           TileEncoding encoding, DeltaPolicy policy)
    : id_(std::move(id)),
      robot_id_(std::move(robot_id)),
      encoding_(encoding),
      policy_(policy),
      tiles_(node),
      deltas_(node),
      meta_(node),
      pose_(node, robot_id_) {}  // in the robot's partition (docs/security.md)

void MapPublisher::publish(GridMap& map, const TimedPose& pose, float fitness, bool complete,
                           std::uint32_t scans, const std::string& params_json) {
  const std::int64_t now = dds::realtime_ns();
  const double stamp = pose.stamp;
  for (const TileKey k : map.take_dirty()) {
    const Tile* tile = map.find_tile(k);
    if (tile == nullptr) continue;
    auto [it, is_new] = sent_.try_emplace(k);
    Sent& sent = it->second;
    if (!is_new && sent.version >= tile->version) continue;  // nothing new since the last send
    const bool whole = is_new || complete || sent.deltas_since_full + 1 >= policy_.full_every ||
                       stamp - sent.full_stamp >= policy_.full_period;
    send(map, k, sent, whole, stamp, now);
  }
  // A follower that joined since the last publish holds the whole copies (transient-local),
  // which may be up to full_period old, and cannot apply deltas against newer versions: bring
  // every whole copy to the newest version now, as at the end of the map.
  const int readers = tiles_.matched_readers();
  const bool joined = readers > tile_readers_;
  tile_readers_ = readers;
  if (joined) ++stats_.joiner_refreshes;
  if (complete || joined) {
    // Late joiners read only whole tiles: make every whole copy the newest version.
    for (auto& [k, sent] : sent_) {
      if (sent.full_version < sent.version && map.find_tile(k) != nullptr) {
        send(map, k, sent, true, stamp, now);
      }
    }
  }
  meta_.write(dds::meta_to_msg(map, id_, complete, scans, params_json, now));
  pose_.write(dds::pose_to_msg(robot_id_, pose, fitness, msg::kStatusMapping));
  ++stats_.publishes;
  stats_.tile_bytes = tiles_.bytes_written();
  stats_.delta_bytes = deltas_.bytes_written();
  stats_.meta_bytes = meta_.bytes_written();
  stats_.pose_bytes = pose_.bytes_written();
  stats_.write_failures = tiles_.write_failures() + deltas_.write_failures() +
                          meta_.write_failures() + pose_.write_failures();
  const GridMap::Bounds b = map.known_bounds();
  if (!b.empty) {
    const auto cells = static_cast<std::uint64_t>(b.max.x - b.min.x + 1) *
                       static_cast<std::uint64_t>(b.max.y - b.min.y + 1);
    stats_.full_map_bytes += cells + 100;
  }
}

void MapPublisher::send(const GridMap& map, TileKey k, Sent& sent, bool whole, double stamp,
                        std::int64_t now) {
  const Tile& tile = *map.find_tile(k);
  if (whole) {
    if (tiles_.write(dds::tile_to_msg(map, k, id_, encoding_, now))) ++stats_.tiles;
    sent.full_version = tile.version;
    sent.full_stamp = stamp;
    sent.deltas_since_full = 0;
  } else {
    if (deltas_.write(dds::tile_delta_to_msg(map, k, sent.version, sent.hit, sent.err, id_,
                                             encoding_, now))) {
      ++stats_.deltas;
    }
    ++sent.deltas_since_full;
  }
  // Updated even when DDS refused the write: the next delta builds on what the map held, and
  // followers that miss a link of the chain wait for the next whole tile.
  sent.version = tile.version;
  sent.hit = tile.hit;
  sent.err = tile.err;
}

bool MapPublisher::flush(std::chrono::milliseconds timeout) {
  return tiles_.wait_for_acknowledgments(timeout) && deltas_.wait_for_acknowledgments(timeout) &&
         meta_.wait_for_acknowledgments(timeout);
}

}  // namespace esfleet::leader
