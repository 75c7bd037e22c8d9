#pragma once
// The follower's map-sharing transport: DDS callbacks hand received tiles, tile deltas and
// summaries to the application thread through a locked queue; the application thread converts
// them (dds/include/esfleet/dds/from_msg.hpp), joins the parts each tile and delta travels in
// (dds::TilePartAssembler: a part, never a fragment, is the unit Fast DDS sees), applies them to
// the protocol's MapReplica,
// counts what became of them (mapshare::ReceiveStats), logs each kind of drop once per sending
// writer and measures the tile latency (leader publish -> applied here).
//
// Hostile peers: Fast DDS refuses samples longer than the wire types' bounds before they reach
// the callbacks (dds/src/endpoints.cpp); a part whose payload still exceeds dds::kTilePartBytes
// is not queued (only its key, to count and log it), so the queue holds at most plausible parts;
// everything else is judged by TilePartAssembler and MapReplica. Rejected and stale samples
// never change the map.

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <mutex>
#include <set>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "esfleet/dds/from_msg.hpp"
#include "esfleet/dds/reader.hpp"
#include "esfleet/mapshare/map_replica.hpp"

namespace esfleet::follower {

struct FollowStats : mapshare::ReceiveStats {
  std::uint64_t bytes_received = 0;
  /// Tile and delta parts refused before joining (inconsistent parts, assembly bounds); each
  /// also counts as a rejected tile or delta.
  std::uint64_t parts_rejected = 0;
  /// Per applied tile or delta: leader publish -> applied here.
  std::vector<double> latency_ms;
};

class MapSubscriber {
 public:
  /// Creates the tile, delta and summary readers on `node` (which must outlive this object).
  /// `map_id` empty = follow the first map seen; `local` as for mapshare::MapReplica. Throws
  /// std::runtime_error naming the topic if DDS refuses.
  MapSubscriber(dds::Node& node, std::string map_id, GridMapConfig local = {});

  /// Applies what arrived (waiting up to `timeout` for something); returns true if the map
  /// changed (a tile or a delta was applied).
  bool spin_once(std::chrono::milliseconds timeout);

  /// A tile (whole or delta) applied to the replica, with the leader's publish stamp.
  struct AppliedTile {
    TileKey key;
    std::uint64_t stamp_ns = 0;
  };
  /// From now on, remember every applied tile for take_applied() (esfleet-view: it forwards
  /// the changed tiles) instead of adding its latency to stats().latency_ms, so that a
  /// long-running viewer's memory stays bounded.
  void record_applied() { record_applied_ = true; }
  /// The tiles applied since the last call, in order (a tile may appear more than once).
  std::vector<AppliedTile> take_applied() { return std::exchange(applied_, {}); }

  const mapshare::MapReplica& replica() const { return replica_; }
  const FollowStats& stats() const { return stats_; }
  int matched_leaders() const { return tiles_.matched_writers(); }
  /// Map samples dropped for another protocol version (dds::Reader logs each writer once).
  std::uint64_t protocol_mismatches() const {
    return tiles_.protocol_mismatches() + deltas_.protocol_mismatches() +
           meta_.protocol_mismatches();
  }

 private:
  struct Received {
    std::variant<msg::MapTile, msg::MapTileDelta, msg::MapMeta> sample;
    std::string writer;
    /// Payload size of a part dropped in the callback for exceeding dds::kTilePartBytes
    /// (`sample` then holds its key only); 0 otherwise.
    std::size_t oversized = 0;
  };
  /// Queues a tile or delta, or only its key when its payload is oversized.
  template <class Msg>
  void push_tile(const Msg& m, const std::string& writer);
  void push(Received r);
  void handle(Received& r);
  /// Joins one tile or delta part; applies the message once all its parts are in.
  template <class Msg>
  void join_part(Msg&& part, bool delta, const std::string& writer);
  /// Applies one tile or delta; counts, logs and measures it.
  void apply_tile(const mapshare::TileMessage& t, const std::string& writer);
  void log_once(const std::string& writer, const char* kind, const std::string& what);

  mapshare::MapReplica replica_;
  dds::TilePartAssembler tile_parts_;
  dds::TilePartAssembler delta_parts_;
  FollowStats stats_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<Received> queue_;
  std::set<std::string> logged_;
  bool record_applied_ = false;
  std::vector<AppliedTile> applied_;
  // Readers last: they are destroyed first, so no callback runs into a dead queue.
  dds::TileReader tiles_;
  dds::TileDeltaReader deltas_;
  dds::MetaReader meta_;
};

}  // namespace esfleet::follower
