#pragma once
// Incoming: the wire types of idl/esfleet.idl as core and map-sharing values. Map messages are
// copied field for field (their validation is MapReplica's); scans and true poses are checked
// here and refused with an exception naming the field. Hostile input never crashes these.

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <tuple>
#include <vector>

#include <esfleet/msg/esfleet.h>

#include "esfleet/core/geometry.hpp"
#include "esfleet/core/laser_scan.hpp"
#include "esfleet/dds/to_msg.hpp"
#include "esfleet/dds/topics.hpp"
#include "esfleet/mapshare/messages.hpp"

namespace esfleet::dds {

/// A received whole tile sent as one sample (part 0 of 1: tile_to_msg); the payload is moved out
/// of `m`. The part fields are not looked at: received tiles go through a TilePartAssembler.
mapshare::TileMessage tile_from_msg(msg::MapTile&& m);
/// A received tile delta sent as one sample; the payload is moved out of `m`.
mapshare::TileMessage delta_from_msg(msg::MapTileDelta&& m);

/// Joins the parts that tile_to_msgs / delta_to_msgs cut a tile or delta into back into one
/// message. One assembler per topic (whole tiles and deltas have separate ones). Parts are joined
/// per writer (its GUID): a message's parts all come from one writer, and another writer (a
/// stale or hostile one) cannot disturb the joining of the leader's. Parts of one version may
/// come in any order; a part of a newer (epoch, version) of the same tile from the same writer
/// drops the parts of the older one still waiting, and parts older than the newest version seen
/// (or joined) from that writer are dropped without a word: a late joiner reads, from the
/// writer's KEEP_LAST 1 history, the parts of an older version that had more parts than the
/// newest. Validation of the joined
/// message is MapReplica's; here only the parts' consistency is checked. Memory is bounded:
/// at most kMaxPendingBytes of waiting parts and kMaxTiles tiles remembered.
/// Not thread-safe (feed it from one thread).
class TilePartAssembler {
 public:
  /// Waiting part bytes (payload plus kPartOverhead per part) that make further new parts
  /// refused (a hostile peer's half tiles).
  static constexpr std::size_t kMaxPendingBytes = 64u << 20;
  /// What one waiting part costs besides its payload, in the count against kMaxPendingBytes.
  static constexpr std::size_t kPartOverhead = 64;
  /// Tiles remembered at once (waiting or joined, per writer), beyond which new tiles' parts
  /// are refused: as many as a tile reader holds keys (kMaxTileKeys, topics.hpp).
  static constexpr std::size_t kMaxTiles = kMaxTileKeys;

  /// Adds one received part. Returns the joined message when this part completed its version
  /// (also at once for a message of one part), std::nullopt otherwise. On std::nullopt,
  /// `error` (if given) is empty when the part was kept or was stale, and otherwise says why it
  /// was refused: part >= parts, parts 0, a payload_size above mapshare::kMaxTilePayloadBytes,
  /// a part longer than payload_size, parts of one
  /// version that disagree (parts, payload_size, base version, layout), part sizes that do not
  /// add up to payload_size, or the memory bounds.
  /// `writer`: the sending writer's id (dds::SampleMeta::writer_guid).
  std::optional<mapshare::TileMessage> add(msg::MapTile&& part, const std::string& writer,
                                           std::string* error = nullptr);
  std::optional<mapshare::TileMessage> add(msg::MapTileDelta&& part, const std::string& writer,
                                           std::string* error = nullptr);

  /// Tiles with parts waiting.
  std::size_t pending_tiles() const;
  /// Payload bytes of the parts waiting.
  std::size_t pending_bytes() const { return pending_bytes_ - kPartOverhead * pending_parts_; }

 private:
  using Key =
      std::tuple<std::string, std::string, std::int32_t, std::int32_t>;  ///< writer, map, tx, ty
  /// The parts of a version still being joined.
  struct Waiting {
    mapshare::TileMessage header;                               ///< the first part's fields
    std::map<std::uint16_t, std::vector<std::uint8_t>> chunks;  ///< part -> its bytes
  };
  /// Small for a tile that is only remembered (joined, or of one part): a flood of new keys
  /// costs one of these per key, up to kMaxTiles.
  struct Entry {
    std::uint32_t epoch = 0;
    std::uint64_t version = 0;
    bool joined = false;  ///< this version was returned; its parts are no longer kept
    std::uint16_t parts = 0;
    std::uint32_t payload_size = 0;
    std::size_t received = 0;          ///< chunks present
    std::size_t bytes = 0;             ///< their payload bytes
    std::unique_ptr<Waiting> waiting;  ///< set while parts of this version wait
  };
  template <typename Msg>
  std::optional<mapshare::TileMessage> add_part(const Msg& m, const std::string& writer,
                                                std::vector<std::uint8_t> bytes,
                                                mapshare::TileMessage header, std::string* error);
  void drop_chunks(Entry& e);

  std::map<Key, Entry> entries_;
  std::size_t pending_bytes_ = 0;  ///< payload + kPartOverhead per part, of the waiting parts
  std::size_t pending_parts_ = 0;
};
mapshare::MetaMessage meta_from_msg(const msg::MapMeta& m);

/// Throws std::invalid_argument naming the field for a scan that cannot be used (no beams,
/// more than 10000, non-finite angles, max_range not > 0, non-finite odometry).
LaserScan scan_from_msg(const msg::LaserScanMsg& m);
/// Evaluation: the true pose in a truth message (the robot is m.robot_id()). Throws
/// std::invalid_argument naming the field for another protocol version, an empty robot_id or a
/// non-finite stamp, x, y or theta.
TimedPose truth_from_msg(const msg::TruthPose& m);

/// A received contributed scan: the contribution (robot id, seq, scan, claimed pose) and the
/// follower's claim (map, epoch, evidence).
struct ReceivedContribution {
  Contribution contribution;
  ContributionClaim claim;
};
/// Throws std::invalid_argument naming the field for a contribution that cannot be used: an
/// empty robot_id or map_id, a non-finite stamp, x, y or theta, agreement or known not in
/// [0, 1], no beams or more than msg::kMaxScanBeams, non-finite or out-of-range angle_min /
/// angle_increment (a zero increment too), max_range not in (0, 1000] m. Ranges come
/// back in metres; msg::kNoReturnMm as max_range.
ReceivedContribution contribution_from_msg(const msg::ContributedScan& m);
/// Throws std::invalid_argument naming the field for an empty robot_id or a verdict that
/// ContributionVerdict does not have.
ContributionTally contribution_status_from_msg(const msg::ContributionStatus& m);

}  // namespace esfleet::dds
