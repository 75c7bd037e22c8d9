#include "map_follower.hpp"

#include <spdlog/spdlog.h>

namespace esfleet::follower {

MapFollower::MapFollower(dds::Node& node, std::string map_id, GridMapConfig local)
    : replica_(std::move(map_id), local),
      tiles_(node, [this](const msg::MapTile& t,
                          const dds::SampleMeta& m) { push_tile(t, m.writer_guid); }),
      deltas_(node, [this](const msg::MapTileDelta& d,
                           const dds::SampleMeta& m) { push_tile(d, m.writer_guid); }),
      meta_(node, [this](const msg::MapMeta& t, const dds::SampleMeta& m) {
        push({t, m.writer_guid});
      }) {}

template <class Msg>
void MapFollower::push_tile(const Msg& m, const std::string& writer) {
  if (m.payload().size() <= dds::kMaxTilePayloadBytes) {
    push({m, writer});
    return;
  }
  Msg key;  // no copy of the payload: a hostile peer's 100 MB sample must not pile up here
  key.map_id(m.map_id());
  key.tx(m.tx());
  key.ty(m.ty());
  push({key, writer, m.payload().size()});
}

void MapFollower::push(Received r) {
  {
    std::lock_guard lock(mutex_);
    queue_.push_back(std::move(r));
  }
  cv_.notify_one();
}

bool MapFollower::spin_once(std::chrono::milliseconds timeout) {
  std::deque<Received> batch;
  {
    std::unique_lock lock(mutex_);
    cv_.wait_for(lock, timeout, [this] { return !queue_.empty(); });
    batch.swap(queue_);
  }
  const std::uint64_t applied_before = stats_.tiles_applied + stats_.deltas_applied;
  for (const Received& r : batch) handle(r);
  stats_.bytes_received =
      tiles_.bytes_received() + deltas_.bytes_received() + meta_.bytes_received();
  return stats_.tiles_applied + stats_.deltas_applied != applied_before;
}

void MapFollower::handle(const Received& r) {
  std::string error;
  const auto oversized = [&r](const auto& m, const char* what) {
    return std::string(what) + " (" + std::to_string(m.tx()) + ", " + std::to_string(m.ty()) +
           ") dropped: payload of " + std::to_string(r.oversized) + " bytes, more than the " +
           std::to_string(dds::kMaxTilePayloadBytes) + " any tile can need";
  };
  if (r.oversized > 0) {
    if (const auto* tile = std::get_if<msg::MapTile>(&r.sample)) {
      ++stats_.tiles_received;
      ++stats_.tiles_rejected;
      log_once(r.writer, "tile", oversized(*tile, "tile"));
    } else if (const auto* delta = std::get_if<msg::MapTileDelta>(&r.sample)) {
      ++stats_.deltas_received;
      ++stats_.deltas_rejected;
      log_once(r.writer, "delta", oversized(*delta, "tile delta"));
    }
    return;
  }
  if (const auto* tile = std::get_if<msg::MapTile>(&r.sample)) {
    ++stats_.tiles_received;
    switch (replica_.apply(*tile, &error)) {
      case dds::Applied::kApplied: {
        ++stats_.tiles_applied;
        const auto now = dds::realtime_ns();
        stats_.latency_ms.push_back(
            static_cast<double>(now - static_cast<std::int64_t>(tile->leader_stamp_ns())) / 1e6);
        break;
      }
      case dds::Applied::kStale:
        ++stats_.tiles_stale;
        // An equal version is normal (the leader resends a tile whole at the version a delta
        // brought); an older one comes from a stale or hostile sender.
        if (const Tile* held = replica_.map().find_tile({tile->tx(), tile->ty()});
            held != nullptr && held->version > tile->version()) {
          log_once(r.writer, "stale tile",
                   "tile (" + std::to_string(tile->tx()) + ", " + std::to_string(tile->ty()) +
                       ") version " + std::to_string(tile->version()) + " is older than the " +
                       std::to_string(held->version) + " held: ignored");
        }
        break;
      case dds::Applied::kIgnored:
        ++stats_.tiles_ignored;
        break;
      case dds::Applied::kRejected:
      case dds::Applied::kNeedsBase:  // not returned for whole tiles
        ++stats_.tiles_rejected;
        log_once(r.writer, "tile",
                 "tile (" + std::to_string(tile->tx()) + ", " + std::to_string(tile->ty()) +
                     ") dropped: " + error);
        break;
    }
  } else if (const auto* delta = std::get_if<msg::MapTileDelta>(&r.sample)) {
    ++stats_.deltas_received;
    switch (replica_.apply(*delta, &error)) {
      case dds::Applied::kApplied: {
        ++stats_.deltas_applied;
        const auto now = dds::realtime_ns();
        stats_.latency_ms.push_back(
            static_cast<double>(now - static_cast<std::int64_t>(delta->leader_stamp_ns())) / 1e6);
        break;
      }
      case dds::Applied::kStale:
        ++stats_.deltas_stale;
        break;
      case dds::Applied::kNeedsBase:
        ++stats_.deltas_needs_base;
        break;
      case dds::Applied::kIgnored:
        ++stats_.deltas_ignored;
        break;
      case dds::Applied::kRejected:
        ++stats_.deltas_rejected;
        log_once(r.writer, "delta",
                 "tile delta (" + std::to_string(delta->tx()) + ", " + std::to_string(delta->ty()) +
                     ") dropped: " + error);
        break;
    }
  } else {
    ++stats_.meta_received;
    if (replica_.apply(std::get<msg::MapMeta>(r.sample), &error) == dds::Applied::kRejected) {
      ++stats_.meta_rejected;
      log_once(r.writer, "meta", "map summary dropped: " + error);
    }
  }
}

void MapFollower::log_once(const std::string& writer, const char* kind, const std::string& what) {
  // One line per writer and kind of sample: a hostile peer cannot flood the log (nor, with
  // ever new writer ids, the memory: at most kMaxLogged writers are remembered).
  constexpr std::size_t kMaxLogged = 1000;
  if (logged_.size() >= kMaxLogged) return;
  if (!logged_.insert(writer + "|" + kind).second) return;
  spdlog::warn("from writer {}: {} (further ones from this writer are counted, not logged)", writer,
               what);
}

}  // namespace esfleet::follower
