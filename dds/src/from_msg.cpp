#include "esfleet/dds/from_msg.hpp"

#include <cmath>
#include <compare>
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

std::size_t TilePartAssembler::pending_tiles() const {
  std::size_t n = 0;
  for (const auto& [key, e] : entries_) n += e.received > 0 ? 1 : 0;
  return n;
}

void TilePartAssembler::drop_chunks(Entry& e) {
  pending_bytes_ -= e.bytes + kPartOverhead * e.received;
  pending_parts_ -= e.received;
  e.waiting.reset();
  e.received = 0;
  e.bytes = 0;
}

std::optional<mapshare::TileMessage> TilePartAssembler::add(msg::MapTile&& part,
                                                            const std::string& writer,
                                                            std::string* error) {
  std::vector<std::uint8_t> bytes = std::move(part.payload());
  return add_part(part, writer, std::move(bytes), tile_fields(part), error);
}

std::optional<mapshare::TileMessage> TilePartAssembler::add(msg::MapTileDelta&& part,
                                                            const std::string& writer,
                                                            std::string* error) {
  std::vector<std::uint8_t> bytes = std::move(part.payload());
  mapshare::TileMessage header = tile_fields(part);
  header.base_version = part.base_version();
  return add_part(part, writer, std::move(bytes), std::move(header), error);
}

template <typename Msg>
std::optional<mapshare::TileMessage> TilePartAssembler::add_part(const Msg& m,
                                                                 const std::string& writer,
                                                                 std::vector<std::uint8_t> bytes,
                                                                 mapshare::TileMessage header,
                                                                 std::string* error) {
  const auto refuse = [&](const std::string& why) -> std::optional<mapshare::TileMessage> {
    if (error != nullptr) *error = why;
    return std::nullopt;
  };
  if (error != nullptr) error->clear();
  const std::uint16_t part = m.part(), parts = m.parts();
  if (parts == 0) return refuse("parts is 0");
  if (part >= parts) {
    return refuse("part " + std::to_string(part) + " of " + std::to_string(parts));
  }
  if (m.payload_size() > mapshare::kMaxTilePayloadBytes) {
    return refuse("payload_size " + std::to_string(m.payload_size()) + ", more than the " +
                  std::to_string(mapshare::kMaxTilePayloadBytes) + " any tile can need");
  }
  if (bytes.size() > m.payload_size()) {
    return refuse("part of " + std::to_string(bytes.size()) +
                  " bytes, more than the payload_size " + std::to_string(m.payload_size()));
  }
  if (parts == 1) {
    if (bytes.size() != m.payload_size()) {
      return refuse("payload of " + std::to_string(bytes.size()) + " bytes, payload_size " +
                    std::to_string(m.payload_size()));
    }
    // Passed on whatever its version (the replica judges it), and remembered when newer than
    // what waits, so that parts of an older version of more parts are dropped.
    auto it = entries_.find(Key{writer, header.map_id, header.tx, header.ty});
    if (it != entries_.end() &&
        std::tie(header.epoch, header.version) > std::tie(it->second.epoch, it->second.version)) {
      drop_chunks(it->second);
      it->second = Entry{};
      it->second.epoch = header.epoch;
      it->second.version = header.version;
      it->second.parts = 1;
      it->second.joined = true;
    } else if (it == entries_.end() && entries_.size() < kMaxTiles) {
      Entry e;
      e.epoch = header.epoch;
      e.version = header.version;
      e.parts = 1;
      e.joined = true;
      entries_.emplace(Key{writer, header.map_id, header.tx, header.ty}, std::move(e));
    }
    header.payload = std::move(bytes);
    return header;
  }
  Key key{writer, header.map_id, header.tx, header.ty};
  auto it = entries_.find(key);
  if (it == entries_.end()) {
    if (entries_.size() >= kMaxTiles) {
      std::erase_if(entries_, [](const auto& kv) { return kv.second.received == 0; });
      if (entries_.size() >= kMaxTiles) return refuse("too many tiles in assembly");
    }
    it = entries_.emplace(std::move(key), Entry{}).first;
  }
  Entry& e = it->second;
  const auto order = std::tie(header.epoch, header.version) <=> std::tie(e.epoch, e.version);
  if (e.parts != 0 && order < 0) return std::nullopt;  // an older version: stale
  if (e.parts == 0 || order > 0) {                     // the first part of a newer version
    drop_chunks(e);
    e = Entry{};
    e.epoch = header.epoch;
    e.version = header.version;
    e.parts = parts;
    e.payload_size = m.payload_size();
    e.waiting = std::make_unique<Waiting>();
    e.waiting->header = std::move(header);
  } else {
    // A duplicate of a part already joined (only a version being joined has parts waiting).
    if (e.joined || !e.waiting) return std::nullopt;
    const mapshare::TileMessage& h = e.waiting->header;
    if (parts != e.parts || m.payload_size() != e.payload_size ||
        header.base_version != h.base_version || header.cells != h.cells ||
        header.tile_edge != h.tile_edge || header.encoding != h.encoding ||
        header.cell_size != h.cell_size || header.protocol != h.protocol) {
      return refuse("parts of version " + std::to_string(e.version) + " disagree");
    }
  }
  if (e.waiting->chunks.contains(part)) return std::nullopt;  // a duplicate
  if (pending_bytes_ + bytes.size() + kPartOverhead > kMaxPendingBytes) {
    return refuse("more than " + std::to_string(kMaxPendingBytes) + " bytes of parts waiting");
  }
  e.bytes += bytes.size();
  pending_bytes_ += bytes.size() + kPartOverhead;
  ++pending_parts_;
  e.waiting->chunks.emplace(part, std::move(bytes));
  if (++e.received < e.parts) return std::nullopt;
  mapshare::TileMessage out = std::move(e.waiting->header);
  const std::size_t total = e.bytes;
  if (total != e.payload_size) {
    drop_chunks(e);
    e.joined = true;
    return refuse("parts of " + std::to_string(total) + " bytes in all, payload_size " +
                  std::to_string(e.payload_size));
  }
  out.payload.reserve(total);
  for (const auto& [index, c] : e.waiting->chunks) {
    out.payload.insert(out.payload.end(), c.begin(), c.end());
  }
  drop_chunks(e);
  e.joined = true;
  return out;
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
  constexpr std::size_t kMaxBeams = msg::kMaxScanBeams;  // the wire's bound (protocol 3)
  auto fail = [](const std::string& what) {
    throw std::invalid_argument("laser scan message: " + what);
  };
  if (m.ranges().empty()) fail("ranges is empty");
  if (m.ranges().size() > kMaxBeams) {
    fail("ranges has " + std::to_string(m.ranges().size()) + " beams, more than " +
         std::to_string(kMaxBeams));
  }
  if (!std::isfinite(m.stamp())) fail("stamp is not finite");
  if (!std::isfinite(m.angle_min()) || !std::isfinite(m.angle_increment()) ||
      std::abs(m.angle_min()) > 7.0f || std::abs(m.angle_increment()) > 1.0f) {
    fail("angle_min / angle_increment out of range");
  }
  // Every beam in one direction is no laser (the CARMEN reader, the ROS 2 scan and the
  // contributed scan refuse it too); a single beam needs no increment.
  if (m.angle_increment() == 0.0f && m.ranges().size() > 1) {
    fail("angle_increment is zero for " + std::to_string(m.ranges().size()) + " beams");
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

ReceivedContribution contribution_from_msg(const msg::ContributedScan& m) {
  auto fail = [](const std::string& what) {
    throw std::invalid_argument("contributed scan message: " + what);
  };
  if (m.robot_id().size() == 0) fail("robot_id is empty");
  if (m.map_id().size() == 0) fail("map_id is empty");
  if (!std::isfinite(m.stamp())) fail("stamp is not finite");
  if (!std::isfinite(m.x()) || !std::isfinite(m.y())) fail("x / y is not finite");
  if (!std::isfinite(m.theta())) fail("theta is not finite");
  if (std::abs(m.x()) > 1e6 || std::abs(m.y()) > 1e6) fail("x / y beyond 1000 km");
  if (!(m.agreement() >= 0.0f && m.agreement() <= 1.0f)) fail("agreement is not in [0, 1]");
  if (!(m.known() >= 0.0f && m.known() <= 1.0f)) fail("known is not in [0, 1]");
  if (m.ranges_mm().empty()) fail("ranges_mm is empty");
  if (m.ranges_mm().size() > msg::kMaxScanBeams) {
    fail("ranges_mm has " + std::to_string(m.ranges_mm().size()) + " beams, more than " +
         std::to_string(msg::kMaxScanBeams));
  }
  if (!std::isfinite(m.angle_min()) || std::abs(m.angle_min()) > 7.0f) {
    fail("angle_min is not finite or out of range");
  }
  if (!std::isfinite(m.angle_increment()) || m.angle_increment() == 0.0f ||
      std::abs(m.angle_increment()) > 1.0f) {
    fail("angle_increment is zero, not finite or out of range");
  }
  if (!(m.max_range() > 0.0f) || !(m.max_range() <= 1000.0f)) {
    fail("max_range must be > 0 and at most 1000 m");
  }
  ReceivedContribution r;
  Contribution& c = r.contribution;
  c.robot = m.robot_id().to_string();
  c.seq = m.seq();
  c.pose = Pose2{m.x(), m.y(), m.theta()};
  c.scan.stamp = m.stamp();
  c.scan.angle_min = m.angle_min();
  c.scan.angle_increment = m.angle_increment();
  c.scan.max_range = m.max_range();
  c.scan.ranges.reserve(m.ranges_mm().size());
  for (const std::uint16_t mm : m.ranges_mm()) {
    c.scan.ranges.push_back(mm == msg::kNoReturnMm ? m.max_range()
                                                   : static_cast<float>(mm) / 1000.0f);
  }
  r.claim.map_id = m.map_id().to_string();
  r.claim.epoch = m.epoch();
  r.claim.agreement = m.agreement();
  r.claim.known = m.known();
  return r;
}

ContributionTally contribution_status_from_msg(const msg::ContributionStatus& m) {
  auto fail = [](const std::string& what) {
    throw std::invalid_argument("contribution status message: " + what);
  };
  if (m.robot_id().size() == 0) fail("robot_id is empty");
  if (m.last_verdict() > static_cast<std::uint8_t>(ContributionVerdict::kContradicts)) {
    fail("last_verdict " + std::to_string(m.last_verdict()) + " is unknown");
  }
  ContributionTally t;
  t.last_seq = m.last_seq();
  t.last_verdict = static_cast<ContributionVerdict>(m.last_verdict());
  t.accepted = m.accepted();
  t.rejected = m.rejected();
  t.rejected_in_row = m.rejected_in_row();
  t.stamp_ns = m.stamp_ns();
  return t;
}

}  // namespace esfleet::dds
