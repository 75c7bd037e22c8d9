#pragma once
// Tiled occupancy grid with per-cell hit/err counters (paper Eq. 2).
//
// The map is unbounded: square tiles of `tile_edge` x `tile_edge` cells are created on first
// touch. Each cell keeps two saturating counters, `hit` (beam end points that fell in it) and
// `err` (beams that passed through it); its value is hit / (hit + err), 0 while unknown.
//
// Besides the counters every tile keeps a derived `score` array, the only thing the pose search
// reads: kUnknownScore for an unknown cell, else hit / (hit + err) as a float that is < 1
// exactly when err > 0. One 4-byte load per beam then gives the map value and both penalty
// flags of Eq. (fitness). A dense directory of tile pointers over the tiles' bounding box makes
// a cell look-up a few shifts and two loads (GridMap::Lookup).
//
// Versioning: a map update (one scan insertion) touches cells through add_hit/add_err (or
// their _deferred forms, whose scores commit_update() refreshes, once per cell), then
// commit_update() bumps the version of every touched tile once and adds it to the dirty set
// that the leader drains with take_dirty() to publish changed tiles.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <unordered_map>
#include <utility>
#include <vector>

namespace esfleet {

struct CellIndex {
  std::int32_t x = 0;
  std::int32_t y = 0;
  friend bool operator==(const CellIndex&, const CellIndex&) = default;
};

/// True when cell coordinates (world coordinates over the cell size) are not finite or lie so
/// far out that no map reaches them: the allowed tiles end within 2^24 cells of the origin
/// (GridMapConfig: max_tile_coord <= 2^14, tile_edge <= 2^10). Code that turns a pose into
/// cell indices checks this first: such a pose scores nothing and writes nothing, where the
/// conversion to int32 would overflow (a wild odometry message put the robot at 1e300 m). Within
/// it, a beam of at most kMaxBeamRange (1000 m, scan_points.hpp) on cells of at least 1 mm adds
/// at most 1e6 cells, well inside int32.
inline bool beyond_any_map(double cx, double cy) {
  constexpr double kFar = 1e8;
  return !(std::abs(cx) < kFar && std::abs(cy) < kFar);
}

struct TileKey {
  std::int32_t tx = 0;
  std::int32_t ty = 0;
  friend bool operator==(const TileKey&, const TileKey&) = default;
  friend auto operator<=>(const TileKey&, const TileKey&) = default;
};

struct TileKeyHash {
  std::size_t operator()(const TileKey& k) const noexcept {
    return std::hash<std::uint64_t>{}(
        (static_cast<std::uint64_t>(static_cast<std::uint32_t>(k.tx)) << 32) |
        static_cast<std::uint32_t>(k.ty));
  }
};

/// Score of a cell nobody has observed (hit + err == 0).
inline constexpr float kUnknownScore = -1.0f;

struct GridMapConfig {
  double cell_size = 0.05;  ///< metres per cell edge (the paper's alpha^Map, value ours)
  int tile_edge = 64;       ///< cells per tile edge; a power of two in [8, 1024]
  /// Tiles may exist only with |tx|, |ty| <= this: bounds the directory and rejects absurd
  /// coordinates (64-cell tiles of 5 cm: +-3.3 km).
  int max_tile_coord = 1024;
  /// Tiles may span at most this many tiles along each axis (their bounding box): bounds the
  /// directory, which holds one pointer per tile of the box and level (2 MB per level at 512).
  /// Without it, two tiles at opposite corners of +-max_tile_coord, which a hostile peer can
  /// send as well-formed tiles, made an 8.4 M-slot directory, 67 MB per level. 512 tiles of
  /// 64 cells of 5 cm are 1.6 km, far more than a map of dds::kMaxTileKeys parts covers.
  int max_tile_span = 512;
  /// Coarse levels kept for coarse-to-fine search (ours, not in the paper): level k has cells
  /// 2^k times larger whose score is the maximum score of the cells they cover. 0 = none.
  int pyramid_levels = 0;
  /// Throws std::invalid_argument naming the offending field.
  void validate() const;
};

/// One square tile. Arrays are row-major: index = ly * edge + lx, (lx, ly) cell offsets inside
/// the tile from its lower-left cell (tx * edge, ty * edge).
struct Tile {
  TileKey key;
  std::uint64_t version = 0;  ///< bumped once per map update that changed the tile
  std::vector<std::uint32_t> hit;
  std::vector<std::uint32_t> err;
  std::vector<float> score;  ///< derived from hit/err, see kUnknownScore
  /// coarse[k - 1]: level-k scores, (edge >> k)^2 cells, max over the 2^k x 2^k cells covered.
  std::vector<std::vector<float>> coarse;
  /// One bit per cell whose counters a deferred write changed and whose score commit_update()
  /// has not refreshed yet (GridMap::add_err_deferred).
  std::vector<std::uint64_t> stale;
  bool touched = false;  ///< changed since the last commit_update()
  bool dirty = false;    ///< in the dirty set (changed since the last take_dirty())
};

class GridMap {
 public:
  explicit GridMap(GridMapConfig config = {});
  GridMap(const GridMap&) = delete;
  GridMap& operator=(const GridMap&) = delete;
  GridMap(GridMap&&) noexcept;
  GridMap& operator=(GridMap&&) noexcept;
  ~GridMap();

  const GridMapConfig& config() const { return config_; }
  double cell_size() const { return config_.cell_size; }
  int tile_edge() const { return config_.tile_edge; }

  /// The cell containing world point (x, y): floor(x / cell_size), floor(y / cell_size).
  CellIndex cell_of(double x, double y) const;
  TileKey tile_of(CellIndex c) const { return {c.x >> shift_, c.y >> shift_}; }
  /// True when a tile at this key is allowed: |tx|, |ty| <= max_tile_coord, and the tiles with
  /// it span at most max_tile_span tiles along each axis.
  bool key_in_range(TileKey k) const;

  std::uint32_t hit(CellIndex c) const;
  std::uint32_t err(CellIndex c) const;
  /// hit / (hit + err); 0 for an unknown cell (paper Eq. 2).
  float value(CellIndex c) const;
  /// The derived score: kUnknownScore if unknown, else value (< 1 exactly when err > 0).
  float score(CellIndex c) const;

  /// Map-update primitives: saturating increments; the tile is created on first touch.
  /// Return false (and change nothing) when the cell lies outside the allowed tile range.
  /// Inline, as the map update writes once per cell a beam crosses (tens of thousands of
  /// cells per scan).
  bool add_hit(CellIndex c) { return modify<true, true>(c); }
  bool add_err(CellIndex c) { return modify<false, true>(c); }
  /// The inverse primitives (saturating at 0), used to take a scan back out of the map when
  /// loop closure moves it.
  bool remove_hit(CellIndex c) { return modify<true, false>(c); }
  bool remove_err(CellIndex c) { return modify<false, false>(c); }
  /// The same four, but the cell's score is refreshed by the next commit_update(), once
  /// however often the cell was counted; until then score() and the look-ups read its score
  /// before. For the map update (update_map): many beams of a scan cross the cells near the
  /// robot, and a loop closure moves hundreds of overlapping scans in one update.
  bool add_hit_deferred(CellIndex c) { return modify<true, true, true>(c); }
  bool add_err_deferred(CellIndex c) { return modify<false, true, true>(c); }
  bool remove_hit_deferred(CellIndex c) { return modify<true, false, true>(c); }
  bool remove_err_deferred(CellIndex c) { return modify<false, false, true>(c); }

  /// Deferred err writes along a path of neighbouring cells (a beam, traverse_steps): the tile
  /// and the cell's index in it carry over from one cell to the next, so the directory is
  /// looked up only where the path enters another tile. write() is add_err_deferred (or
  /// remove_err_deferred, !kIncrement) of the current cell. No other write to the map may come
  /// between two of its writes.
  template <bool kIncrement>
  class ErrPath {
   public:
    ErrPath(GridMap& map, CellIndex start) : map_(map), cell_(start) { enter(); }
    /// False (and nothing changed) when the cell lies outside the allowed tile range.
    bool write();
    /// To the neighbour (x + mx, y + my), |mx| + |my| == 1.
    void move(std::int32_t mx, std::int32_t my);

   private:
    void enter();  ///< in-tile coordinates of cell_; its tile is looked up at the first write
    GridMap& map_;
    CellIndex cell_;
    Tile* tile_ = nullptr;
    bool looked_up_ = false;
    std::int32_t lx_ = 0, ly_ = 0, index_ = 0;
  };

  /// Ends one map update: refreshes the scores of the cells deferred writes changed, bumps
  /// each touched tile's version once and marks it dirty. Returns how many tiles changed.
  std::size_t commit_update();
  /// Keys of tiles changed since the previous call (sorted); clears the dirty set.
  std::vector<TileKey> take_dirty();
  /// Marks every existing tile dirty (e.g. to republish all).
  void mark_all_dirty();
  /// Every tile's counters back to zero (every cell unknown), as if every observation had been
  /// removed, the tiles kept; part of the update the next commit_update() ends (each tile
  /// touched). For re-writing most of a map's scans: adding them all again costs one walk per
  /// scan where removing and adding each costs two.
  void clear_counters();

  const Tile* find_tile(TileKey k) const;
  std::vector<TileKey> tile_keys() const;  ///< sorted
  std::size_t tile_count() const { return tiles_.size(); }
  std::size_t cells_per_tile() const {
    return static_cast<std::size_t>(config_.tile_edge) * config_.tile_edge;
  }

  /// Replaces (or creates) a whole tile from received counters, e.g. on a follower. The spans
  /// must hold cells_per_tile() entries; throws std::invalid_argument otherwise or when the key is
  /// out of range. Does not mark the tile dirty.
  void set_tile(TileKey k, std::uint64_t version, std::span<const std::uint32_t> hit,
                std::span<const std::uint32_t> err);

  struct Bounds {
    CellIndex min;  ///< inclusive
    CellIndex max;  ///< inclusive
    bool empty = true;
  };
  /// Bounding box of cells with hit + err > 0.
  Bounds known_bounds() const;
  /// The cells the tiles cover: the tiles' bounding box, in cells (every cell outside is
  /// unknown). Constant time.
  Bounds tile_bounds() const {
    if (tiles_.empty()) return {};
    const std::int32_t e = config_.tile_edge;
    return {{box_tx0_ * e, box_ty0_ * e}, {(box_tx1_ + 1) * e - 1, (box_ty1_ + 1) * e - 1}, false};
  }

  /// Read-only view of pyramid level `level` (0 = full resolution, cells of cell_size; level k
  /// cells of cell_size * 2^k) for the pose search; valid until the next tile is created.
  class Lookup {
   public:
    /// Branch-free: a missing tile, and any cell outside the directory, reads from a shared
    /// all-unknown tile (the directory's last entry), so the hot loop has no unpredictable
    /// branches. slot() and offset() split the address so callers can vectorise them.
    /// The addressing constants, by value: a hot loop keeps them in registers.
    struct Addressing {
      std::int32_t tx0, ty0, width, height, outside, mask;
      int shift, stride_shift;
      std::int32_t slot(std::int32_t cx, std::int32_t cy) const {
        const std::int32_t tx = (cx >> shift) - tx0;
        const std::int32_t ty = (cy >> shift) - ty0;
        const bool inside = (tx >= 0) & (tx < width) & (ty >= 0) & (ty < height);
        return inside ? (ty << stride_shift) + tx : outside;
      }
      std::int32_t offset(std::int32_t cx, std::int32_t cy) const {
        return ((cy & mask) << shift) | (cx & mask);
      }
    };
    Addressing addressing() const {
      return {tx0_, ty0_, width_, height_, outside_, mask_, shift_, stride_shift_};
    }
    std::int32_t slot(std::int32_t cx, std::int32_t cy) const { return addressing().slot(cx, cy); }
    std::int32_t offset(std::int32_t cx, std::int32_t cy) const {
      return addressing().offset(cx, cy);
    }
    const float* tile(std::int32_t slot) const { return dir_[slot]; }
    float score(std::int32_t cx, std::int32_t cy) const {
      return dir_[slot(cx, cy)][offset(cx, cy)];
    }

   private:
    friend class GridMap;
    const float* const* dir_ = nullptr;
    std::int32_t tx0_ = 0, ty0_ = 0;
    std::int32_t width_ = 0, height_ = 0;
    int stride_shift_ = 0;
    std::int32_t outside_ = 0;  ///< directory index of the all-unknown tile
    int shift_ = 0;
    std::int32_t mask_ = 0;
  };
  Lookup lookup(int level = 0) const;
  int pyramid_levels() const { return config_.pyramid_levels; }

 private:
  Tile* tile_for_write(CellIndex c);
  template <bool kHitCounter, bool kIncrement, bool kDeferred = false>
  bool modify(CellIndex c);
  /// modify()'s write to cell i of a tile it found: the counter, then the score or stale bit.
  template <bool kHitCounter, bool kIncrement, bool kDeferred>
  static void count(Tile& t, std::size_t i);
  void mark_touched(Tile& t) {
    if (!t.touched) {
      t.touched = true;
      touched_.push_back(&t);
    }
  }
  void grow_directory(TileKey k);
  static void refresh_score(Tile& t, std::size_t i);
  void rebuild_coarse(Tile& t) const;
  void set_directory_entry(std::size_t i, Tile* t);
  std::size_t dir_slot(TileKey k) const;

  GridMapConfig config_;
  int shift_ = 6;
  std::int32_t mask_ = 63;
  std::unordered_map<TileKey, std::unique_ptr<Tile>, TileKeyHash> tiles_;
  std::vector<Tile*> touched_;
  /// The tile the last write went to (tiles never move or go away): consecutive cells of a
  /// beam mostly share a tile, so a write skips the directory. A moved-from map forgets it.
  struct LastTile {
    TileKey key;
    Tile* tile = nullptr;
    LastTile() = default;
    LastTile(LastTile&& o) noexcept : key(o.key), tile(std::exchange(o.tile, nullptr)) {}
    LastTile& operator=(LastTile&& o) noexcept {
      key = o.key;
      tile = std::exchange(o.tile, nullptr);
      return *this;
    }
  };
  LastTile last_;
  std::vector<TileKey> dirty_;
  // Directory over tiles [dir_tx0_, dir_tx0_ + dir_w_) x [dir_ty0_, dir_ty0_ + dir_h_).
  /// [level][tile] score arrays; missing tiles and the extra last entry point at unknown_tile_.
  std::vector<std::vector<const float*>> dir_levels_;
  std::vector<float> unknown_tile_;
  std::vector<Tile*> dir_tiles_;
  std::int32_t dir_tx0_ = 0, dir_ty0_ = 0;
  std::uint32_t dir_w_ = 0, dir_h_ = 0;
  int dir_stride_shift_ = 0;
  // Bounding box of the tiles, inclusive (meaningful when tiles_ is not empty).
  std::int32_t box_tx0_ = 0, box_ty0_ = 0, box_tx1_ = 0, box_ty1_ = 0;
};

inline void GridMap::refresh_score(Tile& t, std::size_t i) {
  const std::uint32_t h = t.hit[i], e = t.err[i];
  // Signed 64-bit: converts to double in one instruction (unsigned 64-bit takes several), and
  // exactly, as every count here is below 2^33.
  const std::int64_t total = std::int64_t{h} + std::int64_t{e};
  if (total == 0) {
    t.score[i] = kUnknownScore;
    return;
  }
  auto s = static_cast<float>(static_cast<double>(std::int64_t{h}) / static_cast<double>(total));
  // Keep "score < 1 exactly when err > 0" even where the float ratio rounds up to 1.
  if (e > 0 && s >= 1.0f) s = std::nextafter(1.0f, 0.0f);
  t.score[i] = s;
}

template <bool kHitCounter, bool kIncrement, bool kDeferred>
void GridMap::count(Tile& t, std::size_t i) {
  std::uint32_t& v = kHitCounter ? t.hit[i] : t.err[i];
  // Saturate at both ends: counters never wrap.
  if constexpr (kIncrement) {
    if (v != std::numeric_limits<std::uint32_t>::max()) ++v;
  } else if (v != 0) {
    --v;
  }
  if constexpr (kDeferred) {
    t.stale[i >> 6] |= std::uint64_t{1} << (i & 63);
  } else {
    refresh_score(t, i);
  }
}

template <bool kHitCounter, bool kIncrement, bool kDeferred>
bool GridMap::modify(CellIndex c) {
  const TileKey k = tile_of(c);
  Tile* t = last_.tile;
  if (t == nullptr || !(k == last_.key)) [[unlikely]] {
    t = tile_for_write(c);
    if (t == nullptr) return false;
    last_.key = k;
    last_.tile = t;
  }
  count<kHitCounter, kIncrement, kDeferred>(
      *t, static_cast<std::size_t>(((c.y & mask_) << shift_) | (c.x & mask_)));
  mark_touched(*t);
  return true;
}

template <bool kIncrement>
void GridMap::ErrPath<kIncrement>::enter() {
  lx_ = cell_.x & map_.mask_;
  ly_ = cell_.y & map_.mask_;
  index_ = (ly_ << map_.shift_) | lx_;
  looked_up_ = false;
}

template <bool kIncrement>
bool GridMap::ErrPath<kIncrement>::write() {
  if (!looked_up_) [[unlikely]] {
    tile_ = map_.tile_for_write(cell_);
    looked_up_ = true;
    // Touched now: the write below is the tile's first on this path, and no commit comes
    // between the writes of a path.
    if (tile_ != nullptr) map_.mark_touched(*tile_);
  }
  if (tile_ == nullptr) return false;
  count<false, kIncrement, true>(*tile_, static_cast<std::size_t>(index_));
  return true;
}

template <bool kIncrement>
void GridMap::ErrPath<kIncrement>::move(std::int32_t mx, std::int32_t my) {
  cell_.x += mx;
  cell_.y += my;
  lx_ += mx;
  ly_ += my;
  // Off the tile's edge on either side (a negative coordinate is a large unsigned one).
  if (static_cast<std::uint32_t>(lx_ | ly_) > static_cast<std::uint32_t>(map_.mask_)) [[unlikely]] {
    enter();
    return;
  }
  index_ += mx + my * (std::int32_t{1} << map_.shift_);
}

}  // namespace esfleet
