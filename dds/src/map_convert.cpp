#include "esfleet/dds/map_convert.hpp"

#include <bit>
#include <cmath>
#include <ctime>
#include <stdexcept>

namespace esfleet::dds {

std::int64_t realtime_ns() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

std::uint64_t map_version(const GridMap& map) {
  std::uint64_t sum = 0;
  for (const TileKey k : map.tile_keys()) sum += map.find_tile(k)->version;
  return sum;
}

namespace {

const Tile& tile_or_throw(const GridMap& map, TileKey key) {
  const Tile* tile = map.find_tile(key);
  if (tile == nullptr) {
    throw std::invalid_argument("no tile (" + std::to_string(key.tx) + ", " +
                                std::to_string(key.ty) + ") in the map");
  }
  return *tile;
}

/// The fields MapTile and MapTileDelta share: key, identity, the tile's version and layout,
/// and `hit`/`err` encoded as the payload.
template <typename Msg>
void fill_tile_fields(Msg& m, const GridMap& map, TileKey key, const Tile& tile,
                      const MapIdentity& id, std::span<const std::uint32_t> hit,
                      std::span<const std::uint32_t> err, TileEncoding encoding,
                      std::int64_t stamp_ns) {
  m.map_id(id.map_id);
  m.tx(key.tx);
  m.ty(key.ty);
  m.protocol(msg::kProtocolVersion);
  m.epoch(id.epoch);
  m.version(tile.version);
  m.cell_size(static_cast<float>(map.cell_size()));
  m.tile_edge(static_cast<std::uint16_t>(map.tile_edge()));
  EncodedTile e = encode_tile(hit, err, encoding);
  m.encoding(static_cast<std::uint8_t>(e.encoding));
  m.cells(static_cast<std::uint32_t>(map.cells_per_tile()));
  m.payload(std::move(e.payload));
  m.leader_stamp_ns(static_cast<std::uint64_t>(stamp_ns));
}

}  // namespace

msg::MapTile tile_to_msg(const GridMap& map, TileKey key, const MapIdentity& id,
                         TileEncoding encoding, std::int64_t stamp_ns) {
  const Tile& tile = tile_or_throw(map, key);
  msg::MapTile m;
  fill_tile_fields(m, map, key, tile, id, tile.hit, tile.err, encoding, stamp_ns);
  return m;
}

msg::MapTileDelta tile_delta_to_msg(const GridMap& map, TileKey key, std::uint64_t base_version,
                                    std::span<const std::uint32_t> base_hit,
                                    std::span<const std::uint32_t> base_err, const MapIdentity& id,
                                    TileEncoding encoding, std::int64_t stamp_ns) {
  const Tile& tile = tile_or_throw(map, key);
  if (base_hit.size() != tile.hit.size() || base_err.size() != tile.err.size()) {
    throw std::invalid_argument("delta base has " + std::to_string(base_hit.size()) +
                                " cells, the tile " + std::to_string(tile.hit.size()));
  }
  if (base_version >= tile.version) {
    throw std::invalid_argument("delta base version " + std::to_string(base_version) +
                                " is not older than the tile's " + std::to_string(tile.version));
  }
  std::vector<std::uint32_t> dhit(tile.hit.size()), derr(tile.err.size());
  for (std::size_t i = 0; i < dhit.size(); ++i) {
    dhit[i] = tile.hit[i] - base_hit[i];  // modulo 2^32: counters may also decrease
    derr[i] = tile.err[i] - base_err[i];
  }
  msg::MapTileDelta m;
  fill_tile_fields(m, map, key, tile, id, dhit, derr, encoding, stamp_ns);
  m.base_version(base_version);
  return m;
}

msg::MapMeta meta_to_msg(const GridMap& map, const MapIdentity& id, bool complete,
                         std::uint32_t scans, const std::string& params_json,
                         std::int64_t stamp_ns) {
  msg::MapMeta m;
  m.map_id(id.map_id);
  m.protocol(msg::kProtocolVersion);
  m.epoch(id.epoch);
  m.cell_size(static_cast<float>(map.cell_size()));
  m.tile_edge(static_cast<std::uint16_t>(map.tile_edge()));
  const auto keys = map.tile_keys();
  if (!keys.empty()) {
    std::int32_t min_tx = keys.front().tx, max_tx = keys.front().tx;
    std::int32_t min_ty = keys.front().ty, max_ty = keys.front().ty;
    for (const TileKey k : keys) {
      min_tx = std::min(min_tx, k.tx);
      max_tx = std::max(max_tx, k.tx);
      min_ty = std::min(min_ty, k.ty);
      max_ty = std::max(max_ty, k.ty);
    }
    m.min_tx(min_tx);
    m.min_ty(min_ty);
    m.max_tx(max_tx);
    m.max_ty(max_ty);
  }
  m.tile_count(static_cast<std::uint32_t>(keys.size()));
  m.map_version(map_version(map));
  m.complete(complete);
  m.scans(scans);
  // The field holds at most 1024 characters: a longer parameter dump is cut, not refused.
  m.es_params(params_json.size() <= 1024 ? params_json : params_json.substr(0, 1024));
  m.stamp_ns(static_cast<std::uint64_t>(stamp_ns));
  return m;
}

msg::RobotPose pose_to_msg(const std::string& robot_id, const TimedPose& pose, float fitness,
                           std::uint8_t status) {
  msg::RobotPose m;
  m.robot_id(robot_id);
  m.protocol(msg::kProtocolVersion);
  m.stamp(pose.stamp);
  m.x(pose.pose.x);
  m.y(pose.pose.y);
  m.theta(pose.pose.theta);
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

msg::TruthPose truth_to_msg(const std::string& robot_id, const TimedPose& pose) {
  msg::TruthPose m;
  m.robot_id(robot_id);
  m.protocol(msg::kProtocolVersion);
  m.stamp(pose.stamp);
  m.x(pose.pose.x);
  m.y(pose.pose.y);
  m.theta(pose.pose.theta);
  return m;
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

MapReplica::MapReplica(std::string map_id, GridMapConfig local)
    : map_id_(std::move(map_id)), local_(local) {
  local_.validate();
}

void MapReplica::reset(std::uint32_t epoch, float cell_size, int tile_edge) {
  GridMapConfig c = local_;
  c.cell_size = cell_size;
  c.tile_edge = tile_edge;
  if ((1 << c.pyramid_levels) > tile_edge) c.pyramid_levels = 0;
  map_.reset();
  map_.emplace(c);
  epoch_ = epoch;
  meta_.reset();
}

std::string MapReplica::check_layout(float cell_size, std::uint32_t tile_edge,
                                     bool against_map) const {
  if (!std::isfinite(cell_size) || !(cell_size > 0.0f) || cell_size > 10.0f) {
    return "cell_size " + std::to_string(cell_size) + " is not in (0, 10] m";
  }
  if (tile_edge < 8 || tile_edge > 1024 || !std::has_single_bit(tile_edge)) {
    return "tile_edge " + std::to_string(tile_edge) + " is not a power of two in [8, 1024]";
  }
  if (against_map && map_) {
    if (static_cast<float>(map_->cell_size()) != cell_size) {
      return "cell_size " + std::to_string(cell_size) + " differs from the map's " +
             std::to_string(map_->cell_size());
    }
    if (static_cast<std::uint32_t>(map_->tile_edge()) != tile_edge) {
      return "tile_edge " + std::to_string(tile_edge) + " differs from the map's " +
             std::to_string(map_->tile_edge());
    }
  }
  return {};
}

std::string MapReplica::check_tile(std::uint32_t cells, std::uint32_t tile_edge,
                                   TileKey key) const {
  const std::size_t expected = static_cast<std::size_t>(tile_edge) * tile_edge;
  if (cells != expected) {
    return "cells " + std::to_string(cells) +
           ", expected tile_edge^2 = " + std::to_string(expected);
  }
  if (std::abs(static_cast<std::int64_t>(key.tx)) > local_.max_tile_coord ||
      std::abs(static_cast<std::int64_t>(key.ty)) > local_.max_tile_coord) {
    return "tile (" + std::to_string(key.tx) + ", " + std::to_string(key.ty) + ") is outside +-" +
           std::to_string(local_.max_tile_coord);
  }
  return {};
}

namespace {
Applied reject(std::string* error, std::string what) {
  if (error != nullptr) *error = std::move(what);
  return Applied::kRejected;
}

/// The longest payload a valid tile of `cells` cells can have (see kMaxTilePayloadBytes), or ""
/// when `size` is within it.
std::string check_payload_size(std::size_t size, std::size_t cells) {
  // zlib's deflateBound for the longest inflated stream (kRaw's 8 bytes per cell are less).
  const std::size_t n = 2 * kMaxVarintBytes * cells;
  const std::size_t most = n + (n >> 12) + (n >> 14) + (n >> 25) + 64;
  if (size <= most) return {};
  return "payload of " + std::to_string(size) + " bytes, more than the " + std::to_string(most) +
         " a tile of " + std::to_string(cells) + " cells can need";
}
}  // namespace

template <class Msg>
std::optional<Applied> MapReplica::screen(const Msg& m, std::string* error) const {
  if (m.protocol() != msg::kProtocolVersion) {
    return reject(error, "protocol " + std::to_string(m.protocol()) + ", expected " +
                             std::to_string(msg::kProtocolVersion));
  }
  if (!map_id_.empty() && m.map_id().to_string() != map_id_) return Applied::kIgnored;
  if (m.epoch() < epoch_) return Applied::kIgnored;
  return std::nullopt;
}

Applied MapReplica::apply(const msg::MapTile& t, std::string* error) {
  if (const auto verdict = screen(t, error)) return *verdict;
  const std::string id = t.map_id().to_string();
  // A tile of a newer epoch (or the first one) starts a map: only the ranges are checked.
  const bool fresh = !map_ || t.epoch() > epoch_;
  if (std::string e = check_layout(t.cell_size(), t.tile_edge(), !fresh); !e.empty()) {
    return reject(error, e);
  }
  const std::size_t cells = static_cast<std::size_t>(t.tile_edge()) * t.tile_edge();
  const TileKey key{t.tx(), t.ty()};
  if (std::string e = check_tile(t.cells(), t.tile_edge(), key); !e.empty()) {
    return reject(error, e);
  }
  if (t.version() == 0) return reject(error, "version 0 (tile versions start at 1)");
  if (std::string e = check_payload_size(t.payload().size(), cells); !e.empty()) {
    return reject(error, e);
  }
  if (!fresh) {
    if (const Tile* have = map_->find_tile(key); have != nullptr && have->version >= t.version()) {
      return Applied::kStale;
    }
  }
  try {
    decode_tile(static_cast<TileEncoding>(t.encoding()), t.payload(), cells, hit_, err_);
  } catch (const std::exception& e) {
    return reject(error, std::string("payload: ") + e.what());
  }
  if (fresh) {
    if (map_id_.empty()) map_id_ = id;
    reset(t.epoch(), t.cell_size(), t.tile_edge());
  }
  map_->set_tile(key, t.version(), hit_, err_);
  return Applied::kApplied;
}

Applied MapReplica::apply(const msg::MapTileDelta& d, std::string* error) {
  if (const auto verdict = screen(d, error)) return *verdict;
  const bool same_map = map_ && d.epoch() == epoch_;
  if (std::string e = check_layout(d.cell_size(), d.tile_edge(), same_map); !e.empty()) {
    return reject(error, e);
  }
  const std::size_t cells = static_cast<std::size_t>(d.tile_edge()) * d.tile_edge();
  const TileKey key{d.tx(), d.ty()};
  if (std::string e = check_tile(d.cells(), d.tile_edge(), key); !e.empty()) {
    return reject(error, e);
  }
  if (d.base_version() >= d.version()) {
    return reject(error, "base_version " + std::to_string(d.base_version()) +
                             " is not older than version " + std::to_string(d.version()));
  }
  if (std::string e = check_payload_size(d.payload().size(), cells); !e.empty()) {
    return reject(error, e);
  }
  try {
    decode_tile(static_cast<TileEncoding>(d.encoding()), d.payload(), cells, hit_, err_);
  } catch (const std::exception& e) {
    return reject(error, std::string("payload: ") + e.what());
  }
  if (!same_map) return Applied::kNeedsBase;  // a map (or epoch) known only from deltas
  const Tile* have = map_->find_tile(key);
  if (have != nullptr && have->version >= d.version()) return Applied::kStale;
  if (have == nullptr || have->version != d.base_version()) return Applied::kNeedsBase;
  for (std::size_t i = 0; i < cells; ++i) {
    hit_[i] += have->hit[i];  // modulo 2^32, the inverse of the leader's subtraction
    err_[i] += have->err[i];
  }
  map_->set_tile(key, d.version(), hit_, err_);
  return Applied::kApplied;
}

Applied MapReplica::apply(const msg::MapMeta& m, std::string* error) {
  if (const auto verdict = screen(m, error)) return *verdict;
  const std::string id = m.map_id().to_string();
  const bool new_epoch = m.epoch() > epoch_ || !map_;
  if (std::string e = check_layout(m.cell_size(), m.tile_edge(), !new_epoch); !e.empty()) {
    return reject(error, e);
  }
  if (m.tile_count() > 0) {
    if (m.min_tx() > m.max_tx()) return reject(error, "min_tx > max_tx");
    if (m.min_ty() > m.max_ty()) return reject(error, "min_ty > max_ty");
    const std::int64_t limit = local_.max_tile_coord;
    for (const std::int32_t b : {m.min_tx(), m.min_ty(), m.max_tx(), m.max_ty()}) {
      if (std::abs(static_cast<std::int64_t>(b)) > limit) {
        return reject(error, "bounds [" + std::to_string(m.min_tx()) + ", " +
                                 std::to_string(m.max_tx()) + "] x [" + std::to_string(m.min_ty()) +
                                 ", " + std::to_string(m.max_ty()) + "] reach outside +-" +
                                 std::to_string(limit));
      }
    }
    const std::int64_t area = (static_cast<std::int64_t>(m.max_tx()) - m.min_tx() + 1) *
                              (static_cast<std::int64_t>(m.max_ty()) - m.min_ty() + 1);
    if (m.tile_count() > area) {
      return reject(error, "tile_count " + std::to_string(m.tile_count()) + " exceeds the " +
                               std::to_string(area) + " tiles of its bounds");
    }
  }
  if (new_epoch) {
    if (map_id_.empty()) map_id_ = id;
    reset(m.epoch(), m.cell_size(), m.tile_edge());
  } else if (meta_ && meta_->map_version() > m.map_version()) {
    return Applied::kStale;  // an older summary arriving late
  }
  meta_ = m;
  return Applied::kApplied;
}

bool MapReplica::complete() const {
  return map_ && meta_ && meta_->complete() && meta_->epoch() == epoch_ &&
         meta_->tile_count() == map_->tile_count() && meta_->map_version() == map_version(*map_);
}

}  // namespace esfleet::dds
