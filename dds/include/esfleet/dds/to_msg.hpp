#pragma once
// Outgoing: core and map-sharing values as the wire types of idl/esfleet.idl, field for field.
// No Fast DDS entities here (only the generated message classes).

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <esfleet/msg/esfleet.h>

#include "esfleet/core/contribution.hpp"
#include "esfleet/core/geometry.hpp"
#include "esfleet/core/laser_scan.hpp"
#include "esfleet/mapshare/messages.hpp"

namespace esfleet::dds {

/// Most payload bytes in one tile or delta sample. A sample then serialises to at most ~1.2 kB
/// (tile_part_sample_test checks it with a 64-character map id), below the 1284 bytes of data
/// Fast DDS 2.9.1 puts in one 1400-byte RTPS message before it fragments (maxMessageSize minus
/// the RTPS header, INFO_DST, INFO_TS, DATA_FRAG header and a heartbeat: RTPSWriter.cpp:303-322).
/// Samples that are never fragmented cannot meet the Fast DDS 2.9.1 GAP bug that aborted
/// followers (docs/faults.md, "Fragmented tiles and the Fast DDS GAP bug").
/// Also the bound of the wire's payload sequences (msg::kTilePartBytes, protocol 3).
inline constexpr std::size_t kTilePartBytes = 1024;

/// A whole tile (`tile.is_delta()` must be false) as the samples that carry it: its payload cut
/// into parts of at most `part_bytes` (> 0) bytes, part i of n holding bytes
/// [i * part_bytes, (i + 1) * part_bytes); an empty payload gives one part. Every part carries
/// the tile's key, layout, version and the whole payload's size. Throws std::invalid_argument
/// for part_bytes 0 or more than 65535 parts.
std::vector<msg::MapTile> tile_to_msgs(mapshare::TileMessage tile,
                                       std::size_t part_bytes = kTilePartBytes);
/// The same for a tile delta (`delta.is_delta()` must be true).
std::vector<msg::MapTileDelta> delta_to_msgs(mapshare::TileMessage delta,
                                             std::size_t part_bytes = kTilePartBytes);
/// A whole tile as one sample (part 0 of 1, whatever its size); the payload is moved. For tests
/// and the fuzz seeds: the leader sends tile_to_msgs.
msg::MapTile tile_to_msg(mapshare::TileMessage tile);
/// A tile delta as one sample (part 0 of 1); the payload is moved.
msg::MapTileDelta delta_to_msg(mapshare::TileMessage delta);
/// The map summary. The wire holds at most 1024 characters of parameters: longer ones are cut.
msg::MapMeta meta_to_msg(const mapshare::MetaMessage& meta);

msg::RobotPose pose_to_msg(const std::string& robot_id, const TimedPose& pose, float fitness,
                           std::uint8_t status);
msg::LaserScanMsg scan_to_msg(const std::string& robot_id, std::uint32_t seq,
                              const LaserScan& scan);
/// Simulator: the true pose of robot `robot_id` (kTruthTopic; stamp = the scan's stamp).
msg::TruthPose truth_to_msg(const std::string& robot_id, const TimedPose& pose);

/// What a follower sends with a contributed scan besides the scan and its pose: the map the
/// pose is in and its evidence for the pose (FitnessValue::agreement(), known_share()).
struct ContributionClaim {
  std::string map_id;
  std::uint32_t epoch = 0;
  float agreement = 0.0f;
  float known = 0.0f;
};

/// A range in metres as ContributedScan.ranges_mm holds it: rounded to millimetres; at or
/// beyond `max_range` (or 65.535 m and more) msg::kNoReturnMm; NaN or negative 0 (which the
/// SLAM skips, as it skips them in metres).
std::uint16_t range_to_mm(float range, float max_range);

/// Most serialized bytes of a contributed scan: what Fast DDS 2.9.1 puts in one 1400-byte RTPS
/// message before it fragments (see kTilePartBytes).
inline constexpr std::size_t kMaxContributionData = 1284;

/// A contributed scan (kContributionTopic): robot id and seq from `c`, the scan's ranges in
/// millimetres (range_to_mm). The odometry is not sent (the leader uses only the pose). A scan
/// too long for one RTPS message (more than about 530-590 beams, by the ids' lengths) is sent
/// as every k-th beam, the smallest k that fits kMaxContributionData, with angle_increment
/// k times the scan's: never fragmented. Throws std::invalid_argument for more than
/// msg::kMaxScanBeams beams.
msg::ContributedScan contribution_to_msg(const Contribution& c, const ContributionClaim& claim);

/// The leader's answer to one robot's contributions, as kept by the leader and read by the
/// follower (kContributionStatusTopic).
struct ContributionTally {
  std::uint32_t last_seq = 0;  ///< seq of the contribution last checked
  ContributionVerdict last_verdict = ContributionVerdict::kAccepted;
  std::uint32_t accepted = 0;
  std::uint32_t rejected = 0;
  std::uint32_t rejected_in_row = 0;  ///< rejected since the last accepted one
  std::uint64_t stamp_ns = 0;         ///< leader's CLOCK_REALTIME at publication
};
msg::ContributionStatus contribution_status_to_msg(const std::string& robot_id,
                                                   const ContributionTally& tally);

}  // namespace esfleet::dds
