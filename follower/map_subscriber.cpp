#include "map_subscriber.hpp"

#include <spdlog/spdlog.h>

#include "esfleet/core/clock.hpp"
#include "esfleet/dds/from_msg.hpp"
#include "esfleet/dds/to_msg.hpp"

namespace esfleet::follower {

MapSubscriber::MapSubscriber(dds::Node& node, std::string map_id, GridMapConfig local)
    : replica_(std::move(map_id), local),
      tiles_(node, [this](const msg::MapTile& t,
                          const dds::SampleMeta& m) { push_tile(t, m.writer_guid); }),
      deltas_(node, [this](const msg::MapTileDelta& d,
                           const dds::SampleMeta& m) { push_tile(d, m.writer_guid); }),
      meta_(node, [this](const msg::MapMeta& t, const dds::SampleMeta& m) {
        push({t, m.writer_guid});
      }) {}

template <class Msg>
void MapSubscriber::push_tile(const Msg& m, const std::string& writer) {
  // Fast DDS already refuses samples longer than the type's bound (dds/src/endpoints.cpp), but
  // a part whose other fields are shorter than theirs can carry a few bytes more than
  // kTilePartBytes: refused here too, so that every queued part is one the leader could send.
  if (m.payload().size() <= dds::kTilePartBytes) {
    push({m, writer});
    return;
  }
  Msg key;  // no copy of the payload: a hostile peer's 100 MB sample must not pile up here
  key.map_id(m.map_id());
  key.tx(m.tx());
  key.ty(m.ty());
  push({key, writer, m.payload().size()});
}

void MapSubscriber::push(Received r) {
  {
    std::lock_guard lock(mutex_);
    queue_.push_back(std::move(r));
  }
  cv_.notify_one();
}

bool MapSubscriber::spin_once(std::chrono::milliseconds timeout) {
  std::deque<Received> batch;
  {
    std::unique_lock lock(mutex_);
    cv_.wait_for(lock, timeout, [this] { return !queue_.empty(); });
    batch.swap(queue_);
  }
  const std::uint64_t applied_before = stats_.applied();
  for (Received& r : batch) handle(r);
  stats_.bytes_received =
      tiles_.bytes_received() + deltas_.bytes_received() + meta_.bytes_received();
  return stats_.applied() != applied_before;
}

void MapSubscriber::handle(Received& r) {
  if (r.oversized > 0) {
    const auto drop = [&](const auto& m, bool delta, const char* kind, const char* what) {
      stats_.count_tile(delta, mapshare::Applied::kRejected);
      log_once(r.writer, kind,
               std::string(what) + " (" + std::to_string(m.tx()) + ", " + std::to_string(m.ty()) +
                   ") part dropped: payload of " + std::to_string(r.oversized) +
                   " bytes, more than the " + std::to_string(dds::kTilePartBytes) +
                   " a part holds (protocol " + std::to_string(dds::kProtocolVersion) + ")");
    };
    if (const auto* tile = std::get_if<msg::MapTile>(&r.sample)) {
      drop(*tile, false, "tile", "tile");
    } else if (const auto* delta = std::get_if<msg::MapTileDelta>(&r.sample)) {
      drop(*delta, true, "delta", "tile delta");
    }
    return;
  }
  if (auto* tile = std::get_if<msg::MapTile>(&r.sample)) {
    join_part(std::move(*tile), false, r.writer);
  } else if (auto* delta = std::get_if<msg::MapTileDelta>(&r.sample)) {
    join_part(std::move(*delta), true, r.writer);
  } else {
    std::string error;
    const mapshare::Applied outcome =
        replica_.apply(dds::meta_from_msg(std::get<msg::MapMeta>(r.sample)), &error);
    stats_.count_meta(outcome);
    if (outcome == mapshare::Applied::kRejected) {
      log_once(r.writer, "meta", "map summary dropped: " + error);
    }
  }
}

template <class Msg>
void MapSubscriber::join_part(Msg&& part, bool delta, const std::string& writer) {
  const std::int32_t tx = part.tx(), ty = part.ty();
  std::string error;
  dds::TilePartAssembler& parts = delta ? delta_parts_ : tile_parts_;
  if (std::optional<mapshare::TileMessage> t = parts.add(std::move(part), writer, &error)) {
    apply_tile(*t, writer);
  } else if (!error.empty()) {
    ++stats_.parts_rejected;
    stats_.count_tile(delta, mapshare::Applied::kRejected);
    log_once(
        writer, delta ? "delta" : "tile",
        fmt::format("{} ({}, {}) part dropped: {}", delta ? "tile delta" : "tile", tx, ty, error));
  }
}

void MapSubscriber::apply_tile(const mapshare::TileMessage& t, const std::string& writer) {
  using mapshare::Applied;
  std::string error;
  const Applied outcome = replica_.apply(t, &error);
  stats_.count_tile(t.is_delta(), outcome);
  const std::string where = fmt::format("({}, {})", t.tx, t.ty);
  switch (outcome) {
    case Applied::kApplied:
      if (record_applied_) {
        applied_.push_back({t.key(), t.stamp_ns});
      } else {
        stats_.latency_ms.push_back(
            static_cast<double>(realtime_ns() - static_cast<std::int64_t>(t.stamp_ns)) / 1e6);
      }
      break;
    case Applied::kStale:
      // An equal version is normal (the leader resends a tile whole at the version a delta
      // brought); an older whole tile comes from a stale or hostile sender.
      if (const Tile* held = replica_.map().find_tile(t.key());
          !t.is_delta() && held != nullptr && held->version > t.version) {
        log_once(writer, "stale tile",
                 "tile " + where + " version " + std::to_string(t.version) + " is older than the " +
                     std::to_string(held->version) + " held: ignored");
      }
      break;
    case Applied::kRejected:
      if (t.is_delta()) {
        log_once(writer, "delta", "tile delta " + where + " dropped: " + error);
      } else {
        log_once(writer, "tile", "tile " + where + " dropped: " + error);
      }
      break;
    case Applied::kNeedsBase:
      if (!t.is_delta()) log_once(writer, "tile", "tile " + where + " dropped: " + error);
      break;
    case Applied::kIgnored:
      break;
  }
}

void MapSubscriber::log_once(const std::string& writer, const char* kind, const std::string& what) {
  // One line per writer and kind of sample: a hostile peer cannot flood the log (nor, with
  // ever new writer ids, the memory: at most kMaxLogged writers are remembered).
  constexpr std::size_t kMaxLogged = 1000;
  if (logged_.size() >= kMaxLogged) return;
  if (!logged_.insert(writer + "|" + kind).second) return;
  spdlog::warn("from writer {}: {} (further ones from this writer are counted, not logged)", writer,
               what);
}

}  // namespace esfleet::follower
