#pragma once
// The leader's half of map sharing as one pure step: the tiles that changed since the last
// publish become messages, whole or as deltas, followed by the summary. No network here: the
// caller writes the messages in order (leader/map_publisher.hpp) or, in a test, hands them to a
// MapReplica directly.
//
// When a changed tile goes out whole rather than as a delta:
//  - the tile is new (never sent);
//  - `full_every` - 1 deltas of it followed its last whole copy, or that copy is `full_period`
//    seconds of scan time old (counted in publishes of the tile, not in tile versions: a version
//    is bumped per scan, several per publish);
//  - the map is complete.
// And when the map is complete, or a new tile reader joined since the last publish, every tile
// whose whole copy is not its newest version goes out whole as well: late joiners read only the
// whole copies (they never saw the deltas before they joined), so they catch up at once.

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "esfleet/core/grid_map.hpp"
#include "esfleet/core/tile_codec.hpp"
#include "esfleet/mapshare/messages.hpp"

namespace esfleet::mapshare {

/// When a changed tile goes out whole rather than as a delta (see the file comment).
struct DeltaPolicy {
  /// One whole tile every this many publishes of a tile (full_every - 1 deltas in between);
  /// 1 = always whole (no deltas). Must be >= 1.
  std::uint64_t full_every = 60;
  /// Whole tile when the whole copy is this many seconds of scan time old.
  double full_period = 60.0;
};

/// What one publish sends, in order: `tiles` (whole or deltas), then `meta`.
struct Publication {
  std::vector<TileMessage> tiles;
  MetaMessage meta;
  /// Every whole copy was brought to its newest version because a tile reader had joined.
  bool joiner_refresh = false;
};

class TileSender {
 public:
  explicit TileSender(MapIdentity id, TileEncoding encoding = TileEncoding::kMedZlib,
                      DeltaPolicy policy = {});

  /// One publish at scan time `stamp` and wall clock `now_ns` (CLOCK_REALTIME, for the
  /// followers' latency figures): takes the map's dirty set and turns every tile changed since
  /// it was last sent into a message (see the file comment), then the summary with `complete`,
  /// `scans` and `params`. `reader_joined`: a tile reader matched since the last publish.
  Publication publish(GridMap& map, double stamp, bool complete, bool reader_joined,
                      std::uint32_t scans, const std::string& params, std::uint64_t now_ns);

  /// Forgets what was sent and marks every tile dirty, so the next publish sends every tile
  /// whole (a resumed leader superseding what the dead one sent).
  void republish_all(GridMap& map);

  // The same step in pieces, for a publisher that works from copies of the changed tiles
  // (leader/map_publisher.hpp) while the map moves on. publish() is send() for each changed
  // tile, then refresh_whole() when complete or a reader joined, then the summary.

  /// The message for `tile` (its newest counters; `layout` of its map), whole or as a delta
  /// against the version sent last (see the file comment), stamped `stamp_ns`; nothing when
  /// that version was sent already. Several versions handed over between two calls become one
  /// delta (or one whole tile): the base is always what the followers were sent.
  std::optional<TileMessage> send(const TileLayout& layout, const TileCounters& tile, double stamp,
                                  bool complete, std::uint64_t stamp_ns);
  /// Appends a whole copy of every tile sent whose whole copy is not the newest version sent
  /// (a complete map, or a tile reader joined).
  void refresh_whole(const TileLayout& layout, double stamp, std::uint64_t now_ns,
                     std::vector<TileMessage>& out);
  /// Forgets what was sent: every tile goes whole when it is next sent (republish_all without
  /// the map).
  void forget_sent() { sent_.clear(); }

  const MapIdentity& id() const { return id_; }

 private:
  /// What the followers were sent of one tile.
  struct Sent {
    std::uint64_t version = 0;       ///< version of the last tile or delta sent
    std::vector<std::uint32_t> hit;  ///< the counters at `version` (the next delta's base)
    std::vector<std::uint32_t> err;
    std::uint64_t full_version = 0;       ///< version of the last whole tile sent
    std::uint64_t deltas_since_full = 0;  ///< deltas sent since that whole tile
    double full_stamp = 0.0;              ///< scan time of that whole tile
  };
  /// The message for `tile` whole or as a delta against `sent`; updates `sent`.
  TileMessage make(const TileLayout& layout, const TileCounters& tile, Sent& sent, bool whole,
                   double stamp, std::uint64_t now_ns);

  MapIdentity id_;
  TileEncoding encoding_;
  DeltaPolicy policy_;
  std::map<TileKey, Sent> sent_;
};

}  // namespace esfleet::mapshare
