#include "esfleet/dds/from_msg.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace esfleet::dds {

namespace {
/// The fields MapTile and MapTileDelta share.
template <typename Msg>
mapshare::TileMessage tile_fields(Msg& m) {
  mapshare::TileMessage t;
  t.map_id = m.map_id().to_string();
  t.tx = m.tx();
  t.ty = m.ty();
  t.protocol = m.protocol();
  t.epoch = m.epoch();
  t.version = m.version();
  t.cell_size = m.cell_size();
  t.tile_edge = m.tile_edge();
  t.encoding = m.encoding();
  t.cells = m.cells();
  t.payload = std::move(m.payload());
  t.stamp_ns = m.leader_stamp_ns();
  return t;
}
}  // namespace

mapshare::TileMessage tile_from_msg(msg::MapTile&& m) { return tile_fields(m); }

mapshare::TileMessage delta_from_msg(msg::MapTileDelta&& m) {
  mapshare::TileMessage t = tile_fields(m);
  t.base_version = m.base_version();
  return t;
}

mapshare::MetaMessage meta_from_msg(const msg::MapMeta& m) {
  mapshare::MetaMessage meta;
  meta.map_id = m.map_id().to_string();
  meta.protocol = m.protocol();
  meta.epoch = m.epoch();
  meta.cell_size = m.cell_size();
  meta.tile_edge = m.tile_edge();
  meta.min_tx = m.min_tx();
  meta.min_ty = m.min_ty();
  meta.max_tx = m.max_tx();
  meta.max_ty = m.max_ty();
  meta.tile_count = m.tile_count();
  meta.map_version = m.map_version();
  meta.complete = m.complete();
  meta.scans = m.scans();
  meta.params = m.es_params().to_string();
  meta.stamp_ns = m.stamp_ns();
  return meta;
}

LaserScan scan_from_msg(const msg::LaserScanMsg& m) {
  constexpr std::size_t kMaxBeams = 10000;
  auto fail = [](const std::string& what) {
    throw std::invalid_argument("laser scan message: " + what);
  };
  if (m.ranges().empty()) fail("ranges is empty");
  if (m.ranges().size() > kMaxBeams) {
    fail("ranges has " + std::to_string(m.ranges().size()) + " beams, more than 10000");
  }
  if (!std::isfinite(m.stamp())) fail("stamp is not finite");
  if (!std::isfinite(m.angle_min()) || !std::isfinite(m.angle_increment()) ||
      std::abs(m.angle_min()) > 7.0f || std::abs(m.angle_increment()) > 1.0f) {
    fail("angle_min / angle_increment out of range");
  }
  if (!(m.max_range() > 0.0f) || !std::isfinite(m.max_range())) fail("max_range must be > 0");
  LaserScan s;
  s.stamp = m.stamp();
  s.angle_min = m.angle_min();
  s.angle_increment = m.angle_increment();
  s.max_range = m.max_range();
  s.ranges = m.ranges();  // NaN / negative beams are skipped by the SLAM, not an error here
  if (m.has_odometry()) {
    if (!std::isfinite(m.odom_x()) || !std::isfinite(m.odom_y()) ||
        !std::isfinite(m.odom_theta())) {
      fail("odometry is not finite");
    }
    s.odometry = Pose2{m.odom_x(), m.odom_y(), m.odom_theta()};
  }
  return s;
}

TimedPose truth_from_msg(const msg::TruthPose& m) {
  auto fail = [](const std::string& what) {
    throw std::invalid_argument("truth pose message: " + what);
  };
  if (m.protocol() != msg::kProtocolVersion) {
    fail("protocol " + std::to_string(m.protocol()) + ", expected " +
         std::to_string(msg::kProtocolVersion));
  }
  if (m.robot_id().size() == 0) fail("robot_id is empty");
  if (!std::isfinite(m.stamp())) fail("stamp is not finite");
  if (!std::isfinite(m.x()) || !std::isfinite(m.y())) fail("x / y is not finite");
  if (!std::isfinite(m.theta())) fail("theta is not finite");
  return {m.stamp(), Pose2{m.x(), m.y(), m.theta()}};
}

}  // namespace esfleet::dds
