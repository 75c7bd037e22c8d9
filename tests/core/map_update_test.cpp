#include "esfleet/core/map_update.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <vector>

#include "esfleet/core/grid_traversal.hpp"
#include "esfleet/core/scan_points.hpp"
#include "esfleet/core/slam.hpp"
#include "esfleet/core/tile_codec.hpp"
#include "synthetic_world.hpp"

namespace esfleet {
namespace {

// Cells of 1 m make the expected counters easy to state by hand.
GridMap unit_map() { return GridMap(GridMapConfig{.cell_size = 1.0, .tile_edge = 8}); }

LaserScan scan_of(std::vector<float> ranges, float angle_min, float increment) {
  LaserScan s;
  s.angle_min = angle_min;
  s.angle_increment = increment;
  s.max_range = 81.9f;
  s.ranges = std::move(ranges);
  return s;
}

TEST(MapUpdateTest, StraightBeamErrsCrossedCellsAndHitsEndCell) {
  GridMap map = unit_map();
  const auto stats =
      update_map(map, prepare_scan(scan_of({3.0f}, 0.0f, 0.0f)), Pose2{0.5, 0.5, 0.0});
  EXPECT_EQ(stats.errs, 3u);
  EXPECT_EQ(stats.hits, 1u);
  for (int x = 0; x < 3; ++x) {
    EXPECT_EQ(map.err({x, 0}), 1u) << x;
    EXPECT_EQ(map.hit({x, 0}), 0u) << x;
  }
  EXPECT_EQ(map.hit({3, 0}), 1u);
  EXPECT_EQ(map.err({3, 0}), 0u);
  EXPECT_EQ(map.err({4, 0}), 0u);
  EXPECT_EQ(map.err({0, 1}), 0u);
}

TEST(MapUpdateTest, PoseRotationAndTranslationPlaceTheBeam) {
  GridMap map = unit_map();
  // Facing +y from (2.5, 2.5): a 2 m beam ends in cell (2, 4).
  update_map(map, prepare_scan(scan_of({2.0f}, 0.0f, 0.0f)), Pose2{2.5, 2.5, std::numbers::pi / 2});
  EXPECT_EQ(map.err({2, 2}), 1u);
  EXPECT_EQ(map.err({2, 3}), 1u);
  EXPECT_EQ(map.hit({2, 4}), 1u);
}

TEST(MapUpdateTest, DiagonalBeamVisitsEachCrossedCellOnce) {
  GridMap map = unit_map();
  // From (0.2, 0.6) to (3.2, 2.1): a grid walk from cell (0, 0) to cell (3, 2) crosses exactly
  // |3 - 0| + |2 - 0| = 5 cells before the end cell, each once.
  const double ang = std::atan2(1.5, 3.0);
  const float r = static_cast<float>(std::hypot(3.0, 1.5));
  const auto stats = update_map(map, prepare_scan(scan_of({r}, static_cast<float>(ang), 0.0f)),
                                Pose2{0.2, 0.6, 0.0});
  EXPECT_EQ(stats.hits, 1u);
  EXPECT_EQ(map.hit({3, 2}), 1u);
  EXPECT_EQ(stats.errs, 3u + 2u);  // |3-0| + |2-0| cells before the end cell
  std::uint32_t total_err = 0;
  for (int y = -1; y < 4; ++y)
    for (int x = -1; x < 5; ++x) total_err += map.err({x, y});
  EXPECT_EQ(total_err, 5u);
  EXPECT_EQ(map.err({0, 0}), 1u);
}

/// True when the closed unit square of cell c and the segment a-b share a point, to within
/// `slack` (cell units): the segment clipped to the square's slab in x overlaps its slab in y.
bool segment_touches_cell(double ax, double ay, double bx, double by, CellIndex c, double slack) {
  double t0 = 0.0, t1 = 1.0;
  const auto clip = [&](double a, double d, double lo, double hi) {
    if (d == 0.0) return a >= lo && a <= hi;
    double u = (lo - a) / d, v = (hi - a) / d;
    if (u > v) std::swap(u, v);
    t0 = std::max(t0, u);
    t1 = std::min(t1, v);
    return t0 <= t1;
  };
  return clip(ax, bx - ax, c.x - slack, c.x + 1 + slack) &&
         clip(ay, by - ay, c.y - slack, c.y + 1 + slack);
}

TEST(MapUpdateTest, TraversalIsAFourConnectedPathOfCellsTheBeamCrosses) {
  // Seeded random segments in every direction, many crossing tile borders: traverse() visits
  // |dx| + |dy| cells from the start cell, each a 4-neighbour of the one before and of the end
  // cell after the last, each one the segment passes through.
  std::uint64_t state = 99;
  const auto uniform = [&state](double lo, double hi) {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return lo + (hi - lo) * static_cast<double>(state >> 11) * 0x1p-53;
  };
  for (int k = 0; k < 2000; ++k) {
    const double ax = uniform(-40, 40), ay = uniform(-40, 40);
    const double bx = ax + uniform(-30, 30), by = ay + uniform(-30, 30);
    const CellIndex start{static_cast<std::int32_t>(std::floor(ax)),
                          static_cast<std::int32_t>(std::floor(ay))};
    const CellIndex end{static_cast<std::int32_t>(std::floor(bx)),
                        static_cast<std::int32_t>(std::floor(by))};
    std::vector<CellIndex> cells;
    traverse(ax, ay, bx, by, [&](CellIndex c) { cells.push_back(c); });
    ASSERT_EQ(cells.size(),
              static_cast<std::size_t>(std::abs(end.x - start.x) + std::abs(end.y - start.y)))
        << "segment " << k;
    if (cells.empty()) continue;
    ASSERT_EQ(cells.front(), start) << "segment " << k;
    cells.push_back(end);
    for (std::size_t i = 0; i + 1 < cells.size(); ++i) {
      ASSERT_EQ(std::abs(cells[i + 1].x - cells[i].x) + std::abs(cells[i + 1].y - cells[i].y), 1)
          << "segment " << k << " cell " << i;
      ASSERT_TRUE(segment_touches_cell(ax, ay, bx, by, cells[i], 1e-9))
          << "segment " << k << " cell " << i;
    }
  }
}

TEST(MapUpdateTest, BeamsAcrossTilesCountAsTheTraversalsCells) {
  // A scan of long beams in every direction on 8-cell tiles, inserted and partly removed again:
  // update_map's counters are those of writing each cell traverse() visits, one at a time.
  const GridMapConfig config{.cell_size = 0.05, .tile_edge = 8};
  const MapUpdateConfig update;  // free margin 0.15 m, exact traversal
  GridMap map(config), reference(config);
  std::vector<float> ranges;
  for (int i = 0; i < 720; ++i) ranges.push_back(1.0f + 0.37f * static_cast<float>(i % 11));
  const ScanPoints points = prepare_scan(scan_of(ranges, -3.1f, 0.0086f));
  const Pose2 first{0.123, -0.456, 0.3}, second{-0.61, 0.27, -1.2};
  const auto write_reference = [&](const Pose2& pose, bool remove) {
    // The end points in cell units computed as update_map does (times the inverse cell size),
    // so that a point on a cell border lands in the same cell on both maps.
    const double inv = 1.0 / config.cell_size;
    const double c = std::cos(pose.theta), s = std::sin(pose.theta);
    const double sx = pose.x * inv, sy = pose.y * inv;
    for (std::size_t i = 0; i < points.size(); ++i) {
      const double ex = sx + (c * points.x[i] - s * points.y[i]) * inv;
      const double ey = sy + (s * points.x[i] + c * points.y[i]) * inv;
      const double f = (points.range[i] - update.free_margin) / points.range[i];
      const double stop_x = sx + f * (ex - sx), stop_y = sy + f * (ey - sy);
      const CellIndex end{static_cast<std::int32_t>(std::floor(ex)),
                          static_cast<std::int32_t>(std::floor(ey))};
      const CellIndex stop{static_cast<std::int32_t>(std::floor(stop_x)),
                           static_cast<std::int32_t>(std::floor(stop_y))};
      const auto err = [&](CellIndex cell) {
        remove ? reference.remove_err(cell) : reference.add_err(cell);
      };
      traverse(sx, sy, stop_x, stop_y, err);
      if (stop != end) err(stop);
      remove ? reference.remove_hit(end) : reference.add_hit(end);
    }
    reference.commit_update();
  };
  const MapUpdateStats a = update_map(map, points, first, update);
  const MapUpdateStats b = update_map(map, points, second, update);
  update_map(map, points, first, update, /*remove=*/true);
  write_reference(first, false);
  write_reference(second, false);
  write_reference(first, true);
  EXPECT_GT(a.errs, 20000u);
  EXPECT_GT(b.errs, 20000u);
  EXPECT_EQ(a.out_of_range + b.out_of_range, 0u);
  ASSERT_EQ(map.tile_keys(), reference.tile_keys());
  EXPECT_GT(map.tile_count(), 100u);
  for (int y = -120; y < 120; ++y) {
    for (int x = -120; x < 120; ++x) {
      ASSERT_EQ(map.err({x, y}), reference.err({x, y})) << x << "," << y;
      ASSERT_EQ(map.hit({x, y}), reference.hit({x, y})) << x << "," << y;
      ASSERT_EQ(map.score({x, y}), reference.score({x, y})) << x << "," << y;
    }
  }
}

TEST(MapUpdateTest, BeamsSharingCellsAddOncePerBeam) {
  GridMap map = unit_map();
  // Two beams at +-1 degree along x: both cross cells (0..3, 0) and end in (4, 0).
  const float d = static_cast<float>(1.0 * std::numbers::pi / 180.0);
  update_map(map, prepare_scan(scan_of({4.0f, 4.0f}, -d, 2 * d)), Pose2{0.5, 0.5, 0.0});
  EXPECT_EQ(map.err({0, 0}), 2u);
  EXPECT_EQ(map.err({3, 0}), 2u);
  EXPECT_EQ(map.hit({4, 0}), 2u);
  EXPECT_FLOAT_EQ(map.value({4, 0}), 1.0f);
  EXPECT_FLOAT_EQ(map.value({2, 0}), 0.0f);
}

TEST(MapUpdateTest, NoReturnBeamsAddNoHitAndClearOnlyWhenAsked) {
  GridMap map = unit_map();
  const LaserScan s = scan_of({81.91f}, 0.0f, 0.0f);
  const ScanPoints pts = prepare_scan(s);
  ASSERT_EQ(pts.size(), 0u);
  ASSERT_EQ(pts.no_return_angles.size(), 1u);
  auto stats = update_map(map, pts, Pose2{0.5, 0.5, 0.0});
  EXPECT_EQ(stats.hits + stats.errs, 0u);
  EXPECT_EQ(map.tile_count(), 0u);
  MapUpdateConfig clear;
  clear.no_return_clear_range = 2.0;
  stats = update_map(map, pts, Pose2{0.5, 0.5, 0.0}, clear);
  EXPECT_EQ(stats.hits, 0u);
  EXPECT_EQ(map.err({0, 0}), 1u);
  EXPECT_EQ(map.err({1, 0}), 1u);
  EXPECT_EQ(map.err({2, 0}), 0u);  // end of the clearing ray is not itself cleared
}

TEST(MapUpdateTest, PaperSamplingCountsEachSampledCellOnce) {
  GridMap map = unit_map();
  MapUpdateConfig paper;
  paper.exact_traversal = false;
  paper.alpha_res = 4.0;  // 4 samples per metre: 12 samples on a 3 m beam
  const auto stats =
      update_map(map, prepare_scan(scan_of({3.0f}, 0.0f, 0.0f)), Pose2{0.5, 0.5, 0.0}, paper);
  EXPECT_EQ(stats.hits, 1u);
  EXPECT_EQ(stats.errs, 3u);
  EXPECT_EQ(map.err({0, 0}), 1u);
  EXPECT_EQ(map.err({2, 0}), 1u);
  EXPECT_EQ(map.hit({3, 0}), 1u);
}

TEST(MapUpdateTest, FreeMarginLeavesTheCellsJustBeforeTheEndPoint) {
  // A 3 m beam along +x from (0.5, 0.5) ends in cell 3; with a 1.6 m margin the clearing stops
  // at x = 1.9 (cell 1, still cleared), so cell 2 keeps no err. Both traversals agree.
  MapUpdateConfig exact;
  exact.free_margin = 1.6;
  MapUpdateConfig sampled = exact;
  sampled.exact_traversal = false;
  sampled.alpha_res = 4.0;
  for (const MapUpdateConfig& config : {exact, sampled}) {
    GridMap map = unit_map();
    const ScanPoints beam = prepare_scan(scan_of({3.0f}, 0.0f, 0.0f));
    const auto stats = update_map(map, beam, Pose2{0.5, 0.5, 0.0}, config);
    EXPECT_EQ(stats.errs, 2u);
    EXPECT_EQ(map.err({0, 0}), 1u);
    EXPECT_EQ(map.err({1, 0}), 1u);
    EXPECT_EQ(map.err({2, 0}), 0u);
    EXPECT_EQ(map.hit({2, 0}), 0u);
    EXPECT_EQ(map.hit({3, 0}), 1u);
    // Removing the same scan undoes exactly what it added (loop closure moves scans this way).
    update_map(map, beam, Pose2{0.5, 0.5, 0.0}, config, /*remove=*/true);
    for (int x = 0; x < 4; ++x) {
      EXPECT_EQ(map.err({x, 0}), 0u) << x;
      EXPECT_EQ(map.hit({x, 0}), 0u) << x;
    }
  }
  // A beam shorter than the margin clears nothing and still hits.
  GridMap map = unit_map();
  const auto stats =
      update_map(map, prepare_scan(scan_of({1.0f}, 0.0f, 0.0f)), Pose2{0.5, 0.5, 0.0}, exact);
  EXPECT_EQ(stats.errs, 0u);
  EXPECT_EQ(map.hit({1, 0}), 1u);
  // The paper clears every crossed cell; a negative or NaN margin is refused.
  EXPECT_EQ(SlamConfig::paper().update.free_margin, 0.0);
  EXPECT_GT(SlamConfig{}.update.free_margin, 0.0);
  MapUpdateConfig bad;
  bad.free_margin = -0.1;
  EXPECT_THROW(bad.validate(), std::invalid_argument);
  bad.free_margin = std::nan("");
  EXPECT_THROW(bad.validate(), std::invalid_argument);
}

TEST(MapUpdateTest, ACoarseLaserIsWrittenWithItsWallsFilledIn) {
  // A 1 deg laser 8 m from a wall (the column of 5 cm cells at x = 8.0-8.05, hit in the
  // middle): its beams hit the wall 14 cm apart, so written as they are they leave two of
  // every three of the wall's cells unseen; filled down to 0.5 deg, one in three.
  const double deg = std::numbers::pi / 180.0;
  std::vector<float> ranges;
  for (int i = -10; i <= 10; ++i) ranges.push_back(static_cast<float>(8.025 / std::cos(i * deg)));
  const LaserScan s = scan_of(ranges, static_cast<float>(-10 * deg), static_cast<float>(deg));
  MapUpdateConfig config;
  EXPECT_EQ(config.beam_fill_deg, 0.5);  // the default
  auto wall_cells_hit = [&](const ScanPoints& points) {
    GridMap map(GridMapConfig{.cell_size = 0.05, .tile_edge = 64});
    update_map(map, points, Pose2{0.0, 0.0, 0.0}, config);
    int hit = 0;
    for (int y = -40; y < 40; ++y) hit += map.hit({160, y}) > 0;
    return hit;
  };
  const MapPoints written = map_points(s, 0.0f, 0.0f, config);
  ASSERT_TRUE(written.filled);
  EXPECT_EQ(written.points.size(), 41u);
  const int own = wall_cells_hit(prepare_scan(s));
  const int filled = wall_cells_hit(written.points);
  EXPECT_EQ(own, 21);
  EXPECT_EQ(filled, 41);  // every 7 cm
  // Removing the filled scan undoes it exactly (loop closure moves key scans this way).
  GridMap map(GridMapConfig{.cell_size = 0.05, .tile_edge = 64});
  update_map(map, written.points, Pose2{0.0, 0.0, 0.0}, config);
  update_map(map, written.points, Pose2{0.0, 0.0, 0.0}, config, /*remove=*/true);
  for (int y = -30; y <= 30; ++y) EXPECT_EQ(map.hit({160, y}), 0u) << y;
  // A 0.5 deg laser, the fill off (the paper) or a coarser threshold: written as it is.
  const LaserScan fine = scan_of(ranges, 0.0f, static_cast<float>(0.5 * deg));
  EXPECT_FALSE(map_points(fine, 0.0f, 0.0f, config).filled);
  EXPECT_EQ(SlamConfig::paper().update.beam_fill_deg, 0.0);
  EXPECT_FALSE(map_points(s, 0.0f, 0.0f, SlamConfig::paper().update).filled);
  MapUpdateConfig coarse = config;
  coarse.beam_fill_deg = 1.0;
  EXPECT_FALSE(map_points(s, 0.0f, 0.0f, coarse).filled);
  // The tracking's range limits apply to the filled points too: the 9 beams within 4.5 deg of
  // the wall's normal are under 8.05 m, and the 8 points between them.
  EXPECT_EQ(map_points(s, 0.0f, 8.05f, config).points.size(), 17u);
  MapUpdateConfig bad = config;
  bad.beam_fill_deg = -0.5;
  EXPECT_THROW(bad.validate(), std::invalid_argument);
  bad = config;
  bad.beam_fill_max_gap = std::nan("");
  EXPECT_THROW(bad.validate(), std::invalid_argument);
  bad = config;
  bad.beam_fill_min_step = -0.1;
  EXPECT_THROW(bad.validate(), std::invalid_argument);
  bad = config;
  bad.beam_fill_min_turn_deg = std::numeric_limits<double>::infinity();
  EXPECT_THROW(bad.validate(), std::invalid_argument);
}

/// Every tile's counters, scores and coarse levels equal in a and b (the same tiles).
void expect_same_tiles(const GridMap& a, const GridMap& b) {
  ASSERT_EQ(a.tile_keys(), b.tile_keys());
  for (const TileKey& k : a.tile_keys()) {
    const Tile& ta = *a.find_tile(k);
    const Tile& tb = *b.find_tile(k);
    EXPECT_EQ(ta.hit, tb.hit) << "tile " << k.tx << " " << k.ty;
    EXPECT_EQ(ta.err, tb.err) << "tile " << k.tx << " " << k.ty;
    EXPECT_EQ(ta.score, tb.score) << "tile " << k.tx << " " << k.ty;
    EXPECT_EQ(ta.coarse, tb.coarse) << "tile " << k.tx << " " << k.ty;
  }
}

TEST(MapUpdateTest, EveryScanWrittenIntoAClearedMapEqualsMovingTheMovedOnes) {
  // What Slam::apply_graph relies on when most key scans moved: clearing the counters and
  // writing every scan at its pose gives the map that taking out and writing again the moved
  // ones gives, tile for tile (the tiles only the old poses reached stay, all unknown).
  const auto world = testing::asymmetric_room();
  GridMapConfig config;
  config.pyramid_levels = 2;
  std::vector<ScanPoints> points;
  std::vector<Pose2> was, now;
  for (int i = 0; i < 12; ++i) {
    const Pose2 p{1.5 + 0.8 * i, 2.0 + 0.3 * (i % 4), 0.4 * i};
    points.push_back(prepare_scan(testing::make_scan(world, p)));
    was.push_back(p);
    // Two of three moved, as after a loop closure: a few centimetres and a degree or two.
    now.push_back(i % 3 == 0 ? p : Pose2{p.x + 0.07, p.y - 0.04 * i, p.theta + 0.03});
  }
  GridMap in_place(config), rewritten(config);
  for (GridMap* m : {&in_place, &rewritten}) {
    for (std::size_t i = 0; i < points.size(); ++i) {
      update_map(*m, points[i], was[i], MapUpdateConfig{}, false, false);
    }
    m->commit_update();
  }
  const std::string before = map_digest(in_place);
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (now[i] == was[i]) continue;
    update_map(in_place, points[i], was[i], MapUpdateConfig{}, /*remove=*/true, false);
    update_map(in_place, points[i], now[i], MapUpdateConfig{}, false, false);
  }
  in_place.commit_update();
  rewritten.clear_counters();
  for (std::size_t i = 0; i < points.size(); ++i) {
    update_map(rewritten, points[i], now[i], MapUpdateConfig{}, false, false);
  }
  const std::size_t committed = rewritten.commit_update();
  EXPECT_NE(map_digest(in_place), before);  // the moves changed the map
  EXPECT_EQ(map_digest(rewritten), map_digest(in_place));
  expect_same_tiles(rewritten, in_place);
  // Every tile was part of the update: all of them go out again with a new version.
  EXPECT_EQ(committed, rewritten.tile_count());
  for (const TileKey& k : rewritten.tile_keys()) EXPECT_EQ(rewritten.find_tile(k)->version, 2u);
}

TEST(MapUpdateTest, CommitBumpsVersionOfTouchedTiles) {
  GridMap map = unit_map();
  update_map(map, prepare_scan(scan_of({10.0f}, 0.0f, 0.0f)), Pose2{0.5, 0.5, 0.0});
  // Beam covers cells 0..10 in x: tiles 0 and 1 (edge 8).
  EXPECT_EQ(map.tile_count(), 2u);
  EXPECT_EQ(map.find_tile({0, 0})->version, 1u);
  EXPECT_EQ(map.find_tile({1, 0})->version, 1u);
  EXPECT_EQ(map.take_dirty().size(), 2u);
}

TEST(MapUpdateTest, AScanDeclaringAHugeMaximumWalksAtMostAKilometrePerBeam) {
  // A reading of 10 000 km under a declared max_range of 3.4e38 m used to be an end point: its
  // beam walked 2e8 cells (all outside the allowed tiles) in one map update. It is a no-return
  // now, and the scan's other beams are written as before.
  GridMap map = unit_map();
  LaserScan s = scan_of({1e7f, 3.0f, 3e38f}, 0.0f, 0.5f);
  s.max_range = 3.4e38f;
  const ScanPoints points = prepare_scan(s);
  ASSERT_EQ(points.size(), 1u);
  const MapUpdateStats stats = update_map(map, points, Pose2{0.5, 0.5, 0.0});
  GridMap alone = unit_map();  // the 3 m beam by itself
  const MapUpdateStats expected =
      update_map(alone, prepare_scan(scan_of({3.0f}, 0.5f, 0.0f)), Pose2{0.5, 0.5, 0.0});
  EXPECT_EQ(stats.errs, expected.errs);
  EXPECT_EQ(stats.out_of_range, 0u);
  EXPECT_EQ(stats.hits, 1u);
  EXPECT_EQ(map.tile_keys(), alone.tile_keys());
  MapUpdateConfig far;
  far.write_range = 1000.0;
  far.no_return_clear_range = 1000.5;
  EXPECT_THROW(far.validate(), std::invalid_argument);
  far.no_return_clear_range = 1000.0;
  EXPECT_NO_THROW(far.validate());
}

TEST(MapUpdateTest, EndPointsBeyondTheWriteRangeClearUpToItAndHitNothing) {
  MapUpdateConfig config;
  config.write_range = 5.0;
  GridMap map = unit_map();
  // Along +x from (0.5, 0.5): an 8 m beam is cut at 5 m (x = 5.5), a 4 m one is written.
  const ScanPoints far = prepare_scan(scan_of({8.0f}, 0.0f, 0.0f));
  MapUpdateStats stats = update_map(map, far, Pose2{0.5, 0.5, 0.0}, config);
  EXPECT_EQ(stats.hits, 0u);
  EXPECT_EQ(stats.errs, 5u);
  for (int x = 0; x < 5; ++x) EXPECT_EQ(map.err({x, 0}), 1u) << x;
  for (int x = 5; x <= 8; ++x) EXPECT_EQ(map.err({x, 0}) + map.hit({x, 0}), 0u) << x;
  stats = update_map(map, prepare_scan(scan_of({4.0f}, 0.0f, 0.0f)), Pose2{0.5, 0.5, 0.0}, config);
  EXPECT_EQ(stats.hits, 1u);
  EXPECT_EQ(map.hit({4, 0}), 1u);
  // Exactly at the range is written; the paper's sampling cuts the same way.
  config.exact_traversal = false;
  stats = update_map(map, prepare_scan(scan_of({5.0f}, 0.0f, 0.0f)), Pose2{0.5, 0.5, 0.0}, config);
  EXPECT_EQ(stats.hits, 1u);
  EXPECT_EQ(map.hit({5, 0}), 1u);
  stats = update_map(map, far, Pose2{0.5, 0.5, 0.0}, config);
  EXPECT_EQ(stats.hits, 0u);
  EXPECT_EQ(stats.errs, 5u);
  // Taking the cut beam out again leaves the counters as they were before it.
  update_map(map, far, Pose2{0.5, 0.5, 0.0}, config, /*remove=*/true);
  update_map(map, far, Pose2{0.5, 0.5, 0.0}, config, /*remove=*/true);
  for (int x = 0; x < 4; ++x) EXPECT_EQ(map.err({x, 0}), 2u) << x;  // the 4 m and 5 m beams
  EXPECT_EQ(map.err({4, 0}), 1u);

  for (const double bad : {0.0, -1.0, 1000.5, std::numeric_limits<double>::quiet_NaN()}) {
    MapUpdateConfig c;
    c.write_range = bad;
    EXPECT_THROW(c.validate(), std::invalid_argument) << bad;
  }
  MapUpdateConfig clear;
  clear.no_return_clear_range = 80.5;  // beyond the default write range
  try {
    clear.validate();
    ADD_FAILURE() << "no_return_clear_range beyond write_range accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("update.no_return_clear_range"), std::string::npos)
        << e.what();
  }
}

TEST(MapUpdateTest, APoseBeyondAnyMapWritesNothing) {
  // A pose of 1e300 m (a wild odometry message the converters let through as finite) is 2e301
  // cells of 5 cm: its int32 cell index overflowed (undefined behaviour; fuzz_slam finding 5).
  // No map reaches so far, so nothing is written, not even a refused write.
  const ScanPoints points = prepare_scan(scan_of({3.0f, 90.0f}, 0.0f, 0.5f));
  for (const Pose2 pose : {Pose2{1e300, 0.0, 0.0}, Pose2{0.0, -1.7e308, 0.0}, Pose2{6e6, 0.0, 0.0},
                           Pose2{0.0, 0.0, std::nan("")}}) {
    GridMap map;
    const MapUpdateStats stats = update_map(map, points, pose);
    EXPECT_EQ(stats.hits + stats.errs + stats.out_of_range, 0u) << pose.x << " " << pose.y;
    EXPECT_EQ(map.tile_count(), 0u);
  }
  // 5 000 km (1e8 cells of 5 cm) is beyond any map; 4 000 km is merely outside this one.
  EXPECT_TRUE(beyond_any_map(1e8, 0.0));
  EXPECT_TRUE(beyond_any_map(0.0, std::numeric_limits<double>::infinity()));
  EXPECT_FALSE(beyond_any_map(-8e7, 8e7));
  GridMap map;
  const MapUpdateStats outside = update_map(map, points, Pose2{4e6, 0.0, 0.0});
  EXPECT_GT(outside.out_of_range, 0u);
  EXPECT_EQ(map.tile_count(), 0u);
  GridMapConfig fine;
  fine.cell_size = 0.0005;  // below a millimetre: a kilometre beam could overflow int32 cells
  EXPECT_THROW(fine.validate(), std::invalid_argument);
  fine.cell_size = 0.001;
  EXPECT_NO_THROW(fine.validate());
}

TEST(MapUpdateTest, AScanOfKilometreReadingsWritesOnlyWithinTheWriteRange) {
  // 5 cm cells and 64-cell tiles (3.2 m), the defaults. Ten beams over 360 degrees, every one
  // reading 999 m under a declared 1000 m maximum: each walked 20 000 cells and the scan
  // created a thousand tiles out to a kilometre. With the default 80 m write range each beam
  // walks at most 80 m (a 4-connected path of at most sqrt(2) * 1 600 cells) and hits nothing,
  // and every tile lies within 80 m of the robot.
  GridMap map;
  const MapUpdateConfig config;
  LaserScan s = scan_of(std::vector<float>(10, 999.0f), -3.0f, 0.6f);
  s.max_range = 1000.0f;
  const ScanPoints points = prepare_scan(s);
  ASSERT_EQ(points.size(), 10u);
  const Pose2 pose{3.0, -2.0, 0.4};
  const MapUpdateStats stats = update_map(map, points, pose, config);
  EXPECT_EQ(stats.hits, 0u);
  EXPECT_EQ(stats.out_of_range, 0u);
  EXPECT_GT(stats.errs, 10u * 1600u);
  EXPECT_LE(stats.errs, 10u * 2264u);
  const double tile = map.cell_size() * map.tile_edge();
  for (const TileKey k : map.tile_keys()) {
    // The tile's nearest point to the robot is within the range.
    const double nx = std::clamp(pose.x, k.tx * tile, (k.tx + 1) * tile);
    const double ny = std::clamp(pose.y, k.ty * tile, (k.ty + 1) * tile);
    EXPECT_LE(std::hypot(nx - pose.x, ny - pose.y), config.write_range) << k.tx << " " << k.ty;
  }
  EXPECT_LE(map.tile_count(), 10u * 40u);
}

TEST(MapUpdateTest, PrepareScanDropsShortAndOverLimitBeams) {
  const LaserScan s = scan_of({0.05f, 1.0f, 30.0f, 81.95f}, 0.0f, 0.1f);
  const ScanPoints all = prepare_scan(s);
  EXPECT_EQ(all.size(), 3u);
  EXPECT_EQ(all.no_return_angles.size(), 1u);
  const ScanPoints limited = prepare_scan(s, 0.1f, 20.0f);
  ASSERT_EQ(limited.size(), 1u);
  EXPECT_FLOAT_EQ(limited.range[0], 1.0f);
  EXPECT_NEAR(limited.x[0], std::cos(0.1f), 1e-6);
}

}  // namespace
}  // namespace esfleet
