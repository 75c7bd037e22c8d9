// The SLAM pipeline on scans ray-cast in a synthetic room: it must track a known trajectory,
// be deterministic for a seed, and keep the paper's exact configuration reachable.

#include "esfleet/core/slam.hpp"
#include "esfleet/core/tile_codec.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "synthetic_world.hpp"

namespace esfleet {
namespace {

using testing::asymmetric_room;
using testing::make_scan;

/// A path through the room: forward along the lower half, a left turn, back along the upper
/// half. `step` metres between scans.
std::vector<Pose2> room_path(double step) {
  std::vector<Pose2> path;
  for (double x = 5.0; x <= 10.0; x += step) path.push_back({x, 3.8, 0.0});
  const int turn_steps = 18;
  for (int i = 1; i <= turn_steps; ++i) {
    path.push_back({10.0, 3.8, std::numbers::pi * i / turn_steps});  // turn on the spot
  }
  for (double x = 10.0 - step; x >= 5.0; x -= step) path.push_back({x, 3.8, std::numbers::pi});
  return path;
}

std::vector<LaserScan> scans_along(const std::vector<Pose2>& path, double dt = 0.2) {
  const auto world = asymmetric_room();
  std::vector<LaserScan> scans;
  for (std::size_t i = 0; i < path.size(); ++i) {
    scans.push_back(make_scan(world, path[i], dt * static_cast<double>(i)));
  }
  return scans;
}

/// Largest error of the estimate against the truth, both taken relative to the first pose
/// (the SLAM puts the first scan at the origin).
struct TrackError {
  double xy = 0, theta_deg = 0;
};
TrackError track_error(const std::vector<TimedPose>& estimate, const std::vector<Pose2>& truth) {
  TrackError e;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const Pose2 t = truth[i].relative_to(truth.front());
    const Pose2 d = estimate[i].pose.relative_to(t);
    e.xy = std::max(e.xy, std::hypot(d.x, d.y));
    e.theta_deg = std::max(e.theta_deg, std::abs(rad_to_deg(normalize_angle(d.theta))));
  }
  return e;
}

std::vector<TimedPose> run(const SlamConfig& config, const std::vector<LaserScan>& scans) {
  Slam slam(config);
  for (const LaserScan& s : scans) slam.process(s);
  return slam.trajectory();
}

TEST(Slam, DefaultConfigurationTracksTheRoomPath) {
  const auto path = room_path(0.1);
  const auto scans = scans_along(path);
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    SlamConfig config;
    config.seed = seed;
    const TrackError e = track_error(run(config, scans), path);
    // Worst pose over the run, measured with the free-space margin (the default since
    // 2026-12-04): 0.036 m for every seed; heading 0.02, 1.15, 0.04 deg (seed 2: one turn on
    // the spot; under 1 deg without the margin, which on these noise-free ranges only removes
    // evidence: docs/slam.md item 8).
    EXPECT_LT(e.xy, 0.05) << "seed " << seed;
    EXPECT_LT(e.theta_deg, 1.25) << "seed " << seed;
  }
}

TEST(Slam, BeamFillWritesACoarseLasersWallsDenserAndMatchesItsOwnBeams) {
  // The synthetic laser has 181 beams over 180 deg (1 deg): with the beam fill (the default,
  // 0.5 deg) the scans are written into the map with a point between adjacent beams of one
  // wall, while the tracking still matches the scan's own beams.
  const auto path = room_path(0.1);
  const auto scans = scans_along(path);
  auto hit_cells = [](const GridMap& map) {
    int n = 0;
    for (int y = -400; y < 400; ++y) {
      for (int x = -400; x < 400; ++x) n += map.hit({x, y}) > 0;
    }
    return n;
  };
  SlamConfig config;
  config.seed = 1;
  ASSERT_EQ(config.update.beam_fill_deg, 0.5);  // the default
  // Every scan (by default only scans far apart: the next test).
  config.update.beam_fill_min_step = 0.0;
  config.update.beam_fill_min_turn_deg = 0.0;
  Slam filled(config);
  config.update.beam_fill_deg = 0.0;
  Slam own(config);
  for (const LaserScan& scan : scans) {
    const SlamStep a = own.process(scan);
    const SlamStep b = filled.process(scan);
    if (&scan != &scans.front()) {
      ASSERT_EQ(a.fitness.n_points, b.fitness.n_points);  // the scan's own end points
      EXPECT_EQ(b.fitness.n_points, static_cast<std::int32_t>(prepare_scan(scan).size()));
    }
  }
  const int n_own = hit_cells(own.map()), n_filled = hit_cells(filled.map());
  EXPECT_GT(n_own, 500);
  // Measured: 946 cells hit without the fill, 1010 with it (the room's walls are near: 1 deg
  // beams are under a cell apart on most of them).
  EXPECT_GT(n_filled, n_own + 30) << n_own << " cells hit without the fill";
  EXPECT_LT(track_error(filled.trajectory(), path).xy, 0.05);
  EXPECT_LT(track_error(own.trajectory(), path).xy, 0.05);
}

TEST(Slam, BeamFillOnlyWhileTheScansAreFarApart) {
  // By default a scan is written filled only while this step or one of the 5 before it moved
  // at least 0.3 m or turned at least 15 degrees. The room path (0.1 m steps, turns of 10
  // degrees on the spot) is written with the scans' own beams after the first scan; the same
  // room crossed in 0.5 m steps is written filled.
  auto own_beams_written = [](const std::vector<LaserScan>& scans, SlamConfig config) {
    Slam slam(config);
    std::vector<bool> own;  // per inserted scan: written with exactly its own end points
    for (const LaserScan& scan : scans) {
      const SlamStep s = slam.process(scan);
      if (s.inserted) own.push_back(s.update.hits == prepare_scan(scan).size());
    }
    return own;
  };
  SlamConfig config;
  config.seed = 1;
  ASSERT_EQ(config.update.beam_fill_min_step, 0.3);
  ASSERT_EQ(config.update.beam_fill_min_turn_deg, 15.0);
  const std::vector<bool> slow = own_beams_written(scans_along(room_path(0.1)), config);
  ASSERT_GT(slow.size(), 10u);
  EXPECT_FALSE(slow.front());  // the first scan counts as far from the (none) before it
  EXPECT_EQ(std::count(slow.begin() + 1, slow.end(), false), 0);

  std::vector<Pose2> fast;
  for (double x = 5.0; x <= 10.0; x += 0.5) fast.push_back({x, 3.8, 0.0});
  const std::vector<bool> far = own_beams_written(scans_along(fast), config);
  ASSERT_GT(far.size(), 5u);
  EXPECT_EQ(std::count(far.begin(), far.end(), true), 0);

  // Both thresholds 0: every scan filled, slow or not.
  config.update.beam_fill_min_step = 0.0;
  config.update.beam_fill_min_turn_deg = 0.0;
  const std::vector<bool> always = own_beams_written(scans_along(room_path(0.1)), config);
  EXPECT_EQ(std::count(always.begin(), always.end(), true), 0);
}

TEST(Slam, PaperConfigurationTracksSlowMotion) {
  // The paper's previous-pose prediction only holds while the motion per scan stays inside
  // the initial spread, so the robot moves 2 cm per scan and turns 2 degrees per scan here.
  // Nearest-cell fitness on 5 cm cells: the paper's accuracy is a few cm and a few degrees.
  std::vector<Pose2> path;
  for (double x = 5.0; x <= 7.0; x += 0.02) path.push_back({x, 3.8, 0.0});
  for (int i = 1; i <= 20; ++i) path.push_back({7.0, 3.8, deg_to_rad(2.0 * i)});
  const auto scans = scans_along(path);
  SlamConfig config = SlamConfig::paper();
  config.seed = 4;
  const TrackError e = track_error(run(config, scans), path);
  EXPECT_LT(e.xy, 0.1);
  EXPECT_LT(e.theta_deg, 3.0);
}

TEST(Slam, PaperConfigurationSwitchesEveryExtensionOff) {
  const SlamConfig p = SlamConfig::paper();
  EXPECT_EQ(p.tracking.prediction, MotionPrediction::kPreviousPose);
  EXPECT_FALSE(p.tracking.use_odometry);
  EXPECT_TRUE(p.tracking.use_penalty);
  EXPECT_FALSE(p.tracking.motion_hypotheses);
  EXPECT_FALSE(p.tracking.turn_hypotheses);
  EXPECT_EQ(p.tracking.interpolation, Interpolation::kNone);
  EXPECT_FALSE(p.tracking.refine);
  EXPECT_EQ(p.tracking.prior_sigma_xy, 0.0);
  EXPECT_EQ(p.insert_min_travel, 0.0);
  EXPECT_EQ(p.insert_min_turn_deg, 0.0);
  EXPECT_FALSE(p.loop.enabled);
  EXPECT_EQ(p.tracking.es.mu, 100);
  EXPECT_EQ(p.tracking.es.iterations, 1000);
  EXPECT_NO_THROW(p.validate());
}

TEST(Slam, PaperConfigurationInsertsEveryScan) {
  const auto scans = scans_along(room_path(0.1));
  Slam slam(SlamConfig::paper());
  std::size_t inserted = 0;
  for (std::size_t i = 0; i < 10; ++i) inserted += slam.process(scans[i]).inserted ? 1 : 0;
  EXPECT_EQ(inserted, 10u);
}

TEST(Slam, SameSeedGivesIdenticalTrajectoriesAndMaps) {
  const auto scans = scans_along(room_path(0.1));
  SlamConfig config;
  config.seed = 7;
  Slam a(config), b(config);
  for (const LaserScan& s : scans) {
    a.process(s);
    b.process(s);
  }
  ASSERT_EQ(a.trajectory().size(), b.trajectory().size());
  for (std::size_t i = 0; i < a.trajectory().size(); ++i) {
    // Bitwise equality, not a tolerance: the run is deterministic.
    EXPECT_EQ(a.trajectory()[i].pose, b.trajectory()[i].pose) << "scan " << i;
  }
  ASSERT_EQ(a.map().tile_keys(), b.map().tile_keys());
  for (const TileKey k : a.map().tile_keys()) {
    EXPECT_EQ(a.map().find_tile(k)->hit, b.map().find_tile(k)->hit);
    EXPECT_EQ(a.map().find_tile(k)->err, b.map().find_tile(k)->err);
  }
}

TEST(Slam, DifferentSeedsExploreDifferently) {
  // The seed must reach the ES: with the paper's configuration (no deterministic polish) two
  // seeds give poses that differ in their last bits at least.
  const auto scans = scans_along(room_path(0.1));
  SlamConfig a = SlamConfig::paper(), b = SlamConfig::paper();
  a.seed = 1;
  b.seed = 2;
  const auto ta = run(a, {scans.begin(), scans.begin() + 5});
  const auto tb = run(b, {scans.begin(), scans.begin() + 5});
  bool differ = false;
  for (std::size_t i = 1; i < ta.size(); ++i) differ = differ || !(ta[i].pose == tb[i].pose);
  EXPECT_TRUE(differ);
}

TEST(Slam, OdometryPredictionFollowsFastMotion) {
  // 0.3 m and up to 20 degrees per scan: too fast for the previous-pose prediction, easy with
  // odometry (here with 5 % noise on each increment).
  std::vector<Pose2> path;
  for (double x = 2.0; x <= 10.5; x += 0.3) path.push_back({x, 4.5, 0.0});
  for (int i = 1; i <= 9; ++i) path.push_back({10.5, 4.5, deg_to_rad(20.0 * i)});
  auto scans = scans_along(path);
  std::mt19937 gen(11);
  std::normal_distribution<double> noise(0.0, 0.05);
  Pose2 odom{100.0, -50.0, 1.0};  // odometry has its own frame
  for (std::size_t i = 0; i < scans.size(); ++i) {
    if (i > 0) {
      Pose2 inc = path[i].relative_to(path[i - 1]);
      inc.x *= 1.0 + noise(gen);
      inc.theta *= 1.0 + noise(gen);
      odom = odom.compose(inc);
    }
    scans[i].odometry = odom;
  }
  SlamConfig config;
  config.tracking.use_odometry = true;
  config.seed = 3;
  const TrackError e = track_error(run(config, scans), path);
  EXPECT_LT(e.xy, 0.05);
  EXPECT_LT(e.theta_deg, 1.0);
}

TEST(Slam, AWildOdometryJumpIsNotFollowed) {
  // A driver restarted (its odometry jumps back to its origin, 523 m away) or a broken or
  // hostile message (1e300 m, which ROS 2's Odometry converter lets through as finite): the
  // SLAM keeps tracking the laser, and nothing is written far away. The 523 m jump is beaten
  // by the other motion hypotheses; a step beyond any map is dropped before the search (it
  // used to be followed, and 1e300 m in cells overflowed the map update's int32 cell indices:
  // fuzz_slam, docs/fuzzing.md finding 5).
  const auto path = room_path(0.1);
  for (const double jump : {-523.0, 1e300, -1.7e308}) {
    auto scans = scans_along(path);
    for (std::size_t i = 0; i < scans.size(); ++i) {
      scans[i].odometry = path[i];
      if (i == 20) scans[i].odometry->x += jump;                          // one wild message
      if (i >= 40 && std::abs(jump) < 1e6) scans[i].odometry->x += jump;  // a reset that stays
    }
    SlamConfig config;
    config.tracking.use_odometry = true;
    Slam slam(config);
    for (const LaserScan& s : scans) {
      const SlamStep step = slam.process(s);
      EXPECT_LT(std::hypot(step.pose.x, step.pose.y), 100.0) << jump;  // never followed
      const double tile = slam.map().cell_size() * slam.map().tile_edge();
      for (const TileKey k : slam.map().tile_keys()) {
        ASSERT_LT(std::abs(k.tx * tile), 100.0) << jump;  // the room is 12 m
        ASSERT_LT(std::abs(k.ty * tile), 100.0) << jump;
      }
    }
    const TrackError e = track_error(slam.trajectory(), path);
    EXPECT_LT(e.xy, 0.1) << jump;
    EXPECT_LT(e.theta_deg, 2.0) << jump;
  }
}

TEST(Slam, FirstScanIsAtTheOriginAndMapIsBuilt) {
  const auto scans = scans_along(room_path(0.1));
  Slam slam;
  const SlamStep step = slam.process(scans.front());
  EXPECT_EQ(step.pose, Pose2{});
  EXPECT_TRUE(step.inserted);
  EXPECT_GT(slam.map().tile_count(), 0u);
}

TEST(Slam, InvalidConfigurationIsRefusedNamingTheField) {
  SlamConfig c;
  c.tracking.init_sigma_xy = -1.0;
  try {
    c.validate();
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("init_sigma_xy"), std::string::npos) << e.what();
  }
  EXPECT_THROW(Slam{c}, std::invalid_argument);
  for (const auto& [field, set] : std::vector<std::pair<std::string, void (*)(SlamConfig&)>>{
           {"short_view_range", [](SlamConfig& s) { s.short_view_range = -1.0; }},
           {"short_view_range", [](SlamConfig& s) { s.short_view_range = std::nan(""); }},
           {"short_view_motion_hold", [](SlamConfig& s) { s.short_view_motion_hold = 1.0; }}}) {
    SlamConfig bad;
    set(bad);
    try {
      bad.validate();
      ADD_FAILURE() << field << ": no exception";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  }
}

TEST(Slam, ScanWithoutUsableBeamsKeepsThePrediction) {
  auto scans = scans_along(room_path(0.1));
  Slam slam;
  slam.process(scans[0]);
  LaserScan empty = scans[1];
  for (float& r : empty.ranges) r = std::numeric_limits<float>::quiet_NaN();
  const SlamStep step = slam.process(empty);
  EXPECT_FALSE(step.inserted);
  EXPECT_TRUE(std::isfinite(step.pose.x) && std::isfinite(step.pose.theta));
}

/// After moving a state's graph nodes: every edge re-measured from the moved poses (what a
/// tracking that saw them would have recorded) and the trajectory re-derived from its anchors.
void remeasure(SlamState& st) {
  for (PoseGraphEdge& e : st.graph_edges) {
    e.measurement = st.graph_nodes[e.to].relative_to(st.graph_nodes[e.from]);
  }
  for (std::size_t t = 0; t < st.trajectory.size(); ++t) {
    const auto& [k, rel] = st.anchors[t];
    st.trajectory[t].pose = st.graph_nodes[k].compose(rel);
  }
}

/// The room path mapped with the online loop closure off, then its state rewritten as if the
/// robot had drifted on its way back: the key scans after the turn moved about it by a rigid
/// transform growing from nothing to (8 cm, 6 cm, 1.5 deg) at the last one, consecutive-key edges
/// re-measured from the drifted poses (what a drifted tracking would have recorded), trajectory
/// re-derived. Only revisit matches can undo it.
SlamState drifted_room_state(const SlamConfig& config, const std::vector<LaserScan>& scans,
                             double turn_end_stamp) {
  Slam slam(config);
  for (const LaserScan& s : scans) slam.process(s);
  SlamState st = slam.state();
  std::size_t pivot = 0;
  while (pivot + 1 < st.keys.size() && st.keys[pivot + 1].stamp <= turn_end_stamp) ++pivot;
  const Pose2 p = st.graph_nodes[pivot];
  const std::size_t n = st.graph_nodes.size();
  for (std::size_t k = pivot + 1; k < n; ++k) {
    const double f = static_cast<double>(k - pivot) / static_cast<double>(n - 1 - pivot);
    const Pose2 drift{0.08 * f, 0.06 * f, deg_to_rad(1.5) * f};
    st.graph_nodes[k] = p.compose(drift).compose(st.graph_nodes[k].relative_to(p));
  }
  remeasure(st);
  return st;
}

SlamConfig final_pass_config() {
  SlamConfig c;
  c.loop.every = 1000000;  // no online closure: the final pass alone
  c.loop.min_travel = 3.0;
  c.loop.final_every = 1;
  c.loop.final_icp_neighbours = 3;  // the final pass's tests cover its ICP too
  // Noise-free synthetic ranges: the free-space margin (map_update.hpp), there for range noise,
  // only takes evidence away here. Measured with it (0.15 m): seed 2's heading error after the
  // final pass 1.15 deg of 1.5 (0.46 without), seed 1's 0.54 (0.32).
  c.update.free_margin = 0.0;
  // The final pass as written for the dense logs' 0.5 deg lasers (the synthetic one has 1 deg).
  // With the beam fill (docs/slam.md item 11) the same drift is undone less, seeds 1-6: 0.22 m
  // before, 0.016-0.130 m after, against 0.174 -> 0.029-0.046 m without the fill.
  c.update.beam_fill_deg = 0.0;
  return c;
}

TEST(Slam, FinalPassUndoesDriftAtARevisit) {
  const auto path = room_path(0.1);
  const auto scans = scans_along(path);
  const double turn_end = scans[path.size() / 2 + 9].stamp;
  for (std::uint64_t seed : {1u, 2u}) {
    SlamConfig config = final_pass_config();
    config.seed = seed;
    const SlamState drifted = drifted_room_state(config, scans, turn_end);
    const TrackError before = track_error(drifted.trajectory, path);
    EXPECT_GT(before.xy, 0.15) << "seed " << seed;
    EXPECT_GT(before.theta_deg, 1.4) << "seed " << seed;
    Slam slam(config);
    slam.restore(drifted);
    const SlamFinish f = slam.finish(1);
    EXPECT_GT(f.kept, 5u) << "seed " << seed;
    const TrackError e = track_error(slam.trajectory(), path);
    // Measured: 0.174 m, 1.5 deg -> 0.061 m, 0.71 deg at most (seeds 1, 2). Only some of the
    // way-back scans overlap the old ones enough to match (a 180-degree laser looking the
    // other way), and the graph spreads what they say over the rest.
    EXPECT_LT(e.xy, 0.5 * before.xy) << "seed " << seed;
    EXPECT_LT(e.theta_deg, 0.6 * before.theta_deg) << "seed " << seed;
  }
}

TEST(Slam, AfterTheGraphMovesTheKeyScansTheMapIsTheirsAtTheirNewPoses) {
  // The final pass on the drifted state moves most key scans (the map is then written again
  // whole); a second one moves a few back (taken out and written again one by one): either
  // way the map is what the key scans give at their poses.
  const auto path = room_path(0.1);
  const auto scans = scans_along(path);
  const double turn_end = scans[path.size() / 2 + 9].stamp;
  SlamConfig config = final_pass_config();
  const auto write_keys = [&](const SlamState& st, GridMap& m) {
    for (const KeyScan& k : st.keys) {
      update_map(m, *k.points, k.mapped_pose, config.update, false, false);
    }
    m.commit_update();
  };
  const auto from_scratch = [&](const SlamState& st) {
    GridMap m(config.map);
    write_keys(st, m);
    return map_digest(m);
  };
  const auto moved = [](const SlamState& a, const SlamState& b) {
    std::size_t n = 0;
    for (std::size_t k = 0; k < a.keys.size(); ++k) {
      n += a.keys[k].mapped_pose == b.keys[k].mapped_pose ? 0 : 1;
    }
    return n;
  };
  // restore() takes the state besides the map; the map is the key scans where they were
  // written.
  const auto finished = [&](const SlamState& st) {
    Slam slam(config);
    slam.restore(st);
    write_keys(st, slam.map());
    slam.finish(1);
    return std::pair{slam.state(), map_digest(slam.map())};
  };
  const SlamState drifted = drifted_room_state(config, scans, turn_end);
  const auto [after, after_map] = finished(drifted);
  EXPECT_GT(2 * moved(drifted, after), after.keys.size());
  EXPECT_NE(after_map, from_scratch(drifted));
  EXPECT_EQ(after_map, from_scratch(after));

  // Four key scans written 5 cm off their graph poses: the next pass puts back those few.
  SlamState again = after;
  for (std::size_t k = again.keys.size() - 4; k < again.keys.size(); ++k) {
    again.keys[k].mapped_pose.x += 0.05;
  }
  const auto [last, last_map] = finished(again);
  const std::size_t n = moved(again, last);
  EXPECT_GT(n, 0u);
  EXPECT_LT(2 * n, last.keys.size());
  EXPECT_NE(last_map, from_scratch(again));
  EXPECT_EQ(last_map, from_scratch(last));
}

TEST(Slam, FinalPassIsTheSameForAnyNumberOfThreads) {
  const auto path = room_path(0.1);
  const auto scans = scans_along(path);
  const SlamConfig config = final_pass_config();
  const SlamState drifted = drifted_room_state(config, scans, scans[path.size() / 2 + 9].stamp);
  std::vector<TimedPose> first;
  for (unsigned threads : {1u, 2u, 3u}) {
    Slam slam(config);
    slam.restore(drifted);
    slam.finish(threads);
    if (first.empty()) {
      first = slam.trajectory();
      continue;
    }
    ASSERT_EQ(slam.trajectory().size(), first.size());
    for (std::size_t i = 0; i < first.size(); ++i) {
      ASSERT_EQ(slam.trajectory()[i].pose, first[i].pose) << threads << " threads, pose " << i;
    }
  }
}

/// The room path mapped with the online loop closure off, then every key scan's pose jittered
/// (seeded, 2 cm and 0.4 deg standard deviation: a noisy tracking) with the consecutive-key
/// edges re-measured from the jittered poses and the trajectory re-derived.
SlamState jittered_room_state(const SlamConfig& config, const std::vector<LaserScan>& scans,
                              std::uint32_t seed) {
  Slam slam(config);
  for (const LaserScan& s : scans) slam.process(s);
  SlamState st = slam.state();
  std::mt19937 gen(seed);
  std::normal_distribution<double> xy(0.0, 0.02), th(0.0, deg_to_rad(0.4));
  for (std::size_t k = 1; k < st.graph_nodes.size(); ++k) {
    st.graph_nodes[k] = st.graph_nodes[k].compose(Pose2{xy(gen), xy(gen), th(gen)});
  }
  remeasure(st);
  return st;
}

TEST(Slam, FinalPassAlignsSuccessiveKeyScansByIcp) {
  const auto path = room_path(0.1);
  const auto scans = scans_along(path);
  for (std::uint32_t seed : {1u, 2u, 3u}) {
    TrackError e[2];
    for (int icp : {0, 1}) {
      SlamConfig config = final_pass_config();
      config.loop.final_icp_neighbours = icp * 3;
      Slam slam(config);
      slam.restore(jittered_room_state(config, scans, seed));
      const SlamFinish f = slam.finish(1);
      if (icp == 1) {
        // Every key scan against the 3 before it that are within 0.5 m (all but a few);
        // noise-free scans of a room align.
        const std::size_t keys = slam.state().keys.size();
        EXPECT_LE(f.icp_tried, 3 * keys - 6) << "seed " << seed;
        EXPECT_GT(f.icp_tried, (3 * keys - 6) * 8 / 10) << "seed " << seed;
        EXPECT_GT(f.icp_aligned, f.icp_tried * 9 / 10) << "seed " << seed;
      } else {
        EXPECT_EQ(f.icp_tried, 0u);
      }
      e[icp] = track_error(slam.trajectory(), path);
    }
    // Measured (seeds 1-3, worst pose): without 7.1-11.6 cm and 1.10-1.17 deg; with ICP
    // 2.8-3.3 cm and 0.31-0.56 deg.
    EXPECT_LT(e[1].xy, 0.5 * e[0].xy) << "seed " << seed;
    EXPECT_LT(e[1].theta_deg, 0.6 * e[0].theta_deg) << "seed " << seed;
  }
}

TEST(Slam, FinalPassIsOffInThePaperConfiguration) {
  const auto scans = scans_along(room_path(0.1));
  Slam slam(SlamConfig::paper());
  for (const LaserScan& s : scans) slam.process(s);
  const std::vector<TimedPose> before = slam.trajectory();
  const SlamFinish f = slam.finish();
  EXPECT_EQ(f.tried, 0u);
  ASSERT_EQ(slam.trajectory().size(), before.size());
  for (std::size_t i = 0; i < before.size(); ++i)
    EXPECT_EQ(slam.trajectory()[i].pose, before[i].pose);
}

}  // namespace
}  // namespace esfleet
