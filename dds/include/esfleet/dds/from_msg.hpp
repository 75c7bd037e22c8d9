#pragma once
// Incoming: the wire types of idl/esfleet.idl as core and map-sharing values. Map messages are
// copied field for field (their validation is MapReplica's); scans and true poses are checked
// here and refused with an exception naming the field. Hostile input never crashes these.

#include <esfleet/msg/esfleet.h>

#include "esfleet/core/geometry.hpp"
#include "esfleet/core/laser_scan.hpp"
#include "esfleet/mapshare/messages.hpp"

namespace esfleet::dds {

/// A received whole tile; the payload is moved out of `m`.
mapshare::TileMessage tile_from_msg(msg::MapTile&& m);
/// A received tile delta; the payload is moved out of `m`.
mapshare::TileMessage delta_from_msg(msg::MapTileDelta&& m);
mapshare::MetaMessage meta_from_msg(const msg::MapMeta& m);

/// Throws std::invalid_argument naming the field for a scan that cannot be used (no beams,
/// more than 10000, non-finite angles, max_range not > 0, non-finite odometry).
LaserScan scan_from_msg(const msg::LaserScanMsg& m);
/// Evaluation: the true pose in a truth message (the robot is m.robot_id()). Throws
/// std::invalid_argument naming the field for another protocol version, an empty robot_id or a
/// non-finite stamp, x, y or theta.
TimedPose truth_from_msg(const msg::TruthPose& m);

}  // namespace esfleet::dds
