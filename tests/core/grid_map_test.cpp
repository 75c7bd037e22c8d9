#include "esfleet/core/grid_map.hpp"

#include <gtest/gtest.h>

#include <limits>
#include <stdexcept>
#include <vector>

namespace esfleet {
namespace {

TEST(GridMapTest, UnknownCellsReadZero) {
  GridMap map;
  EXPECT_EQ(map.hit({5, 7}), 0u);
  EXPECT_EQ(map.err({5, 7}), 0u);
  EXPECT_EQ(map.value({5, 7}), 0.0f);
  EXPECT_EQ(map.score({5, 7}), kUnknownScore);
  EXPECT_EQ(map.tile_count(), 0u);
}

TEST(GridMapTest, CellOfFloorsNegativeCoordinates) {
  GridMap map(GridMapConfig{.cell_size = 0.5});
  EXPECT_EQ(map.cell_of(0.0, 0.0), (CellIndex{0, 0}));
  EXPECT_EQ(map.cell_of(0.49, 0.51), (CellIndex{0, 1}));
  EXPECT_EQ(map.cell_of(-0.01, -0.5), (CellIndex{-1, -1}));
  EXPECT_EQ(map.cell_of(-0.51, 1e12).x, -2);
}

TEST(GridMapTest, CountersGiveEquationTwoValue) {
  GridMap map;
  const CellIndex c{-3, 130};
  ASSERT_TRUE(map.add_hit(c));
  ASSERT_TRUE(map.add_hit(c));
  ASSERT_TRUE(map.add_hit(c));
  ASSERT_TRUE(map.add_err(c));
  EXPECT_EQ(map.hit(c), 3u);
  EXPECT_EQ(map.err(c), 1u);
  EXPECT_FLOAT_EQ(map.value(c), 0.75f);
  EXPECT_FLOAT_EQ(map.score(c), 0.75f);
  // Tile created on first touch, keyed by floor division.
  ASSERT_EQ(map.tile_count(), 1u);
  EXPECT_EQ(map.tile_keys().front(), (TileKey{-1, 2}));
}

TEST(GridMapTest, ErrOnlyCellScoresZeroButIsKnown) {
  GridMap map;
  map.add_err({1, 1});
  EXPECT_EQ(map.value({1, 1}), 0.0f);
  EXPECT_EQ(map.score({1, 1}), 0.0f);
  EXPECT_NE(map.score({1, 1}), kUnknownScore);
}

TEST(GridMapTest, LookupMatchesScoreEverywhere) {
  GridMap map(GridMapConfig{.cell_size = 0.05, .tile_edge = 8});
  // Touch cells spread over many tiles, including negative ones, forcing directory growth.
  for (int i = -40; i < 40; i += 3) {
    map.add_hit({i, -i / 2});
    map.add_err({i * 2, i});
  }
  const GridMap::Lookup view = map.lookup();
  for (int y = -60; y < 60; ++y) {
    for (int x = -90; x < 90; ++x) {
      ASSERT_EQ(view.score(x, y), map.score({x, y})) << "cell " << x << "," << y;
    }
  }
}

TEST(GridMapTest, VersionBumpsOncePerCommitAndDirtySetDrains) {
  GridMap map(GridMapConfig{.cell_size = 0.05, .tile_edge = 16});
  map.add_hit({0, 0});
  map.add_err({1, 0});
  map.add_hit({20, 0});  // second tile
  EXPECT_EQ(map.commit_update(), 2u);
  EXPECT_EQ(map.find_tile({0, 0})->version, 1u);
  EXPECT_EQ(map.find_tile({1, 0})->version, 1u);
  map.add_hit({0, 0});
  EXPECT_EQ(map.commit_update(), 1u);
  EXPECT_EQ(map.find_tile({0, 0})->version, 2u);
  EXPECT_EQ(map.find_tile({1, 0})->version, 1u);
  const std::vector<TileKey> dirty = map.take_dirty();
  ASSERT_EQ(dirty.size(), 2u);  // each tile once, sorted
  EXPECT_EQ(dirty[0], (TileKey{0, 0}));
  EXPECT_EQ(dirty[1], (TileKey{1, 0}));
  EXPECT_TRUE(map.take_dirty().empty());
  map.mark_all_dirty();
  EXPECT_EQ(map.take_dirty().size(), 2u);
}

TEST(GridMapTest, DeferredWritesScoreAtCommitAsImmediateOnes) {
  // The same writes, immediate on one map and deferred on the other, with pyramid levels: the
  // deferred map keeps its old scores until commit_update(), then every score and coarse cell
  // is what the immediate map holds. Cells are written many times, removed and added again.
  const GridMapConfig config{.cell_size = 0.05, .tile_edge = 8, .pyramid_levels = 2};
  GridMap now(config), later(config);
  now.add_hit({40, 40});
  later.add_hit({40, 40});
  now.commit_update();
  later.commit_update();
  const auto write = [](GridMap& map, bool deferred, int i) {
    const CellIndex a{i % 13 - 6, (i * 7) % 11 - 5}, b{(i * 5) % 17 - 8, i % 9 - 4};
    if (deferred) {
      map.add_err_deferred(a);
      map.add_hit_deferred(b);
      if (i % 3 == 0) map.remove_err_deferred(a);
      if (i % 4 == 0) map.remove_hit_deferred({40, 40});
    } else {
      map.add_err(a);
      map.add_hit(b);
      if (i % 3 == 0) map.remove_err(a);
      if (i % 4 == 0) map.remove_hit({40, 40});
    }
  };
  for (int i = 0; i < 200; ++i) {
    write(now, false, i);
    write(later, true, i);
  }
  EXPECT_EQ(later.score({40, 40}), 1.0f);  // not refreshed yet: the hit there was removed
  EXPECT_EQ(later.hit({40, 40}), 0u);
  EXPECT_EQ(now.score({40, 40}), kUnknownScore);
  EXPECT_EQ(now.commit_update(), later.commit_update());
  ASSERT_EQ(now.tile_keys(), later.tile_keys());
  for (int level = 0; level <= 2; ++level) {
    const GridMap::Lookup a = now.lookup(level), b = later.lookup(level);
    for (int y = -20; y < 50; ++y) {
      for (int x = -20; x < 50; ++x) {
        ASSERT_EQ(a.score(x, y), b.score(x, y)) << "level " << level << " cell " << x << "," << y;
      }
    }
  }
}

TEST(GridMapTest, ErrPathWritesAsDeferredWritesCellByCell) {
  // A seeded random walk over neighbouring cells, across tile borders in every direction and
  // out of the allowed tile range (|tile coordinate| <= 2): ErrPath on one map,
  // add_err_deferred / remove_err_deferred of each cell on the other. Same results, counters,
  // scores, tiles and touched tiles.
  const GridMapConfig config{
      .cell_size = 0.05, .tile_edge = 8, .max_tile_coord = 2, .pyramid_levels = 1};
  GridMap by_path(config), by_cell(config);
  std::uint64_t state = 12345;  // a fixed LCG: the walk is the same on every run
  const auto next = [&state] {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<std::uint32_t>(state >> 33);
  };
  CellIndex cell{3, -5};
  std::size_t refused = 0;
  for (int path = 0; path < 40; ++path) {
    const bool add = path % 4 != 3;
    GridMap::ErrPath<true> adds(by_path, cell);
    GridMap::ErrPath<false> removes(by_path, cell);
    for (int step = 0; step < 60; ++step) {
      const bool written = add ? adds.write() : removes.write();
      const bool expected =
          add ? by_cell.add_err_deferred(cell) : by_cell.remove_err_deferred(cell);
      ASSERT_EQ(written, expected) << "path " << path << " step " << step;
      refused += !written;
      const std::uint32_t r = next() % 4;
      const std::int32_t mx = r == 0 ? 1 : r == 1 ? -1 : 0, my = r == 2 ? 1 : r == 3 ? -1 : 0;
      adds.move(mx, my);
      removes.move(mx, my);
      cell.x += mx;
      cell.y += my;
    }
    ASSERT_EQ(by_path.commit_update(), by_cell.commit_update()) << "path " << path;
  }
  EXPECT_GT(refused, 0u);  // the walk left the allowed range
  ASSERT_EQ(by_path.tile_keys(), by_cell.tile_keys());
  EXPECT_GE(by_path.tile_count(), 9u);  // and crossed many tiles
  for (int y = -30; y < 30; ++y) {
    for (int x = -30; x < 30; ++x) {
      ASSERT_EQ(by_path.err({x, y}), by_cell.err({x, y})) << x << "," << y;
      ASSERT_EQ(by_path.score({x, y}), by_cell.score({x, y})) << x << "," << y;
    }
  }
}

TEST(GridMapTest, CountersSaturateInsteadOfWrapping) {
  GridMap map(GridMapConfig{.cell_size = 0.05, .tile_edge = 8});
  const std::size_t n = map.cells_per_tile();
  std::vector<std::uint32_t> hit(n, std::numeric_limits<std::uint32_t>::max()), err(n, 1);
  map.set_tile({0, 0}, 7, hit, err);
  map.add_hit({0, 0});
  EXPECT_EQ(map.hit({0, 0}), std::numeric_limits<std::uint32_t>::max());
  // err > 0 keeps the score strictly below 1 even though the ratio rounds to 1 in float.
  EXPECT_LT(map.score({0, 0}), 1.0f);
  EXPECT_EQ(map.find_tile({0, 0})->version, 7u);
}

TEST(GridMapTest, SetTileRejectsWrongSizesAndFarKeys) {
  GridMap map(GridMapConfig{.cell_size = 0.05, .tile_edge = 8, .max_tile_coord = 100});
  std::vector<std::uint32_t> ok(64, 0), bad(63, 0);
  EXPECT_THROW(map.set_tile({0, 0}, 1, bad, ok), std::invalid_argument);
  EXPECT_THROW(map.set_tile({101, 0}, 1, ok, ok), std::invalid_argument);
  EXPECT_EQ(map.tile_count(), 0u);
  EXPECT_FALSE(map.add_hit({8 * 101, 0}));
  EXPECT_EQ(map.tile_count(), 0u);
  EXPECT_NO_THROW(map.set_tile({-100, 100}, 1, ok, ok));
}

TEST(GridMapTest, TilesSpanAtMostMaxTileSpan) {
  // Two tiles at opposite corners of +-max_tile_coord made a directory of the whole range
  // (8.4 M slots at 1024); now the tiles' bounding box is bounded along each axis.
  GridMap map(GridMapConfig{
      .cell_size = 0.05, .tile_edge = 8, .max_tile_coord = 1024, .max_tile_span = 512});
  std::vector<std::uint32_t> ok(64, 0);
  ok[5] = 3;
  EXPECT_NO_THROW(map.set_tile({-1024, -1024}, 1, ok, ok));
  EXPECT_FALSE(map.key_in_range({1024, 1024}));
  EXPECT_THROW(map.set_tile({1024, 1024}, 1, ok, ok), std::invalid_argument);
  EXPECT_THROW(map.set_tile({-1024 + 512, -1024}, 1, ok, ok), std::invalid_argument);
  EXPECT_FALSE(map.add_hit({8 * (-1024 + 512), 8 * -1024}));
  // The far edge of the span is still allowed, in both axes, and every tile stays readable
  // through the directory.
  EXPECT_NO_THROW(map.set_tile({-1024 + 511, -1024 + 511}, 1, ok, ok));
  EXPECT_TRUE(map.add_hit({8 * (-1024 + 300), 8 * (-1024 + 200)}));
  EXPECT_EQ(map.tile_count(), 3u);
  EXPECT_EQ(map.hit({8 * -1024 + 5, 8 * -1024}), 3u);
  EXPECT_EQ(map.hit({8 * (-1024 + 511) + 5, 8 * (-1024 + 511)}), 3u);
  EXPECT_EQ(map.hit({8 * (-1024 + 300), 8 * (-1024 + 200)}), 1u);
  EXPECT_THROW(GridMap(GridMapConfig{.max_tile_span = 0}), std::invalid_argument);
}

TEST(GridMapTest, KnownBoundsCoverObservedCellsOnly) {
  GridMap map;
  EXPECT_TRUE(map.known_bounds().empty);
  map.add_hit({-5, 3});
  map.add_err({70, -2});
  const auto b = map.known_bounds();
  ASSERT_FALSE(b.empty);
  EXPECT_EQ(b.min, (CellIndex{-5, -2}));
  EXPECT_EQ(b.max, (CellIndex{70, 3}));
}

TEST(GridMapTest, ConfigValidationNamesField) {
  try {
    GridMap map(GridMapConfig{.cell_size = 0.05, .tile_edge = 48});
    FAIL() << "tile_edge 48 accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("tile_edge"), std::string::npos);
  }
  EXPECT_THROW(GridMap(GridMapConfig{.cell_size = -1.0}), std::invalid_argument);
}

}  // namespace
}  // namespace esfleet
