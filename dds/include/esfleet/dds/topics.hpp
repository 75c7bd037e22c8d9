#pragma once
// The esfleet DDS contract in one place: topic names, the default domain and the protocol
// version every message carries. Plain C++ (no Fast DDS headers), cheap to include.
//
// Topics (type in esfleet/msg/esfleet.h, generated from idl/esfleet.idl):
//   esfleet/map/tiles        msg::MapTile       leader -> followers, keyed (map_id, tx, ty)
//   esfleet/map/tile_deltas  msg::MapTileDelta  leader -> followers, keyed (map_id, tx, ty)
//   esfleet/map/meta         msg::MapMeta       leader -> followers, keyed map_id
//   esfleet/robots/pose      msg::RobotPose     every robot, keyed robot_id
//   esfleet/robots/scan      msg::LaserScanMsg  every robot (optional), keyed robot_id
//   esfleet/sim/truth        msg::TruthPose     simulator -> evaluation only, keyed robot_id
//   esfleet/robots/contribution         msg::ContributedScan     follower -> leader, robot_id
//   esfleet/robots/contribution_status  msg::ContributionStatus  leader -> follower, robot_id

#include <cstdint>
#include <string>
#include <string_view>

namespace esfleet::dds {

/// Version of the wire protocol; every message's `protocol` field must hold it. Mirrors
/// esfleet::msg::kProtocolVersion in idl/esfleet.idl (a static_assert in node.cpp keeps the two
/// equal). Readers drop samples of any other protocol.
inline constexpr std::uint16_t kProtocolVersion = 3;

/// DDS domain used when nothing else is configured.
inline constexpr int kDefaultDomain = 0;
/// Highest domain id Fast DDS 2.9 accepts with the default port mapping (233+ overflow the
/// 16-bit UDP port range).
inline constexpr int kMaxDomain = 232;

/// Reader partition that matches every writer partition: readers of everyone's poses or scans
/// (writers of the robot topics publish in the partition named after their robot id).
inline constexpr const char* kAllPartitions = "*";
/// Partition of the simulator's truth writer when it has no robot id (see sim/).
inline constexpr const char* kSimPartition = "sim";

/// Map tiles (msg::MapTile): reliable, transient-local, keep last 1 per tile.
inline constexpr std::string_view kTileTopic = "esfleet/map/tiles";
/// Tile deltas (msg::MapTileDelta): reliable, volatile, keep last 64 per tile.
inline constexpr std::string_view kTileDeltaTopic = "esfleet/map/tile_deltas";
/// Map summaries (msg::MapMeta): reliable, transient-local, keep last 1 per map.
inline constexpr std::string_view kMetaTopic = "esfleet/map/meta";
/// Robot poses (msg::RobotPose): reliable, volatile, keep last 1 per robot.
inline constexpr std::string_view kPoseTopic = "esfleet/robots/pose";
/// Laser scans (msg::LaserScanMsg): reliable, volatile, keep last 50 per robot.
inline constexpr std::string_view kScanTopic = "esfleet/robots/scan";
/// True poses of simulated robots (msg::TruthPose): reliable, volatile, keep last 50 per robot.
/// For evaluation only: SLAM and localisation never subscribe to it.
inline constexpr std::string_view kTruthTopic = "esfleet/sim/truth";

/// Scans followers contribute to the leader's map (msg::ContributedScan): reliable, volatile,
/// keep last 32 per robot; written in the robot's partition, read by the leader in every one.
inline constexpr std::string_view kContributionTopic = "esfleet/robots/contribution";
/// The leader's answer per robot (msg::ContributionStatus): reliable, volatile, keep last 1 per
/// robot; written by the leader in the robot's own partition (so that DDS Security can grant
/// each robot its own status only), read by the follower in its partition.
inline constexpr std::string_view kContributionStatusTopic = "esfleet/robots/contribution_status";

/// Keys (map_id, tx, ty, part) a tile or delta endpoint holds at once (its max_instances):
/// about 4096 tiles of 4 parts (64-cell tiles at 5 cm are 3.2 m square: 4096 cover
/// 200 m x 200 m). A real map needs far fewer: the whole MIT CSAIL log (odometry on) makes 236
/// tiles in 532 part keys, fr079 69 tiles in 266 (MED zlib; rogue_peer --passive), 30 and 60
/// times less. Every key stays an instance for as long as its writer lives (KEEP_LAST keeps the
/// newest sample per key), so this, not the run's length, bounds what a peer flooding new keys
/// costs a follower: about 0.6 kB per key with the follower's own bookkeeping
/// (dds::TilePartAssembler), 19 MB for both topics at the bound, less than a clean follower's
/// peak (docs/fuzzing.md, "Memory"). The price: once a flood has filled it, Fast DDS refuses
/// the leader's new keys for good (a sample rejected by the instance limit is never resent)
/// until the flooding writer leaves and the follower rejoins; only DDS Security keeps such a
/// peer out.
inline constexpr std::int32_t kMaxTileKeys = 16384;
/// Maps (map_id keys) a summary endpoint holds: one leader per map, a few per domain.
inline constexpr std::int32_t kMaxMaps = 64;
/// Robots (robot_id keys) a pose, scan or truth endpoint holds: the largest fleet, with room.
inline constexpr std::int32_t kMaxRobots = 256;

/// One endpoint's DDS topic name and QoS. Each esfleet message type has its own (writer.hpp);
/// the ROS 2 endpoints (ros.hpp) pick theirs per topic, as ROS 2 tools expect them. Writers
/// send heartbeats every 100 ms.
///
/// Resource limits: max_instances = `max_instances`, max_samples_per_instance = the endpoint's
/// KEEP_LAST depth, max_samples = their product (Fast DDS 2.9 refuses an entity whose
/// max_samples is below the product, or finite while another limit is unlimited). 0 = all
/// unlimited: the ROS 2 endpoints, whose types esfleet does not bound.
struct TopicQos {
  std::string topic;               ///< DDS topic name, e.g. "esfleet/map/tiles" or "rt/map"
  bool reliable = true;            ///< RELIABLE, else BEST_EFFORT
  bool transient_local = false;    ///< TRANSIENT_LOCAL, else VOLATILE
  std::int32_t depth = 1;          ///< KEEP_LAST depth (per key for keyed topics)
  std::int32_t max_instances = 0;  ///< keys held at once; 0 = unlimited resource limits
  /// KEEP_LAST depth of the readers if > 0 (else `depth`): a reader hands every sample to its
  /// callback at once, so it needs less than a writer that must resend.
  std::int32_t reader_depth = 0;
};

}  // namespace esfleet::dds
