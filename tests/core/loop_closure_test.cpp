// Loop-closure detection on scans ray-cast in a synthetic room: an old key scan and a current
// scan from a nearby true pose, with a drifted estimate. The match must recover the true
// relative pose, and nothing must be matched when the old scans are not far enough back.

#include "esfleet/core/loop_closure.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "esfleet/core/random.hpp"

#include "synthetic_world.hpp"

namespace esfleet {
namespace {

using testing::asymmetric_room;
using testing::make_scan;

struct Scene {
  std::vector<KeyScan> keys;
  std::vector<Pose2> poses;
};

/// Key scans of `world` mapped at their true poses `truths`, 0.4 m apart along the path.
Scene keys_at(const std::vector<testing::Segment>& world, const std::vector<Pose2>& truths) {
  Scene s;
  for (std::size_t i = 0; i < truths.size(); ++i) {
    KeyScan k;
    k.stamp = static_cast<double>(i);
    k.points = std::make_shared<const ScanPoints>(prepare_scan(make_scan(world, truths[i])));
    k.mapped_pose = truths[i];
    k.path_length = 0.4 * static_cast<double>(i);
    s.keys.push_back(std::move(k));
    s.poses.push_back(truths[i]);
  }
  return s;
}

/// Six key scans along a line in the asymmetric room, path lengths from 0.
Scene old_keys() {
  std::vector<Pose2> truths;
  for (int i = 0; i < 6; ++i) truths.push_back({5.0 + 0.4 * i, 4.0, 0.1 * i});
  return keys_at(asymmetric_room(), truths);
}

TEST(LoopClosure, WindowGrowsWithThePlausibleDriftUpToItsCap) {
  LoopClosureConfig c;  // +-2 m, drift 0.3 m + 2 %, cap 4 m
  EXPECT_DOUBLE_EQ(loop_search_window_xy(c, 10.0), 2.0);
  EXPECT_NEAR(loop_search_window_xy(c, 100.0), 2.3, 1e-12);
  EXPECT_DOUBLE_EQ(loop_search_window_xy(c, 1000.0), 4.0);
  c.window_max_xy = 0.0;  // fixed
  EXPECT_DOUBLE_EQ(loop_search_window_xy(c, 1000.0), 2.0);
}

TEST(LoopClosure, AGrownWindowFindsARevisitTooFarOffForTheFixedOne) {
  // 2.6 m off after 200 m of travel: plausible (0.3 m + 2 % of 198 m), beyond +-2 m.
  const Scene scene = old_keys();
  const Pose2 truth{6.1, 4.3, 0.25};
  const ScanPoints current = prepare_scan(make_scan(asymmetric_room(), truth));
  const Pose2 drifted{truth.x + 2.6, truth.y, truth.theta};
  LoopClosureConfig config;
  const double travel = 200.0;
  auto search = [&](double window) {
    LoopClosureConfig c = config;
    c.window_xy = window;
    return find_loop_closure(scene.keys, scene.poses, current, drifted, travel, c, GridMapConfig{},
                             MapUpdateConfig{}, FitnessOptions{});
  };
  EXPECT_FALSE(search(config.window_xy).has_value());
  const double grown = loop_search_window_xy(config, travel - scene.keys.front().path_length);
  ASSERT_GT(grown, 2.6);
  const auto match = search(grown);
  ASSERT_TRUE(match.has_value());
  EXPECT_NEAR(match->pose.x, truth.x, 0.05);
  EXPECT_NEAR(match->pose.y, truth.y, 0.05);
  EXPECT_NEAR(normalize_angle(match->pose.theta - truth.theta), 0.0, deg_to_rad(1.0));
}

TEST(LoopClosure, RecoversTheTruePoseFromADriftedEstimate) {
  const Scene scene = old_keys();
  const Pose2 truth{6.1, 4.3, 0.25};
  const ScanPoints current = prepare_scan(make_scan(asymmetric_room(), truth));
  const Pose2 drifted{truth.x + 0.35, truth.y - 0.25, truth.theta + deg_to_rad(3.0)};
  LoopClosureConfig config;
  const auto match = find_loop_closure(scene.keys, scene.poses, current, drifted,
                                       /*path_length=*/40.0, config, GridMapConfig{},
                                       MapUpdateConfig{}, FitnessOptions{});
  ASSERT_TRUE(match.has_value());
  EXPECT_NEAR(match->pose.x, truth.x, 0.05);
  EXPECT_NEAR(match->pose.y, truth.y, 0.05);
  EXPECT_NEAR(normalize_angle(match->pose.theta - truth.theta), 0.0, deg_to_rad(1.0));
  EXPECT_GE(match->value.agreement(), config.min_agreement);
  // The relative pose is the pose seen from the anchor key scan.
  const Pose2 rel = match->pose.relative_to(scene.poses[match->anchor]);
  EXPECT_NEAR(rel.x, match->relative.x, 1e-9);
  EXPECT_NEAR(rel.y, match->relative.y, 1e-9);
}

TEST(LoopClosure, IgnoresScansThatAreNotFarEnoughBackAlongThePath) {
  const Scene scene = old_keys();
  const Pose2 truth{6.1, 4.3, 0.25};
  const ScanPoints current = prepare_scan(make_scan(asymmetric_room(), truth));
  LoopClosureConfig config;
  config.min_travel = 10.0;
  // Only 3 m travelled since the first key scan: nothing is old enough to close a loop with.
  const auto match = find_loop_closure(scene.keys, scene.poses, current, truth, 3.0, config,
                                       GridMapConfig{}, MapUpdateConfig{}, FitnessOptions{});
  EXPECT_FALSE(match.has_value());
}

TEST(LoopClosure, RefusesAnImplausiblyLargeCorrection) {
  const Scene scene = old_keys();
  const Pose2 truth{6.1, 4.3, 0.25};
  const ScanPoints current = prepare_scan(make_scan(asymmetric_room(), truth));
  // 1.5 m off after only 12 m of travel: more than drift_floor + drift_rate * travel allows.
  const Pose2 far{truth.x + 1.5, truth.y, truth.theta};
  LoopClosureConfig config;
  const auto match = find_loop_closure(scene.keys, scene.poses, current, far, 12.0, config,
                                       GridMapConfig{}, MapUpdateConfig{}, FitnessOptions{});
  EXPECT_FALSE(match.has_value());
}

/// Key scans along a corridor with a door jamb (a few end points see along it), 0.4 m apart.
Scene corridor_keys(const std::vector<testing::Segment>& world) {
  std::vector<Pose2> truths;
  for (int i = 0; i < 6; ++i) truths.push_back({0.4 * i, 0.0, 0.0});
  return keys_at(world, truths);
}

const std::vector<testing::Segment> kCorridor{
    {-100, 1, 100, 1}, {-100, -1, 100, -1}, {3.5, 1, 3.5, 0.8}};

/// The submap of `scene`'s scans and a fitness of `points` in it, as find_loop_closure builds
/// them.
struct SceneFitness {
  GridMap map;
  FitnessEvaluator fitness;
  SceneFitness(const Scene& scene, const ScanPoints& points)
      : map(scene_map(scene)), fitness(map, points, FitnessOptions{}) {}
  static GridMap scene_map(const Scene& scene) {
    GridMap m{GridMapConfig{}};
    for (std::size_t i = 0; i < scene.keys.size(); ++i) {
      update_map(m, *scene.keys[i].points, scene.poses[i], MapUpdateConfig{});
    }
    return m;
  }
};

TEST(LoopClosure, TheFlattestDirectionIsACorridorsAxisAndNoneInARoom) {
  // What the final pass's degenerate_ratio (0.1) sees, over two cells as it looks.
  const Pose2 truth{1.0, 0.1, 0.02};
  const ScanPoints in_corridor = prepare_scan(make_scan(kCorridor, truth));
  const SceneFitness corridor(corridor_keys(kCorridor), in_corridor);
  const Flattest flat =
      flattest_direction(corridor.fitness, truth, corridor.fitness.fitness(truth), 0.1);
  ASSERT_TRUE(flat.curved);
  EXPECT_LT(flat.ratio, 0.1);
  EXPECT_GT(std::abs(flat.vx), 0.99);  // along x, the corridor's axis
  EXPECT_NEAR(std::hypot(flat.vx, flat.vy), 1.0, 1e-9);
  // Demanding less of the flattest direction: constrained enough.
  EXPECT_GE(flat.ratio, 1e-4);

  const Pose2 in_room{6.1, 4.3, 0.25};
  const SceneFitness room(old_keys(), prepare_scan(make_scan(asymmetric_room(), in_room)));
  const Flattest in_the_room =
      flattest_direction(room.fitness, in_room, room.fitness.fitness(in_room), 0.1);
  EXPECT_TRUE(in_the_room.curved);
  EXPECT_GE(in_the_room.ratio, 0.1);
}

TEST(LoopClosure, AlongACorridorAMatchKeepsTheEstimatesPosition) {
  // The estimate is 0.2 m ahead along the corridor and 0.1 m off across it. With
  // degenerate_ratio the match takes the correction across (and the heading) but not along.
  const Scene scene = corridor_keys(kCorridor);
  const Pose2 truth{1.0, 0.1, 0.02};
  const ScanPoints current = prepare_scan(make_scan(kCorridor, truth));
  const Pose2 estimate{truth.x + 0.2, truth.y - 0.1, truth.theta + deg_to_rad(1.0)};
  LoopClosureConfig config;  // as the final pass searches
  config.window_xy = 0.3;
  config.window_theta_deg = 3.0;
  config.rival_distance = 0.3;
  config.max_ambiguity = 1.0;
  auto search = [&](double ratio) {
    LoopClosureConfig c = config;
    c.degenerate_ratio = ratio;
    return find_loop_closure(scene.keys, scene.poses, current, estimate, 40.0, c, GridMapConfig{},
                             MapUpdateConfig{}, FitnessOptions{});
  };
  const auto free = search(0.0);
  const auto held = search(0.1);
  ASSERT_TRUE(free.has_value());
  ASSERT_TRUE(held.has_value());
  EXPECT_GT(std::abs(free->pose.x - estimate.x), 0.05);  // the free match moved along
  EXPECT_NEAR(held->pose.x, estimate.x, 0.01);           // the held one did not
  for (const auto& m : {*free, *held}) {
    EXPECT_NEAR(m.pose.y, truth.y, 0.03);
    EXPECT_NEAR(normalize_angle(m.pose.theta - truth.theta), 0.0, deg_to_rad(0.5));
  }
  EXPECT_NEAR(held->relative.x, held->pose.relative_to(scene.poses[held->anchor]).x, 1e-9);
  EXPECT_THROW(
      [] {
        LoopClosureConfig bad;
        bad.degenerate_ratio = 1.0;
        bad.validate();
      }(),
      std::invalid_argument);
}

/// Every cell of `a` and `b` the same (counters, scores, coarse levels); a tile only one of them
/// has must be all unknown.
void expect_same_cells(const GridMap& a, const GridMap& b) {
  std::set<TileKey> keys;
  for (const TileKey& k : a.tile_keys()) keys.insert(k);
  for (const TileKey& k : b.tile_keys()) keys.insert(k);
  for (const TileKey& k : keys) {
    const Tile* ta = a.find_tile(k);
    const Tile* tb = b.find_tile(k);
    const Tile* only = ta == nullptr ? tb : (tb == nullptr ? ta : nullptr);
    if (only != nullptr) {
      for (std::size_t i = 0; i < only->hit.size(); ++i) {
        ASSERT_EQ(only->hit[i] + only->err[i], 0u) << "tile " << k.tx << "," << k.ty;
      }
      continue;
    }
    ASSERT_EQ(ta->hit, tb->hit) << "tile " << k.tx << "," << k.ty;
    ASSERT_EQ(ta->err, tb->err);
    ASSERT_EQ(ta->score, tb->score);
    ASSERT_EQ(ta->coarse, tb->coarse);
  }
}

TEST(SubmapCache, EveryBuildHoldsTheCellsOfASubmapBuiltFromScratch) {
  // A pool of scans along a path; each search takes a sliding window of them, and now and then
  // a closure moves some (their poses change by a little): the cache must give the submap a
  // fresh build gives, and ray-cast fewer scans than fresh builds would.
  const auto world = asymmetric_room();
  Rng rng(7);
  std::vector<SubmapScan> pool;
  for (int i = 0; i < 40; ++i) {
    const Pose2 truth{1.0 + 0.25 * i, i < 20 ? 1.5 : 6.5, rng.uniform(-3.0, 3.0)};
    pool.push_back(
        {std::make_shared<const ScanPoints>(prepare_scan(make_scan(world, truth))), truth});
  }
  GridMapConfig config;
  config.pyramid_levels = 2;
  const MapUpdateConfig update;
  SubmapCache cache;
  std::size_t fresh_casts = 0;
  for (int search = 0; search < 30; ++search) {
    SCOPED_TRACE("search " + std::to_string(search));
    if (search % 7 == 6) {  // a closure moved the scans
      for (SubmapScan& s : pool) s.pose.x += 0.01 * rng.uniform(-1.0, 1.0);
    }
    const std::size_t first = static_cast<std::size_t>(search) % 25;
    std::vector<SubmapScan> scans(pool.begin() + static_cast<std::ptrdiff_t>(first),
                                  pool.begin() + static_cast<std::ptrdiff_t>(first + 15));
    std::swap(scans[0], scans[9]);  // the order of the nearest-first list changes too
    GridMap fresh(config);
    for (const SubmapScan& s : scans) update_map(fresh, *s.points, s.pose, update, false, false);
    fresh.commit_update();
    fresh_casts += scans.size();
    const GridMap& cached = cache.build(scans, config, update);
    expect_same_cells(cached, fresh);
    if (HasFatalFailure()) return;
    // The fitness the loop-closure search reads, at some poses and on the coarse level.
    for (int level : {0, 2}) {
      const FitnessOptions options{.level = level};
      const FitnessEvaluator ec(cached, *pool[first + 3].points, options);
      const FitnessEvaluator ef(fresh, *pool[first + 3].points, options);
      for (int j = 0; j < 5; ++j) {
        const Pose2 p{rng.uniform(0.0, 12.0), rng.uniform(0.0, 8.0), rng.uniform(-3.0, 3.0)};
        EXPECT_EQ(ec.evaluate(p).fitness, ef.evaluate(p).fitness);
      }
    }
  }
  EXPECT_LT(cache.scans_cast(), fresh_casts / 3) << "the cache should save most ray-casting";
}

TEST(SubmapCache, LoopClosureFindsTheSameMatchWithAndWithoutIt) {
  const Scene scene = old_keys();
  const Pose2 truth{6.1, 4.3, 0.25};
  const ScanPoints current = prepare_scan(make_scan(asymmetric_room(), truth));
  const LoopClosureConfig config;
  SubmapCache cache;
  for (const Pose2 drifted : {Pose2{truth.x + 0.35, truth.y - 0.25, truth.theta + 0.05},
                              Pose2{truth.x - 0.2, truth.y + 0.1, truth.theta - 0.03}}) {
    const auto plain = find_loop_closure(scene.keys, scene.poses, current, drifted, 40.0, config,
                                         GridMapConfig{}, MapUpdateConfig{}, FitnessOptions{});
    const auto cached =
        find_loop_closure(scene.keys, scene.poses, current, drifted, 40.0, config, GridMapConfig{},
                          MapUpdateConfig{}, FitnessOptions{}, &cache);
    ASSERT_TRUE(plain.has_value());
    ASSERT_TRUE(cached.has_value());
    EXPECT_EQ(plain->pose, cached->pose);
    EXPECT_EQ(plain->value.fitness, cached->value.fitness);
    EXPECT_EQ(plain->anchor, cached->anchor);
  }
  // The second search reused the first one's submap: 6 scans cast, not 12.
  EXPECT_EQ(cache.scans_cast(), scene.keys.size());
}

}  // namespace
}  // namespace esfleet
