#include "esfleet/mapshare/map_replica.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>

namespace esfleet::mapshare {

namespace {
Applied reject(std::string* error, std::string what) {
  if (error != nullptr) *error = std::move(what);
  return Applied::kRejected;
}
}  // namespace

MapReplica::MapReplica(std::string map_id, GridMapConfig local)
    : map_id_(std::move(map_id)), local_(local) {
  local_.validate();
}

GridMapConfig MapReplica::layout_config(float cell_size, std::uint32_t tile_edge) const {
  GridMapConfig c = local_;
  c.cell_size = cell_size;
  c.tile_edge = static_cast<int>(std::min<std::uint32_t>(tile_edge, INT32_MAX));
  if ((1 << c.pyramid_levels) > c.tile_edge) c.pyramid_levels = 0;
  return c;
}

void MapReplica::reset(std::uint32_t epoch, float cell_size, int tile_edge) {
  map_.reset();
  map_.emplace(layout_config(cell_size, static_cast<std::uint32_t>(tile_edge)));
  epoch_ = epoch;
  meta_.reset();
}

std::string MapReplica::check_layout(float cell_size, std::uint32_t tile_edge,
                                     bool against_map) const {
  // The map's own validation, so that whatever passes here makes a GridMap (reset()): a
  // cell size of 0.5 mm passed an older copy of these checks and then threw in reset().
  try {
    layout_config(cell_size, tile_edge).validate();
  } catch (const std::invalid_argument& e) {
    return e.what();
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

std::string MapReplica::check_tile(const TileMessage& t, bool against_map) const {
  if (std::string e = check_layout(t.cell_size, t.tile_edge, against_map); !e.empty()) return e;
  const std::size_t expected = static_cast<std::size_t>(t.tile_edge) * t.tile_edge;
  if (t.cells != expected) {
    return "cells " + std::to_string(t.cells) +
           ", expected tile_edge^2 = " + std::to_string(expected);
  }
  if (std::abs(static_cast<std::int64_t>(t.tx)) > local_.max_tile_coord ||
      std::abs(static_cast<std::int64_t>(t.ty)) > local_.max_tile_coord) {
    return "tile (" + std::to_string(t.tx) + ", " + std::to_string(t.ty) + ") is outside +-" +
           std::to_string(local_.max_tile_coord);
  }
  // Bounds the directory of the map (GridMapConfig::max_tile_span): two tiles far apart, even
  // well-formed ones, cannot make it huge.
  if (against_map && map_ && !map_->key_in_range(t.key())) {
    return "tile (" + std::to_string(t.tx) + ", " + std::to_string(t.ty) +
           ") would make the map span more than " + std::to_string(local_.max_tile_span) + " tiles";
  }
  if (t.is_delta() && *t.base_version >= t.version) {
    return "base_version " + std::to_string(*t.base_version) + " is not older than version " +
           std::to_string(t.version);
  }
  if (!t.is_delta() && t.version == 0) return "version 0 (tile versions start at 1)";
  if (const std::size_t most = max_payload_bytes(expected); t.payload.size() > most) {
    return "payload of " + std::to_string(t.payload.size()) + " bytes, more than the " +
           std::to_string(most) + " a tile of " + std::to_string(expected) + " cells can need";
  }
  return {};
}

std::optional<Applied> MapReplica::screen(std::uint16_t protocol, const std::string& map_id,
                                          std::uint32_t epoch, std::string* error) const {
  if (protocol != kProtocolVersion) {
    return reject(error, "protocol " + std::to_string(protocol) + ", expected " +
                             std::to_string(kProtocolVersion));
  }
  if (!map_id_.empty() && map_id != map_id_) return Applied::kIgnored;
  if (epoch < epoch_) return Applied::kIgnored;
  return std::nullopt;
}

Applied MapReplica::apply(const TileMessage& tile, std::string* error) {
  if (const auto verdict = screen(tile.protocol, tile.map_id, tile.epoch, error)) return *verdict;
  return tile.is_delta() ? apply_delta(tile, error) : apply_whole(tile, error);
}

Applied MapReplica::apply_whole(const TileMessage& t, std::string* error) {
  // A tile of a newer epoch (or the first one) starts a map: only the ranges are checked.
  const bool fresh = !map_ || t.epoch > epoch_;
  if (std::string e = check_tile(t, !fresh); !e.empty()) return reject(error, e);
  if (!fresh) {
    if (const Tile* have = map_->find_tile(t.key());
        have != nullptr && have->version >= t.version) {
      return Applied::kStale;
    }
  }
  try {
    decode_tile(static_cast<TileEncoding>(t.encoding), t.payload, t.cells, hit_, err_);
  } catch (const std::exception& e) {
    return reject(error, std::string("payload: ") + e.what());
  }
  if (fresh) {
    if (map_id_.empty()) map_id_ = t.map_id;
    reset(t.epoch, t.cell_size, t.tile_edge);
  }
  map_->set_tile(t.key(), t.version, hit_, err_);
  return Applied::kApplied;
}

Applied MapReplica::apply_delta(const TileMessage& d, std::string* error) {
  const bool same_map = map_ && d.epoch == epoch_;
  if (std::string e = check_tile(d, same_map); !e.empty()) return reject(error, e);
  try {
    decode_tile(static_cast<TileEncoding>(d.encoding), d.payload, d.cells, hit_, err_);
  } catch (const std::exception& e) {
    return reject(error, std::string("payload: ") + e.what());
  }
  if (!same_map) return Applied::kNeedsBase;  // a map (or epoch) known only from deltas
  const Tile* have = map_->find_tile(d.key());
  if (have != nullptr && have->version >= d.version) return Applied::kStale;
  if (have == nullptr || have->version != *d.base_version) return Applied::kNeedsBase;
  for (std::size_t i = 0; i < d.cells; ++i) {
    hit_[i] += have->hit[i];  // modulo 2^32, the inverse of the leader's subtraction
    err_[i] += have->err[i];
  }
  map_->set_tile(d.key(), d.version, hit_, err_);
  return Applied::kApplied;
}

Applied MapReplica::apply(const MetaMessage& m, std::string* error) {
  if (const auto verdict = screen(m.protocol, m.map_id, m.epoch, error)) return *verdict;
  const bool new_epoch = m.epoch > epoch_ || !map_;
  if (std::string e = check_layout(m.cell_size, m.tile_edge, !new_epoch); !e.empty()) {
    return reject(error, e);
  }
  if (m.tile_count > 0) {
    if (m.min_tx > m.max_tx) return reject(error, "min_tx > max_tx");
    if (m.min_ty > m.max_ty) return reject(error, "min_ty > max_ty");
    const std::int64_t limit = local_.max_tile_coord;
    for (const std::int32_t b : {m.min_tx, m.min_ty, m.max_tx, m.max_ty}) {
      if (std::abs(static_cast<std::int64_t>(b)) > limit) {
        return reject(error, "bounds [" + std::to_string(m.min_tx) + ", " +
                                 std::to_string(m.max_tx) + "] x [" + std::to_string(m.min_ty) +
                                 ", " + std::to_string(m.max_ty) + "] reach outside +-" +
                                 std::to_string(limit));
      }
    }
    const std::int64_t area = (static_cast<std::int64_t>(m.max_tx) - m.min_tx + 1) *
                              (static_cast<std::int64_t>(m.max_ty) - m.min_ty + 1);
    if (m.tile_count > area) {
      return reject(error, "tile_count " + std::to_string(m.tile_count) + " exceeds the " +
                               std::to_string(area) + " tiles of its bounds");
    }
  }
  if (new_epoch) {
    if (map_id_.empty()) map_id_ = m.map_id;
    reset(m.epoch, m.cell_size, m.tile_edge);
  } else if (meta_ && meta_->map_version > m.map_version) {
    return Applied::kStale;  // an older summary arriving late
  }
  meta_ = m;
  return Applied::kApplied;
}

bool MapReplica::complete() const {
  return map_ && meta_ && meta_->complete && meta_->epoch == epoch_ &&
         meta_->tile_count == map_->tile_count() && meta_->map_version == map_version(*map_);
}

bool MapReplica::arriving() const {
  return meta_ && meta_->complete && meta_->epoch == epoch_ &&
         (!map_ || map_->tile_count() < meta_->tile_count);
}

void ReceiveStats::count_tile(bool delta, Applied outcome) {
  if (!delta) {
    ++tiles_received;
    switch (outcome) {
      case Applied::kApplied:
        ++tiles_applied;
        break;
      case Applied::kStale:
        ++tiles_stale;
        break;
      case Applied::kIgnored:
        ++tiles_ignored;
        break;
      case Applied::kRejected:
      case Applied::kNeedsBase:  // not returned for whole tiles
        ++tiles_rejected;
        break;
    }
    return;
  }
  ++deltas_received;
  switch (outcome) {
    case Applied::kApplied:
      ++deltas_applied;
      break;
    case Applied::kStale:
      ++deltas_stale;
      break;
    case Applied::kNeedsBase:
      ++deltas_needs_base;
      break;
    case Applied::kIgnored:
      ++deltas_ignored;
      break;
    case Applied::kRejected:
      ++deltas_rejected;
      break;
  }
}

void ReceiveStats::count_meta(Applied outcome) {
  ++meta_received;
  if (outcome == Applied::kRejected) ++meta_rejected;
}

}  // namespace esfleet::mapshare
