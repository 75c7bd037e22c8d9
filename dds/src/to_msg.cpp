#include "esfleet/dds/to_msg.hpp"

#include <esfleet/msg/esfleetPubSubTypes.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace esfleet::dds {

static_assert(mapshare::kProtocolVersion == msg::kProtocolVersion,
              "mapshare's messages.hpp and idl/esfleet.idl must name the same protocol");
static_assert(kTilePartBytes == msg::kTilePartBytes,
              "the parts tile_to_msgs cuts must fit the bounded payload of idl/esfleet.idl");

namespace {
/// The fields MapTile and MapTileDelta share.
template <typename Msg>
Msg tile_fields(mapshare::TileMessage& t) {
  Msg m;
  m.map_id(t.map_id);
  m.tx(t.tx);
  m.ty(t.ty);
  m.protocol(t.protocol);
  m.epoch(t.epoch);
  m.version(t.version);
  m.cell_size(t.cell_size);
  m.tile_edge(t.tile_edge);
  m.encoding(t.encoding);
  m.cells(t.cells);
  m.part(0);
  m.parts(1);
  m.payload_size(static_cast<std::uint32_t>(t.payload.size()));
  m.payload(std::move(t.payload));
  m.leader_stamp_ns(t.stamp_ns);
  return m;
}

/// `t` cut into parts of at most `part_bytes` payload bytes (see tile_to_msgs).
template <typename Msg>
std::vector<Msg> split(mapshare::TileMessage& t, std::size_t part_bytes) {
  if (part_bytes == 0) throw std::invalid_argument("tile_to_msgs: part_bytes must be > 0");
  const std::size_t size = t.payload.size();
  const std::size_t n = std::max<std::size_t>(1, (size + part_bytes - 1) / part_bytes);
  if (n > std::numeric_limits<std::uint16_t>::max()) {
    throw std::invalid_argument("tile_to_msgs: " + std::to_string(size) +
                                " payload bytes need more than 65535 parts of " +
                                std::to_string(part_bytes));
  }
  std::vector<std::uint8_t> payload = std::move(t.payload);
  t.payload.clear();
  std::vector<Msg> out(n, tile_fields<Msg>(t));
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t begin = i * part_bytes, end = std::min(size, begin + part_bytes);
    out[i].part(static_cast<std::uint16_t>(i));
    out[i].parts(static_cast<std::uint16_t>(n));
    out[i].payload_size(static_cast<std::uint32_t>(size));
    out[i].payload().assign(payload.begin() + static_cast<std::ptrdiff_t>(begin),
                            payload.begin() + static_cast<std::ptrdiff_t>(end));
  }
  return out;
}

/// The fields RobotPose and TruthPose share: the robot, the protocol and the timed pose.
template <typename Msg>
Msg timed_pose_fields(const std::string& robot_id, const TimedPose& pose) {
  Msg m;
  m.robot_id(robot_id);
  m.protocol(msg::kProtocolVersion);
  m.stamp(pose.stamp);
  m.x(pose.pose.x);
  m.y(pose.pose.y);
  m.theta(pose.pose.theta);
  return m;
}
}  // namespace

std::vector<msg::MapTile> tile_to_msgs(mapshare::TileMessage tile, std::size_t part_bytes) {
  return split<msg::MapTile>(tile, part_bytes);
}

std::vector<msg::MapTileDelta> delta_to_msgs(mapshare::TileMessage delta, std::size_t part_bytes) {
  std::vector<msg::MapTileDelta> out = split<msg::MapTileDelta>(delta, part_bytes);
  for (msg::MapTileDelta& m : out) m.base_version(delta.base_version.value_or(0));
  return out;
}

msg::MapTile tile_to_msg(mapshare::TileMessage tile) { return tile_fields<msg::MapTile>(tile); }

msg::MapTileDelta delta_to_msg(mapshare::TileMessage delta) {
  msg::MapTileDelta m = tile_fields<msg::MapTileDelta>(delta);
  m.base_version(delta.base_version.value_or(0));
  return m;
}

msg::MapMeta meta_to_msg(const mapshare::MetaMessage& meta) {
  constexpr std::size_t kMaxParams = 1024;  // string<1024> es_params
  msg::MapMeta m;
  m.map_id(meta.map_id);
  m.protocol(meta.protocol);
  m.epoch(meta.epoch);
  m.cell_size(meta.cell_size);
  m.tile_edge(meta.tile_edge);
  m.min_tx(meta.min_tx);
  m.min_ty(meta.min_ty);
  m.max_tx(meta.max_tx);
  m.max_ty(meta.max_ty);
  m.tile_count(meta.tile_count);
  m.map_version(meta.map_version);
  m.complete(meta.complete);
  m.scans(meta.scans);
  m.es_params(meta.params.size() <= kMaxParams ? meta.params : meta.params.substr(0, kMaxParams));
  m.stamp_ns(meta.stamp_ns);
  return m;
}

msg::RobotPose pose_to_msg(const std::string& robot_id, const TimedPose& pose, float fitness,
                           std::uint8_t status) {
  msg::RobotPose m = timed_pose_fields<msg::RobotPose>(robot_id, pose);
  m.fitness(fitness);
  m.status(status);
  return m;
}

msg::LaserScanMsg scan_to_msg(const std::string& robot_id, std::uint32_t seq,
                              const LaserScan& scan) {
  msg::LaserScanMsg m;
  m.robot_id(robot_id);
  m.protocol(msg::kProtocolVersion);
  m.seq(seq);
  m.stamp(scan.stamp);
  m.angle_min(scan.angle_min);
  m.angle_increment(scan.angle_increment);
  m.max_range(scan.max_range);
  m.ranges(scan.ranges);
  m.has_odometry(scan.odometry.has_value());
  if (scan.odometry) {
    m.odom_x(scan.odometry->x);
    m.odom_y(scan.odometry->y);
    m.odom_theta(scan.odometry->theta);
  }
  return m;
}

msg::TruthPose truth_to_msg(const std::string& robot_id, const TimedPose& pose) {
  return timed_pose_fields<msg::TruthPose>(robot_id, pose);
}

std::uint16_t range_to_mm(float range, float max_range) {
  if (std::isnan(range) || range < 0.0f) return 0;
  if (range >= max_range) return msg::kNoReturnMm;
  const double mm = std::round(static_cast<double>(range) * 1000.0);
  if (mm >= static_cast<double>(msg::kNoReturnMm)) return msg::kNoReturnMm;
  return static_cast<std::uint16_t>(mm);
}

msg::ContributedScan contribution_to_msg(const Contribution& c, const ContributionClaim& claim) {
  const LaserScan& scan = c.scan;
  if (scan.ranges.size() > msg::kMaxScanBeams) {
    throw std::invalid_argument("contribution_to_msg: " + std::to_string(scan.ranges.size()) +
                                " beams, more than " + std::to_string(msg::kMaxScanBeams));
  }
  msg::ContributedScan m;
  m.robot_id(c.robot);
  m.protocol(msg::kProtocolVersion);
  m.seq(c.seq);
  m.map_id(claim.map_id);
  m.epoch(claim.epoch);
  m.stamp(scan.stamp);
  m.x(c.pose.x);
  m.y(c.pose.y);
  m.theta(c.pose.theta);
  m.agreement(claim.agreement);
  m.known(claim.known);
  m.angle_min(scan.angle_min);
  m.angle_increment(scan.angle_increment);
  m.max_range(scan.max_range);
  // Every step-th beam, the smallest step whose sample fits in one RTPS message: the fields
  // besides the ranges (ids included) measured, then 2 bytes per beam.
  msg::ContributedScanPubSubType type;
  const std::size_t fixed = type.getSerializedSizeProvider(&m)();
  const std::size_t room = kMaxContributionData > fixed ? (kMaxContributionData - fixed) / 2 : 1;
  const std::size_t n = scan.ranges.size();
  const std::size_t step = std::max<std::size_t>(1, (n + room - 1) / room);
  m.angle_increment(scan.angle_increment * static_cast<float>(step));
  std::vector<std::uint16_t> mm;
  mm.reserve((n + step - 1) / step);
  for (std::size_t i = 0; i < n; i += step)
    mm.push_back(range_to_mm(scan.ranges[i], scan.max_range));
  m.ranges_mm(std::move(mm));
  return m;
}

msg::ContributionStatus contribution_status_to_msg(const std::string& robot_id,
                                                   const ContributionTally& tally) {
  msg::ContributionStatus m;
  m.robot_id(robot_id);
  m.protocol(msg::kProtocolVersion);
  m.last_seq(tally.last_seq);
  m.last_verdict(static_cast<std::uint8_t>(tally.last_verdict));
  m.accepted(tally.accepted);
  m.rejected(tally.rejected);
  m.rejected_in_row(tally.rejected_in_row);
  m.stamp_ns(tally.stamp_ns);
  return m;
}

}  // namespace esfleet::dds
