#pragma once
// Outgoing: core and map-sharing values as the wire types of idl/esfleet.idl, field for field.
// No Fast DDS entities here (only the generated message classes).

#include <cstdint>
#include <string>

#include <esfleet/msg/esfleet.h>

#include "esfleet/core/geometry.hpp"
#include "esfleet/core/laser_scan.hpp"
#include "esfleet/mapshare/messages.hpp"

namespace esfleet::dds {

/// A whole tile (`tile.is_delta()` must be false); the payload is moved.
msg::MapTile tile_to_msg(mapshare::TileMessage tile);
/// A tile delta (`delta.is_delta()` must be true); the payload is moved.
msg::MapTileDelta delta_to_msg(mapshare::TileMessage delta);
/// The map summary. The wire holds at most 1024 characters of parameters: longer ones are cut.
msg::MapMeta meta_to_msg(const mapshare::MetaMessage& meta);

msg::RobotPose pose_to_msg(const std::string& robot_id, const TimedPose& pose, float fitness,
                           std::uint8_t status);
msg::LaserScanMsg scan_to_msg(const std::string& robot_id, std::uint32_t seq,
                              const LaserScan& scan);
/// Simulator: the true pose of robot `robot_id` (kTruthTopic; stamp = the scan's stamp).
msg::TruthPose truth_to_msg(const std::string& robot_id, const TimedPose& pose);

}  // namespace esfleet::dds
