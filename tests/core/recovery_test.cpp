// The recovery search (recovery.hpp) on scans ray-cast in a synthetic room: it must find a pose
// far outside the tracking's reach, judge poses by their consistency with the map (a pose that
// looks through walls scores low), and the SLAM must keep a scan it cannot place out of the map.

#include "esfleet/core/recovery.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "esfleet/core/slam.hpp"
#include "synthetic_world.hpp"

namespace esfleet {
namespace {

using testing::asymmetric_room;
using testing::make_scan;
using testing::map_of;

TEST(Recovery, FindsAPoseFarOutsideTheTrackingReach) {
  const auto world = asymmetric_room();
  const GridMap map = map_of(world, 12, 8);
  const Pose2 truth{6.0, 3.2, deg_to_rad(20.0)};
  const ScanPoints points = prepare_scan(make_scan(world, truth));
  // The prediction is 1.1 m and 50 degrees off; the window (+-1.5 m, +-90 degrees) covers it.
  const Pose2 predicted{truth.x - 0.8, truth.y + 0.75, truth.theta - deg_to_rad(50.0)};
  RecoveryConfig config;
  TrackingConfig tracking;
  const EvolutionStrategy es(tracking.es);
  Rng rng(7);
  const RecoveryResult r = recover_pose(config, tracking, es, rng, map, points, predicted);
  EXPECT_GT(r.coarse_poses, 1000);
  ASSERT_FALSE(r.coarse.empty());
  EXPECT_NEAR(r.result.pose.x, truth.x, 0.05) << "seed 7";
  EXPECT_NEAR(r.result.pose.y, truth.y, 0.05) << "seed 7";
  EXPECT_NEAR(rad_to_deg(normalize_angle(r.result.pose.theta - truth.theta)), 0.0, 1.0) << "seed 7";
  EXPECT_GT(r.result.value.agreement(), 0.9f);
}

TEST(Recovery, OutsideTheWindowItFindsNothingBetter) {
  const auto world = asymmetric_room();
  const GridMap map = map_of(world, 12, 8);
  const Pose2 truth{6.0, 3.2, deg_to_rad(20.0)};
  const ScanPoints points = prepare_scan(make_scan(world, truth));
  const Pose2 predicted{truth.x - 3.0, truth.y + 0.5, truth.theta};
  RecoveryConfig config;
  config.window_xy = 0.5;
  TrackingConfig tracking;
  const EvolutionStrategy es(tracking.es);
  Rng rng(7);
  const RecoveryResult r = recover_pose(config, tracking, es, rng, map, points, predicted);
  EXPECT_GT(std::hypot(r.result.pose.x - truth.x, r.result.pose.y - truth.y), 1.0);
  EXPECT_LT(consistency(map, points, r.result.pose, config.tolerance).score(),
            consistency(map, points, truth, config.tolerance).score() - 0.2f);
}

// The first `candidates` coarse poses are refined; only when none of them fits the map are the
// next ones up to `more_candidates`.
TEST(Recovery, MoreCandidatesAreRefinedOnlyWhenNoneFits) {
  const auto world = asymmetric_room();
  const GridMap map = map_of(world, 12, 8);
  const Pose2 truth{6.0, 3.2, deg_to_rad(20.0)};
  const ScanPoints points = prepare_scan(make_scan(world, truth));
  TrackingConfig tracking;
  const EvolutionStrategy es(tracking.es);
  RecoveryConfig config;  // candidates 8, more_candidates 64
  // The truth in the window: the first candidates hold it.
  Rng rng(7);
  RecoveryResult r = recover_pose(config, tracking, es, rng, map, points,
                                  {truth.x - 0.8, truth.y + 0.75, truth.theta});
  EXPECT_EQ(r.coarse.size(), 8u);
  EXPECT_LT(std::hypot(r.result.pose.x - truth.x, r.result.pose.y - truth.y), 0.05);
  // Far outside it: nothing fits, and up to more_candidates are refined (every distinct coarse
  // pose with a positive score), none of them taken.
  config.window_xy = 0.5;
  const Pose2 far{truth.x - 3.0, truth.y + 0.5, truth.theta};
  rng = Rng(7);
  r = recover_pose(config, tracking, es, rng, map, points, far);
  EXPECT_LT(consistency(map, points, r.result.pose, config.tolerance).score(), config.more_below);
  EXPECT_GT(r.coarse.size(), 8u);
  EXPECT_LE(r.coarse.size(), static_cast<std::size_t>(config.more_candidates));
  const Pose2 with_more = r.result.pose;
  config.more_below = -2.0;  // never
  rng = Rng(7);
  r = recover_pose(config, tracking, es, rng, map, points, far);
  EXPECT_EQ(r.coarse.size(), 8u);
  // None of the extra ones fitted: the ES finished from the same start, to the same pose.
  EXPECT_EQ(r.result.pose.x, with_more.x);
  EXPECT_EQ(r.result.pose.y, with_more.y);
  EXPECT_EQ(r.result.pose.theta, with_more.theta);
}

TEST(Recovery, ConsistencySeesBeamsThroughWalls) {
  const auto world = asymmetric_room();
  const GridMap map = map_of(world, 12, 8);
  const Pose2 truth{6.0, 3.2, deg_to_rad(20.0)};
  const ScanPoints points = prepare_scan(make_scan(world, truth));
  for (const int tolerance : {0, 1}) {
    SCOPED_TRACE("tolerance " + std::to_string(tolerance));
    const Consistency at_truth = consistency(map, points, truth, tolerance);
    EXPECT_GT(at_truth.evidence, 0.9f);
    EXPECT_LT(at_truth.see_through, 0.02f);
    EXPECT_LT(at_truth.contradiction, 0.05f);
    // Turned by 90 degrees the beams run through the room's walls.
    const Pose2 turned{truth.x, truth.y, truth.theta + deg_to_rad(90.0)};
    const Consistency wrong = consistency(map, points, turned, tolerance);
    EXPECT_GT(wrong.see_through, 0.2f);
    EXPECT_LT(wrong.score(), at_truth.score() - 0.5f);
    // Nothing known: zero evidence, nothing contradicts.
    const Consistency empty = consistency(GridMap{}, points, truth, tolerance);
    EXPECT_EQ(empty.evidence, 0.0f);
    EXPECT_EQ(empty.see_through, 0.0f);
  }
}

/// consistency() without its clip to the tiles: every sample of every beam looked up with
/// GridMap::score (the reference for the test below).
Consistency consistency_walking_everything(const GridMap& map, const ScanPoints& points,
                                           const Pose2& pose, int tolerance) {
  const double inv = 1.0 / map.cell_size();
  const double c = std::cos(pose.theta), s = std::sin(pose.theta);
  const double ox = pose.x * inv, oy = pose.y * inv;
  auto at = [&](double x, double y) {
    return map.score(
        {static_cast<std::int32_t>(std::floor(x)), static_cast<std::int32_t>(std::floor(y))});
  };
  int hit = 0, free = 0, through = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const double ex = points.x[i] * inv, ey = points.y[i] * inv;
    const double wx = ox + c * ex - s * ey, wy = oy + s * ex + c * ey;
    const float v = at(wx, wy);
    bool near = false;
    for (int dy = -tolerance; dy <= tolerance; ++dy) {
      for (int dx = -tolerance; dx <= tolerance; ++dx) near |= at(wx + dx, wy + dy) > 0.0f;
    }
    const bool on_hit = v > 0.0f || near;
    hit += on_hit;
    free += !on_hit && v == 0.0f;
    const double len = std::hypot(ex, ey);
    const int steps = static_cast<int>(len - 3.0);
    for (int k = 1; k < steps; ++k) {
      if (at(ox + (wx - ox) / len * k, oy + (wy - oy) / len * k) > 0.5f) {
        ++through;
        break;
      }
    }
  }
  const auto n = static_cast<float>(points.size());
  return {static_cast<float>(hit) / n, static_cast<float>(free) / n,
          static_cast<float>(through) / n};
}

TEST(Recovery, ConsistencyWalksOnlyWhereTheTilesAreWithTheSameResult) {
  // Beams of up to 200 m from poses inside the room's tiles, beside them and 60 m away (whose
  // beams enter the tiles from outside, or never): the clipped walk sees every wall the full
  // walk sees.
  const auto world = asymmetric_room();
  const GridMap map = map_of(world, 12, 8);
  std::mt19937 gen(5);
  std::uniform_real_distribution<double> place(-60.0, 70.0), turn(-3.2, 3.2);
  std::uniform_real_distribution<float> reach(0.1f, 200.0f);
  LaserScan scan;
  scan.angle_min = -3.1f;
  scan.angle_increment = 0.05f;
  scan.max_range = 1000.0f;
  scan.ranges.resize(124);
  int looked_through = 0;
  for (int trial = 0; trial < 60; ++trial) {
    for (float& r : scan.ranges) r = reach(gen);
    const ScanPoints points = prepare_scan(scan);
    const Pose2 pose = trial < 20 ? Pose2{6.0 + trial * 0.1, 3.2, turn(gen)}
                                  : Pose2{place(gen), place(gen), turn(gen)};
    for (const int tolerance : {0, 1}) {
      const Consistency got = consistency(map, points, pose, tolerance);
      const Consistency want = consistency_walking_everything(map, points, pose, tolerance);
      EXPECT_EQ(got.evidence, want.evidence) << "trial " << trial;
      EXPECT_EQ(got.contradiction, want.contradiction) << "trial " << trial;
      EXPECT_EQ(got.see_through, want.see_through) << "trial " << trial;
      looked_through += want.see_through > 0.0f && trial >= 20;
    }
  }
  EXPECT_GT(looked_through, 10);  // beams from outside did cross the room's walls

  // A wall on the very edge of the only tile, 1 m cells: a beam from 20 m outside crosses it
  // on its first sample inside the tile.
  GridMap edge(GridMapConfig{.cell_size = 1.0, .tile_edge = 8});
  for (std::int32_t y = 0; y < 8; ++y) edge.add_hit({0, y});
  edge.commit_update();
  LaserScan ahead;
  ahead.angle_increment = 0.001f;
  ahead.max_range = 1000.0f;
  ahead.ranges = {40.0f, 40.0f};
  const ScanPoints beams = prepare_scan(ahead);
  for (const double x : {-20.5, -20.0, -7.2, -1.0}) {
    const Pose2 pose{x, 3.5, 0.0};
    const Consistency got = consistency(edge, beams, pose, 0);
    EXPECT_EQ(got.see_through, 1.0f) << x;
    EXPECT_EQ(got.see_through, consistency_walking_everything(edge, beams, pose, 0).see_through);
  }
}

// A wall seen from afar along a corridor: its hits lie in one row of cells, and the beams that
// grazed it cleared the row in front (as on the key-scan log at key scan 155). End points in
// that row are next to the wall, not in free space.
TEST(Recovery, EndPointsNextToAWallAreEvidenceWithinTheTolerance) {
  GridMap map;
  const double cell = map.cell_size();
  for (std::int32_t x = 0; x < 100; ++x) {
    for (int k = 0; k < 3; ++k) map.add_hit({x, 40});           // the wall: y in [2.00, 2.05)
    for (std::int32_t y = 0; y < 40; ++y) map.add_err({x, y});  // free up to its face
  }
  map.commit_update();
  // End points along the wall, in the free row in front of it, seen from (0, 1.0).
  ScanPoints points;
  for (int i = 0; i < 40; ++i) {
    const double x = 0.5 + i * 0.1, y = 39.5 * cell - 1.0;
    points.x.push_back(static_cast<float>(x));
    points.y.push_back(static_cast<float>(y));
    points.range.push_back(static_cast<float>(std::hypot(x, y)));
  }
  const Pose2 pose{0.0, 1.0, 0.0};
  const Consistency exact = consistency(map, points, pose, 0);
  EXPECT_EQ(exact.evidence, 0.0f);
  EXPECT_EQ(exact.contradiction, 1.0f);
  const Consistency near = consistency(map, points, pose, 1);
  EXPECT_EQ(near.evidence, 1.0f);
  EXPECT_EQ(near.contradiction, 0.0f);
  // Two cells short of the wall is free space for a tolerance of one cell.
  const Consistency short_of_it = consistency(map, points, {0.0, 1.0 - cell, 0.0}, 1);
  EXPECT_EQ(short_of_it.evidence, 0.0f);
  EXPECT_EQ(short_of_it.contradiction, 1.0f);
  EXPECT_EQ(near.see_through, 0.0f);
}

TEST(Recovery, WeakMatchNeedsKnownEndPoints) {
  RecoveryConfig c;
  FitnessValue v;
  v.n_points = 100;
  v.n_known = 80;
  v.n_hit = 40;  // agreement 0.5
  EXPECT_TRUE(weak_match(c, v));
  v.n_hit = 75;  // agreement 0.94
  EXPECT_FALSE(weak_match(c, v));
  v.n_known = 25;  // few known end points: nothing to judge the agreement by
  v.n_hit = 5;
  EXPECT_FALSE(weak_match(c, v));
  v.n_known = 10;  // almost none: a view the prediction turned away from the map
  v.n_hit = 10;
  EXPECT_TRUE(weak_match(c, v));
  c.lost_view_known = 0.0;  // ... unless switched off
  EXPECT_FALSE(weak_match(c, v));
  c.lost_view_known = 0.2;
  EXPECT_FALSE(weak_match(c, FitnessValue{}));  // no end points at all: nothing to search with
}

/// `c` must be refused with a message naming `field`.
void expect_refused(const RecoveryConfig& c, const std::string& field) {
  try {
    c.validate();
    ADD_FAILURE() << "accepted a bad " << field;
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
  }
}

TEST(Recovery, ValidateNamesTheField) {
  RecoveryConfig c;
  c.window_theta_deg = 0.0;
  expect_refused(c, "slam.recovery_window_theta");
  RecoveryConfig lost;
  lost.lost_view_known = 1.5;
  EXPECT_THROW(lost.validate(), std::invalid_argument);
  RecoveryConfig settled;
  settled.settled_known = -0.1;
  expect_refused(settled, "slam.recovery_settled_known");
  RecoveryConfig more;
  more.more_candidates = more.candidates - 1;
  expect_refused(more, "slam.recovery_more_candidates");
  more = RecoveryConfig{};
  more.more_below = 1.5;
  expect_refused(more, "slam.recovery_more_below");
  RecoveryConfig odometry;
  odometry.odometry_window_theta_deg = 0.0;
  expect_refused(odometry, "slam.recovery_odometry_window_theta");
  odometry = RecoveryConfig{};
  odometry.odometry_window_frac = std::numeric_limits<double>::quiet_NaN();
  expect_refused(odometry, "slam.recovery_odometry_window_frac");
  // On by default (key-scan logs, dropped scans); the paper's configuration has none of it.
  EXPECT_TRUE(SlamConfig{}.recovery.enabled);
  EXPECT_FALSE(SlamConfig::paper().recovery.enabled);
}

TEST(Recovery, TheGainAJumpNeedsGrowsWithItsLengthUpToAClearGain) {
  RecoveryConfig c;  // weak 0.05 + 0.15 d, fair 0.15 + 0.375 d, at most 0.5
  EXPECT_DOUBLE_EQ(gain_needed(c, true, 0.0), 0.05);
  EXPECT_DOUBLE_EQ(gain_needed(c, true, 2.0), 0.35);
  EXPECT_DOUBLE_EQ(gain_needed(c, false, 0.0), 0.15);
  EXPECT_DOUBLE_EQ(gain_needed(c, false, 0.8), 0.45);
  // A fair tracked pose turned by 100 degrees, the jump 1.8 windows: 0.825 without the cap.
  EXPECT_DOUBLE_EQ(gain_needed(c, false, 1.8), 0.5);
  c.clear_gain = 0.0;
  EXPECT_DOUBLE_EQ(gain_needed(c, false, 1.8), 0.825);
  c.clear_gain = -0.1;
  expect_refused(c, "slam.recovery_clear_gain");
}

TEST(Recovery, AFairPosesShortJumpNeedsOnlyAWeakOnesGain) {
  RecoveryConfig c;  // fair_short_jump 1
  // Key-scan log, key scan 200: a fair tracked pose 0.39 m off after a 1.04 m step.
  EXPECT_TRUE(judged_as_weak(c, false, 0.39, 1.04));
  EXPECT_TRUE(judged_as_weak(c, false, 1.04, 1.04));
  // CSAIL scan 1006: a 0.36 m jump after a 0.23 m step keeps the fair gains.
  EXPECT_FALSE(judged_as_weak(c, false, 0.36, 0.23));
  c.fair_short_jump = 0.5;
  EXPECT_FALSE(judged_as_weak(c, false, 0.6, 1.04));
  EXPECT_TRUE(judged_as_weak(c, true, 0.36, 0.23));   // a weak pose is weak
  EXPECT_FALSE(judged_as_weak(c, false, 0.01, 0.0));  // no motion predicted: any jump is long
  c.fair_short_jump = 0.0;                            // off: the fair gains for every jump
  EXPECT_FALSE(judged_as_weak(c, false, 0.01, 1.0));
  c.fair_short_jump = -0.5;
  expect_refused(c, "slam.recovery_fair_short_jump");
}

TEST(Recovery, AFewKnownEndPointsDoWhenTheyExplainMoreOfTheScan) {
  RecoveryConfig c;  // min_known 0.3, min_hits 0.1
  auto value = [](int hit, int known) {
    FitnessValue v;
    v.n_points = 181;
    v.n_hit = hit;
    v.n_known = known;
    return v;
  };
  const FitnessValue lost = value(0, 74);  // 41 % known, none on hits
  // 30 % known: enough whatever the hits.
  EXPECT_TRUE(overlaps_enough(c, value(10, 55), lost));
  // A turn in place into new space (the simulated robot of sim.sim_slam_test): 21 % known,
  // 35 hits.
  EXPECT_TRUE(overlaps_enough(c, value(35, 38), lost));
  EXPECT_FALSE(overlaps_enough(c, value(17, 38), lost));           // under 10 % on hits
  EXPECT_TRUE(overlaps_enough(c, value(35, 38), value(23, 74)));   // 1.5 times the tracked's
  EXPECT_FALSE(overlaps_enough(c, value(35, 38), value(24, 74)));  // not 1.5 times
  c.min_hits_ratio = 2.0;
  EXPECT_FALSE(overlaps_enough(c, value(35, 38), value(18, 74)));
  c.min_hits_ratio = -1.0;
  expect_refused(c, "slam.recovery_min_hits_ratio");
  c.min_hits_ratio = 1.5;
  c.min_hits = 0.0;
  EXPECT_FALSE(overlaps_enough(c, value(35, 38), lost));
  c.min_hits = 1.5;
  expect_refused(c, "slam.recovery_min_hits");
}

TEST(Recovery, ToleranceOutsideItsRangeIsRefused) {
  RecoveryConfig c;
  EXPECT_EQ(c.tolerance, 1);
  c.tolerance = -1;
  expect_refused(c, "slam.recovery_tolerance");
  c.tolerance = 4;
  expect_refused(c, "slam.recovery_tolerance");
}

/// Scans along a path in the room, every `every`-th kept: the SLAM's pose error at the end.
double slam_error(bool recovery, int every, std::size_t* recovered = nullptr) {
  const auto world = asymmetric_room();
  SlamConfig config;
  config.recovery.enabled = recovery;
  config.seed = 3;
  Slam slam(config);
  // Drive 5 m along y = 4 while turning 90 degrees, then back along x.
  std::vector<Pose2> path;
  for (int i = 0; i <= 50; ++i) path.push_back({2.0 + 0.1 * i, 4.0, deg_to_rad(1.8 * i)});
  for (int i = 1; i <= 30; ++i) path.push_back({7.0, 4.0 - 0.08 * i, deg_to_rad(90.0 - 3.0 * i)});
  Pose2 first = path.front(), last_truth = first, last_estimate;
  std::size_t n = 0;
  for (std::size_t i = 0; i < path.size(); i += static_cast<std::size_t>(every)) {
    const SlamStep step = slam.process(make_scan(world, path[i], 0.2 * static_cast<double>(i)));
    if (recovered != nullptr && step.recovered) ++*recovered;
    last_truth = path[i];
    last_estimate = step.pose;
    ++n;
  }
  // The SLAM's frame is the first scan's pose.
  const Pose2 truth_rel = last_truth.relative_to(first);
  return std::hypot(last_estimate.x - truth_rel.x, last_estimate.y - truth_rel.y) +
         std::abs(normalize_angle(last_estimate.theta - truth_rel.theta));
}

TEST(Recovery, SlamHoldsOnSparseScansWithIt) {
  std::size_t recovered = 0;
  // Every 10th scan: 1 m and 18 degrees between scans, then 0.8 m and 30 degrees.
  const double with = slam_error(true, 10, &recovered);
  EXPECT_LT(with, 0.1) << "seed 3";
  EXPECT_GT(recovered, 0u);
  // Without it the SLAM loses track (4.75 m + rad off when this test was written).
  EXPECT_GT(slam_error(false, 10), 1.0) << "seed 3";
  // Dense scans: the same result whether recovery is on or not (it never changes a good pose).
  EXPECT_LT(slam_error(true, 1), 0.1) << "seed 3";
}

TEST(Recovery, AJumpIsNotTakenForTheRobotsMotion) {
  // Laser only, steady 0.4 m per scan (0.5 s) along the room, then one scan 0.5 m farther than
  // that (a slip, or a scan stamped late): the recovery search puts it right. That jump is a
  // correction of the estimate; the scan after it must be predicted with the motion before it
  // (0.4 m), not with the jump (0.9 m).
  const auto world = asymmetric_room();
  SlamConfig config;
  config.recovery.enabled = true;
  config.seed = 5;
  Slam slam(config);
  std::vector<double> xs{1.0, 1.4, 1.8, 2.2, 2.6, 3.5, 3.9};
  const std::size_t jump = 5;
  for (std::size_t i = 0; i < xs.size(); ++i) {
    const Pose2 truth{xs[i] - xs[0], 0.0, 0.0};  // in the SLAM's frame (the first scan's)
    const SlamStep step =
        slam.process(make_scan(world, {xs[i], 4.0, 0.0}, 0.5 * static_cast<double>(i)));
    if (i == jump) {
      EXPECT_TRUE(step.recovered) << "seed 5";
      EXPECT_NEAR(step.pose.x, truth.x, 0.05) << "seed 5";
    }
    if (i == jump + 1) {
      // The step before the jump, continued from the jumped pose: 3.5 + 0.4 m.
      EXPECT_NEAR(step.predicted.x, truth.x, 0.1) << "seed 5";
      EXPECT_NEAR(step.pose.x, truth.x, 0.05) << "seed 5";
    }
  }
}

TEST(Recovery, AnInPlaceTurnTheTrackingMatchedIsNotSearched) {
  // Laser only, turning in place 20 degrees per scan (a large predicted turn) and back over
  // the part of the room already seen: the tracked poses agree with the map, so the wide
  // search does not run for them; with the rule off (settled_agreement 0) it does.
  const auto world = asymmetric_room();
  const std::vector<double> headings{0, 20, 40, 60, 80, 60, 40, 20, 0};
  auto searched = [&](double settled_agreement) {
    SlamConfig config;
    config.recovery.settled_agreement = settled_agreement;
    config.seed = 3;
    Slam slam(config);
    int tried = 0;
    for (std::size_t i = 0; i < headings.size(); ++i) {
      const SlamStep step = slam.process(
          make_scan(world, {6.0, 4.0, deg_to_rad(headings[i])}, 0.5 * static_cast<double>(i)));
      // The turn back: the prediction carries on the last turn; from the second scan back on
      // it turns the right way, and the scans see only cells seen before.
      if (i >= 6) {
        EXPECT_NEAR(rad_to_deg(normalize_angle(step.pose.theta)), headings[i], 1.0) << "seed 3";
        tried += step.recovery_tried ? 1 : 0;
      }
    }
    return tried;
  };
  EXPECT_EQ(searched(SlamConfig{}.recovery.settled_agreement), 0);
  EXPECT_EQ(searched(0.0), 3);
}

TEST(Recovery, ARobotThatStoodMayHaveDrivenOffInTheTimeSinceTheLastScan) {
  // Laser only, a scan every 2 s (as in a log of every 8th scan): the robot stands for four
  // scans, then drives 0.9 m per scan. Standing, the prediction is no motion: the search's
  // window follows the recent motion (a quarter of +-1.5 m), and the 0.9 m step is out of its
  // reach although the match is weak. With max_speed the time since the last scan (2 s at
  // 1 m/s) starts the search on every scan, with the whole window.
  const auto world = asymmetric_room();
  const std::vector<double> xs{2.0, 2.0, 2.0, 2.0, 2.9, 3.8, 4.7};
  struct Run {
    double worst = 0.0;  // metres from the truth
    int searched_standing = 0;
  };
  auto run = [&](double max_speed, int seed) {
    SlamConfig config;
    config.recovery.max_speed = max_speed;
    config.seed = static_cast<std::uint64_t>(seed);
    Slam slam(config);
    Run r;
    for (std::size_t i = 0; i < xs.size(); ++i) {
      const SlamStep step =
          slam.process(make_scan(world, {xs[i], 4.0, 0.0}, 2.0 * static_cast<double>(i)));
      if (i >= 1 && i <= 3) r.searched_standing += step.recovery_tried ? 1 : 0;
      r.worst = std::max(r.worst, std::hypot(step.pose.x - (xs[i] - xs[0]), step.pose.y));
    }
    return r;
  };
  for (int seed = 1; seed <= 3; ++seed) {
    const Run with = run(1.0, seed);
    EXPECT_LT(with.worst, 0.1) << "seed " << seed;
    EXPECT_EQ(with.searched_standing, 3) << "seed " << seed;
    const Run without = run(0.0, seed);
    EXPECT_GT(without.worst, 0.5) << "seed " << seed;
    EXPECT_EQ(without.searched_standing, 0) << "seed " << seed;
  }
  RecoveryConfig bad;
  bad.max_speed = -1.0;
  expect_refused(bad, "slam.recovery_max_speed");
}

}  // namespace
}  // namespace esfleet
