#include "esfleet/core/grid_map.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace esfleet {

void GridMapConfig::validate() const {
  if (!(cell_size >= 0.001) || !std::isfinite(cell_size) || cell_size > 10.0) {
    throw std::invalid_argument("map.cell_size must be in [0.001, 10] m, got " +
                                std::to_string(cell_size));
  }
  if (tile_edge < 8 || tile_edge > 1024 || !std::has_single_bit(static_cast<unsigned>(tile_edge))) {
    throw std::invalid_argument("map.tile_edge must be a power of two in [8, 1024], got " +
                                std::to_string(tile_edge));
  }
  if (pyramid_levels < 0 || pyramid_levels > 4 || (1 << pyramid_levels) > tile_edge) {
    throw std::invalid_argument(
        "map.pyramid_levels must be in [0, 4] with 2^levels <= tile_edge, got " +
        std::to_string(pyramid_levels));
  }
  if (max_tile_coord < 1 || max_tile_coord > 1 << 14) {
    throw std::invalid_argument("map.max_tile_coord must be in [1, 16384], got " +
                                std::to_string(max_tile_coord));
  }
  if (max_tile_span < 1 || max_tile_span > 1 << 15) {
    throw std::invalid_argument("map.max_tile_span must be in [1, 32768], got " +
                                std::to_string(max_tile_span));
  }
}

GridMap::GridMap(GridMapConfig config) : config_(config) {
  config_.validate();
  shift_ = std::countr_zero(static_cast<unsigned>(config_.tile_edge));
  mask_ = config_.tile_edge - 1;
  unknown_tile_.assign(cells_per_tile(), kUnknownScore);
  dir_levels_.assign(static_cast<std::size_t>(config_.pyramid_levels) + 1,
                     std::vector<const float*>(1, unknown_tile_.data()));
}

GridMap::GridMap(GridMap&&) noexcept = default;
GridMap& GridMap::operator=(GridMap&&) noexcept = default;
GridMap::~GridMap() = default;

CellIndex GridMap::cell_of(double x, double y) const {
  // Clamp before converting so a wild coordinate cannot overflow int32; such cells are rejected
  // by key_in_range() anyway.
  constexpr double kLimit = 1e9;
  const double fx = std::clamp(std::floor(x / config_.cell_size), -kLimit, kLimit);
  const double fy = std::clamp(std::floor(y / config_.cell_size), -kLimit, kLimit);
  return {static_cast<std::int32_t>(fx), static_cast<std::int32_t>(fy)};
}

bool GridMap::key_in_range(TileKey k) const {
  const std::int32_t m = config_.max_tile_coord;
  if (k.tx < -m || k.tx > m || k.ty < -m || k.ty > m) return false;
  if (tiles_.empty()) return true;
  const std::int64_t span = config_.max_tile_span;
  return std::int64_t{std::max(box_tx1_, k.tx)} - std::min(box_tx0_, k.tx) < span &&
         std::int64_t{std::max(box_ty1_, k.ty)} - std::min(box_ty0_, k.ty) < span;
}

const Tile* GridMap::find_tile(TileKey k) const {
  const auto it = tiles_.find(k);
  return it == tiles_.end() ? nullptr : it->second.get();
}

std::uint32_t GridMap::hit(CellIndex c) const {
  const Tile* t = find_tile(tile_of(c));
  return t ? t->hit[static_cast<std::size_t>(((c.y & mask_) << shift_) | (c.x & mask_))] : 0;
}

std::uint32_t GridMap::err(CellIndex c) const {
  const Tile* t = find_tile(tile_of(c));
  return t ? t->err[static_cast<std::size_t>(((c.y & mask_) << shift_) | (c.x & mask_))] : 0;
}

float GridMap::score(CellIndex c) const {
  const Tile* t = find_tile(tile_of(c));
  return t ? t->score[static_cast<std::size_t>(((c.y & mask_) << shift_) | (c.x & mask_))]
           : kUnknownScore;
}

float GridMap::value(CellIndex c) const { return std::max(score(c), 0.0f); }

void GridMap::grow_directory(TileKey k) {
  std::int32_t x0 = k.tx, y0 = k.ty, x1 = k.tx, y1 = k.ty;
  if (dir_w_ > 0) {
    const std::int32_t old_x1 = dir_tx0_ + static_cast<std::int32_t>(dir_w_) - 1;
    const std::int32_t old_y1 = dir_ty0_ + static_cast<std::int32_t>(dir_h_) - 1;
    x0 = std::min(x0, dir_tx0_);
    y0 = std::min(y0, dir_ty0_);
    x1 = std::max(x1, old_x1);
    y1 = std::max(y1, old_y1);
    // Grow with a margin on the side that overflowed, so an exploring robot does not re-layout
    // the directory at every new tile.
    const std::int32_t mx = std::max<std::int32_t>(4, (x1 - x0 + 1) / 2);
    const std::int32_t my = std::max<std::int32_t>(4, (y1 - y0 + 1) / 2);
    if (k.tx < dir_tx0_) x0 -= mx;
    if (k.tx > old_x1) x1 += mx;
    if (k.ty < dir_ty0_) y0 -= my;
    if (k.ty > old_y1) y1 += my;
  } else {
    x0 -= 4;
    y0 -= 4;
    x1 += 4;
    y1 += 4;
  }
  const std::int32_t m = config_.max_tile_coord;
  x0 = std::max(x0, -m);
  y0 = std::max(y0, -m);
  x1 = std::min(x1, m);
  y1 = std::min(y1, m);
  // No wider than max_tile_span: the margin shrinks, the tiles' box (with k, which
  // key_in_range admitted) always fits.
  const std::int32_t span = config_.max_tile_span;
  x0 = std::max(x0, std::max(box_tx1_, k.tx) - span + 1);
  x1 = std::min(x1, std::min(box_tx0_, k.tx) + span - 1);
  y0 = std::max(y0, std::max(box_ty1_, k.ty) - span + 1);
  y1 = std::min(y1, std::min(box_ty0_, k.ty) + span - 1);
  const auto w = static_cast<std::uint32_t>(x1 - x0 + 1);
  const auto h = static_cast<std::uint32_t>(y1 - y0 + 1);
  // Rows are a power of two apart so a look-up computes the slot with a shift.
  dir_stride_shift_ = std::countr_zero(std::bit_ceil(w));
  const std::size_t n = (static_cast<std::size_t>(h) << dir_stride_shift_);
  dir_tiles_.assign(n, nullptr);
  for (auto& level : dir_levels_) level.assign(n + 1, unknown_tile_.data());
  dir_tx0_ = x0;
  dir_ty0_ = y0;
  dir_w_ = w;
  dir_h_ = h;
  for (auto& [key, tile] : tiles_) set_directory_entry(dir_slot(key), tile.get());
}

std::size_t GridMap::dir_slot(TileKey k) const {
  return (static_cast<std::size_t>(k.ty - dir_ty0_) << dir_stride_shift_) +
         static_cast<std::size_t>(k.tx - dir_tx0_);
}

void GridMap::set_directory_entry(std::size_t i, Tile* t) {
  dir_tiles_[i] = t;
  dir_levels_[0][i] = t->score.data();
  for (std::size_t k = 1; k < dir_levels_.size(); ++k) dir_levels_[k][i] = t->coarse[k - 1].data();
}

void GridMap::rebuild_coarse(Tile& t) const {
  // Level k from level k-1: each coarse cell is the max of its 2x2 children, so it is the max
  // over the 2^k x 2^k full-resolution cells it covers. kUnknownScore (-1) loses to any known
  // score, so a coarse cell is unknown only when all its cells are.
  const float* finer = t.score.data();
  std::size_t finer_edge = static_cast<std::size_t>(config_.tile_edge);
  for (auto& level : t.coarse) {
    const std::size_t edge = finer_edge / 2;
    for (std::size_t y = 0; y < edge; ++y) {
      const float* r0 = finer + (2 * y) * finer_edge;
      const float* r1 = r0 + finer_edge;
      for (std::size_t x = 0; x < edge; ++x) {
        level[y * edge + x] =
            std::max(std::max(r0[2 * x], r0[2 * x + 1]), std::max(r1[2 * x], r1[2 * x + 1]));
      }
    }
    finer = level.data();
    finer_edge = edge;
  }
}

Tile* GridMap::tile_for_write(CellIndex c) {
  const TileKey k = tile_of(c);
  const auto dx = static_cast<std::uint32_t>(k.tx - dir_tx0_);
  const auto dy = static_cast<std::uint32_t>(k.ty - dir_ty0_);
  if (dx < dir_w_ && dy < dir_h_) {
    if (Tile* t = dir_tiles_[dir_slot(k)]) return t;
  }
  if (!key_in_range(k)) return nullptr;
  auto tile = std::make_unique<Tile>();
  tile->key = k;
  const std::size_t n = cells_per_tile();
  tile->hit.assign(n, 0);
  tile->err.assign(n, 0);
  tile->score.assign(n, kUnknownScore);
  tile->stale.assign((n + 63) / 64, 0);
  for (int level = 1; level <= config_.pyramid_levels; ++level) {
    tile->coarse.emplace_back(n >> (2 * level), kUnknownScore);
  }
  Tile* raw = tile.get();
  if (tiles_.empty()) {
    box_tx0_ = box_tx1_ = k.tx;
    box_ty0_ = box_ty1_ = k.ty;
  }
  tiles_.emplace(k, std::move(tile));
  if (dx < dir_w_ && dy < dir_h_) {
    set_directory_entry(dir_slot(k), raw);
  } else {
    grow_directory(k);
  }
  box_tx0_ = std::min(box_tx0_, k.tx);
  box_ty0_ = std::min(box_ty0_, k.ty);
  box_tx1_ = std::max(box_tx1_, k.tx);
  box_ty1_ = std::max(box_ty1_, k.ty);
  return raw;
}

std::size_t GridMap::commit_update() {
  const std::size_t n = touched_.size();
  for (Tile* t : touched_) {
    t->touched = false;
    for (std::size_t w = 0; w < t->stale.size(); ++w) {
      for (std::uint64_t bits = std::exchange(t->stale[w], 0); bits != 0; bits &= bits - 1) {
        refresh_score(*t, 64 * w + static_cast<std::size_t>(std::countr_zero(bits)));
      }
    }
    rebuild_coarse(*t);
    ++t->version;
    if (!t->dirty) {
      t->dirty = true;
      dirty_.push_back(t->key);
    }
  }
  touched_.clear();
  return n;
}

std::vector<TileKey> GridMap::take_dirty() {
  std::vector<TileKey> out;
  out.swap(dirty_);
  for (const TileKey& k : out) tiles_.at(k)->dirty = false;
  std::sort(out.begin(), out.end());
  return out;
}

void GridMap::mark_all_dirty() {
  for (auto& [key, tile] : tiles_) {
    if (!tile->dirty) {
      tile->dirty = true;
      dirty_.push_back(key);
    }
  }
}

void GridMap::clear_counters() {
  for (auto& [key, tile] : tiles_) {
    Tile& t = *tile;
    std::fill(t.hit.begin(), t.hit.end(), 0u);
    std::fill(t.err.begin(), t.err.end(), 0u);
    std::fill(t.score.begin(), t.score.end(), kUnknownScore);
    std::fill(t.stale.begin(), t.stale.end(), std::uint64_t{0});
    mark_touched(t);  // commit_update() rebuilds its coarse levels and bumps its version
  }
}

std::vector<TileKey> GridMap::tile_keys() const {
  std::vector<TileKey> keys;
  keys.reserve(tiles_.size());
  for (const auto& [key, tile] : tiles_) keys.push_back(key);
  std::sort(keys.begin(), keys.end());
  return keys;
}

void GridMap::set_tile(TileKey k, std::uint64_t version, std::span<const std::uint32_t> hit,
                       std::span<const std::uint32_t> err) {
  const std::size_t n = cells_per_tile();
  if (hit.size() != n || err.size() != n) {
    throw std::invalid_argument("tile (" + std::to_string(k.tx) + ", " + std::to_string(k.ty) +
                                ") has " + std::to_string(hit.size()) + "/" +
                                std::to_string(err.size()) + " hit/err cells, expected " +
                                std::to_string(n));
  }
  if (!key_in_range(k)) {
    throw std::invalid_argument("tile (" + std::to_string(k.tx) + ", " + std::to_string(k.ty) +
                                ") is outside +-" + std::to_string(config_.max_tile_coord) +
                                " or makes the tiles span more than " +
                                std::to_string(config_.max_tile_span));
  }
  Tile* t = tile_for_write(CellIndex{k.tx * config_.tile_edge, k.ty * config_.tile_edge});
  std::copy(hit.begin(), hit.end(), t->hit.begin());
  std::copy(err.begin(), err.end(), t->err.begin());
  for (std::size_t i = 0; i < n; ++i) refresh_score(*t, i);
  rebuild_coarse(*t);
  t->version = version;
}

GridMap::Bounds GridMap::known_bounds() const {
  Bounds b;
  const std::int32_t edge = config_.tile_edge;
  for (const auto& [key, tile] : tiles_) {
    for (std::int32_t ly = 0; ly < edge; ++ly) {
      for (std::int32_t lx = 0; lx < edge; ++lx) {
        const auto i = static_cast<std::size_t>(ly * edge + lx);
        if (tile->score[i] == kUnknownScore) continue;
        const CellIndex c{key.tx * edge + lx, key.ty * edge + ly};
        if (b.empty) {
          b.min = b.max = c;
          b.empty = false;
        } else {
          b.min = {std::min(b.min.x, c.x), std::min(b.min.y, c.y)};
          b.max = {std::max(b.max.x, c.x), std::max(b.max.y, c.y)};
        }
      }
    }
  }
  return b;
}

GridMap::Lookup GridMap::lookup(int level) const {
  if (level < 0 || level > config_.pyramid_levels) {
    throw std::invalid_argument("map level " + std::to_string(level) +
                                " not kept (pyramid_levels " +
                                std::to_string(config_.pyramid_levels) + ")");
  }
  Lookup l;
  l.dir_ = dir_levels_[static_cast<std::size_t>(level)].data();
  l.tx0_ = dir_tx0_;
  l.ty0_ = dir_ty0_;
  l.width_ = static_cast<std::int32_t>(dir_w_);
  l.height_ = static_cast<std::int32_t>(dir_h_);
  l.stride_shift_ = dir_stride_shift_;
  l.shift_ = shift_ - level;
  l.mask_ = mask_ >> level;
  l.outside_ = static_cast<std::int32_t>(dir_levels_[0].size() - 1);
  return l;
}

}  // namespace esfleet
