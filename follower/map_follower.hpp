#pragma once
// The follower's side of map sharing: DDS callbacks hand received tiles, tile deltas and
// summaries to the
// application thread through a locked queue; the application thread applies them to a
// MapReplica, counts what it dropped (logging once per sending writer and kind of drop) and
// measures the tile latency (leader publish -> applied here).
//
// Hostile peers: a sample whose payload exceeds kMaxTilePayloadBytes is not queued (only its
// key, to count and log it), so the queue holds at most plausible tiles; everything else is
// judged by MapReplica. Rejected and stale samples never change the map.

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <mutex>
#include <set>
#include <string>
#include <variant>
#include <vector>

#include "esfleet/dds/map_convert.hpp"
#include "esfleet/dds/reader.hpp"

namespace esfleet::follower {

struct FollowStats {
  std::uint64_t tiles_received = 0;
  std::uint64_t tiles_applied = 0;
  std::uint64_t tiles_stale = 0;     ///< version not newer than held (duplicates, stale senders)
  std::uint64_t tiles_ignored = 0;   ///< other map id / older epoch
  std::uint64_t tiles_rejected = 0;  ///< malformed or oversized (see MapReplica::apply)
  std::uint64_t deltas_received = 0;
  std::uint64_t deltas_applied = 0;
  std::uint64_t deltas_stale = 0;
  std::uint64_t deltas_needs_base = 0;  ///< base missing: the next whole tile brings the tile up
  std::uint64_t deltas_ignored = 0;     ///< other map id / older epoch
  std::uint64_t deltas_rejected = 0;
  std::uint64_t meta_received = 0;
  std::uint64_t meta_rejected = 0;
  std::uint64_t bytes_received = 0;
  /// Per applied tile or delta: leader publish -> applied here.
  std::vector<double> latency_ms;
};

class MapFollower {
 public:
  MapFollower(dds::Node& node, std::string map_id, GridMapConfig local = {});

  /// Applies what arrived (waiting up to `timeout` for something); returns true if the map
  /// changed (a tile or a delta was applied).
  bool spin_once(std::chrono::milliseconds timeout);

  const dds::MapReplica& replica() const { return replica_; }
  const FollowStats& stats() const { return stats_; }
  int matched_leaders() const { return tiles_.matched_writers(); }

 private:
  struct Received {
    std::variant<msg::MapTile, msg::MapTileDelta, msg::MapMeta> sample;
    std::string writer;
    /// Payload size of a sample dropped in the callback for exceeding kMaxTilePayloadBytes
    /// (`sample` then holds its key only); 0 otherwise.
    std::size_t oversized = 0;
  };
  /// Queues a tile or delta, or only its key when its payload is oversized.
  template <class Msg>
  void push_tile(const Msg& m, const std::string& writer);
  void push(Received r);
  void handle(const Received& r);
  void log_once(const std::string& writer, const char* kind, const std::string& what);

  dds::MapReplica replica_;
  FollowStats stats_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<Received> queue_;
  std::set<std::string> logged_;
  // Readers last: they are destroyed first, so no callback runs into a dead queue.
  dds::TileReader tiles_;
  dds::TileDeltaReader deltas_;
  dds::MetaReader meta_;
};

}  // namespace esfleet::follower
