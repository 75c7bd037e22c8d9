#include "map_publisher.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <exception>
#include <utility>

#include "esfleet/core/clock.hpp"
#include "esfleet/dds/to_msg.hpp"

namespace esfleet::leader {

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

}  // namespace

MapPublisher::MapPublisher(dds::Node& node, mapshare::MapIdentity id, std::string robot_id,
                           TileEncoding encoding, mapshare::DeltaPolicy policy)
    : robot_id_(std::move(robot_id)),
      tiles_(node),
      deltas_(node),
      meta_(node),
      pose_(node, robot_id_),
      sender_(std::move(id), encoding, policy),
      thread_([this] { run(); }) {}

MapPublisher::~MapPublisher() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  work_.notify_all();
  thread_.join();
}

void MapPublisher::publish(GridMap& map, const TimedPose& pose, float fitness, bool complete,
                           std::uint32_t scans, const std::string& params_json) {
  hand_over(map, pose.stamp, complete, scans, params_json,
            dds::pose_to_msg(robot_id_, pose, fitness, msg::kStatusMapping));
}

std::size_t MapPublisher::publish_map(GridMap& map, double stamp, bool complete,
                                      std::uint32_t scans, const std::string& params_json) {
  return hand_over(map, stamp, complete, scans, params_json, std::nullopt);
}

std::size_t MapPublisher::hand_over(GridMap& map, double stamp, bool complete, std::uint32_t scans,
                                    const std::string& params_json,
                                    std::optional<msg::RobotPose> pose) {
  const auto t0 = Clock::now();
  const auto now = static_cast<std::uint64_t>(realtime_ns());
  // The summary is made here, from the map as it is: its version sum is that of the tiles
  // handed over with it, which followers reach once those are written.
  msg::MapMeta meta = dds::meta_to_msg(
      mapshare::meta_message(map, sender_.id(), complete, scans, params_json, now));
  std::uint64_t full_map_bytes = 0;
  const GridMap::Bounds b = map.known_bounds();
  if (!b.empty) {
    full_map_bytes = static_cast<std::uint64_t>(b.max.x - b.min.x + 1) *
                         static_cast<std::uint64_t>(b.max.y - b.min.y + 1) +
                     100;
  }
  std::size_t copied = 0;
  {
    std::lock_guard lock(mutex_);
    copied = queue_.put_changed(map, now);
    next_.meta = std::move(meta);
    if (pose) next_.pose = std::move(pose);
    next_.layout = mapshare::tile_layout(map);
    next_.stamp = stamp;
    next_.complete = complete;
    if (!waiting_) waiting_since_ = t0;
    waiting_ = true;
    ++stats_.publishes;
    stats_.tiles_handed_over += copied;
    stats_.coalesced = queue_.coalesced();
    stats_.queue_high_water = queue_.high_water();
    stats_.full_map_bytes += full_map_bytes;
    stats_.handover_s += seconds_since(t0);
  }
  work_.notify_one();
  return copied;
}

void MapPublisher::republish_all(GridMap& map) {
  std::lock_guard lock(mutex_);
  map.mark_all_dirty();
  next_.forget_sent = true;  // taken with the copies of every tile, before they are encoded
}

bool MapPublisher::has_work() const { return waiting_ || !queue_.empty(); }

void MapPublisher::run() {
  while (true) {
    Round round;
    {
      std::unique_lock lock(mutex_);
      work_.wait(lock, [this] { return stop_ || has_work(); });
      if (stop_) return;
      stats_.max_wait_s = std::max(stats_.max_wait_s, seconds_since(waiting_since_));
      round = std::exchange(next_, Round{});
      round.tiles = queue_.take_all();
      waiting_ = false;
      writing_ = true;
    }
    try {
      write_round(round);
    } catch (const std::exception& e) {  // encoding a tile; should not happen
      spdlog::error("map publisher: {}", e.what());
    }
    {
      std::lock_guard lock(mutex_);
      writing_ = false;
      ++stats_.rounds;
      count_bytes();
    }
    written_.notify_all();
    wait_acknowledged();
  }
}

void MapPublisher::write_round(Round& round) {
  if (round.forget_sent) sender_.forget_sent();
  // Summary and pose first: small, and what a follower needs to know how far it is behind.
  if (round.meta) meta_.write(*round.meta);
  if (round.pose) pose_.write(*round.pose);
  // A follower that joined since the last round holds the whole copies (transient-local),
  // which may be up to full_period old, and cannot apply deltas against newer versions.
  const int readers = tiles_.matched_readers();
  const bool joined = readers > tile_readers_;
  tile_readers_ = readers;
  const auto t0 = Clock::now();
  std::vector<mapshare::TileMessage> out = encode(round, joined);
  const auto t1 = Clock::now();
  write_tiles(out);
  std::lock_guard lock(mutex_);
  if (joined) ++stats_.joiner_refreshes;
  stats_.encode_s += std::chrono::duration<double>(t1 - t0).count();
  stats_.write_s += seconds_since(t1);
}

std::vector<mapshare::TileMessage> MapPublisher::encode(const Round& round, bool joined) {
  std::vector<mapshare::TileMessage> out;
  for (const mapshare::TileCopy& t : round.tiles) {
    auto m = sender_.send(round.layout, t.counters(), round.stamp, round.complete, t.stamp_ns);
    if (m) out.push_back(std::move(*m));
  }
  if (round.complete || joined) {
    sender_.refresh_whole(round.layout, round.stamp, static_cast<std::uint64_t>(realtime_ns()),
                          out);
  }
  // Whole tiles ahead of the deltas: they are what a follower that missed a delta waits for.
  std::stable_partition(out.begin(), out.end(),
                        [](const mapshare::TileMessage& m) { return !m.is_delta(); });
  return out;
}

void MapPublisher::write_tiles(std::vector<mapshare::TileMessage>& out) {
  // Each tile and delta in parts that fit in one RTPS message (dds::kTilePartBytes): Fast DDS
  // never fragments them (docs/faults.md, "Fragmented tiles and the Fast DDS GAP bug").
  const auto write_parts = [](auto& writer, auto parts) {
    bool ok = true;
    for (const auto& part : parts) ok = writer.write(part) && ok;
    return ok;
  };
  std::uint64_t tiles = 0, deltas = 0;
  auto last_pose = Clock::now();
  for (mapshare::TileMessage& t : out) {
    // On a slow link a round takes seconds (writes wait for the interface): the newest pose
    // and summary handed over meanwhile go out between its tiles, not after them.
    if (Clock::now() - last_pose >= kPoseEvery) {
      write_newest_pose_and_meta();
      last_pose = Clock::now();
    }
    if (t.is_delta()) {
      if (write_parts(deltas_, dds::delta_to_msgs(std::move(t)))) ++deltas;
    } else if (write_parts(tiles_, dds::tile_to_msgs(std::move(t)))) {
      ++tiles;
    }
  }
  std::lock_guard lock(mutex_);
  stats_.tiles += tiles;
  stats_.deltas += deltas;
}

void MapPublisher::write_newest_pose_and_meta() {
  std::optional<msg::RobotPose> pose;
  std::optional<msg::MapMeta> meta;
  {
    std::lock_guard lock(mutex_);
    pose = std::exchange(next_.pose, std::nullopt);
    meta = std::exchange(next_.meta, std::nullopt);
    if (pose || meta) ++stats_.mid_round_updates;
  }
  if (meta) meta_.write(*meta);
  if (pose) pose_.write(*pose);
}

void MapPublisher::wait_acknowledged() {
  // In slices, so that stopping is quick; the summary writer is the last one written to.
  constexpr std::chrono::milliseconds kSlice{50};
  const auto t0 = Clock::now();
  bool acked = false, timed_out = false;
  while (!acked && !timed_out) {
    {
      std::lock_guard lock(mutex_);
      if (stop_) break;
    }
    acked = tiles_.wait_for_acknowledgments(kSlice) && deltas_.wait_for_acknowledgments(kSlice) &&
            meta_.wait_for_acknowledgments(kSlice);
    timed_out = Clock::now() - t0 >= kAckTimeout;
  }
  std::lock_guard lock(mutex_);
  stats_.ack_wait_s += seconds_since(t0);
  if (!acked && timed_out) ++stats_.ack_timeouts;
}

void MapPublisher::count_bytes() {
  stats_.tile_bytes = tiles_.bytes_written();
  stats_.delta_bytes = deltas_.bytes_written();
  stats_.meta_bytes = meta_.bytes_written();
  stats_.pose_bytes = pose_.bytes_written();
  stats_.write_failures = tiles_.write_failures() + deltas_.write_failures() +
                          meta_.write_failures() + pose_.write_failures();
}

PublishStats MapPublisher::stats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

bool MapPublisher::drain(std::chrono::milliseconds timeout) {
  std::unique_lock lock(mutex_);
  return written_.wait_for(lock, timeout, [this] { return !has_work() && !writing_; });
}

bool MapPublisher::flush(std::chrono::milliseconds timeout) {
  const auto until = Clock::now() + timeout;
  const auto left = [&] {
    return std::chrono::duration_cast<std::chrono::milliseconds>(
        std::max(until - Clock::now(), Clock::duration::zero()));
  };
  return drain(timeout) && tiles_.wait_for_acknowledgments(left()) &&
         deltas_.wait_for_acknowledgments(left()) && meta_.wait_for_acknowledgments(left());
}

}  // namespace esfleet::leader
