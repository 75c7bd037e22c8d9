// The branch-and-bound window search against scoring every candidate: the same best candidate
// (lowest index of the highest score) and the same rival score, bit for bit, on maps made from
// a synthetic world, for seeded random scans, windows, headings and both fitness conditions;
// with a rival ratio, the same answer to whether the rival is within it.

#include "esfleet/core/window_search.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "esfleet/core/random.hpp"
#include "synthetic_world.hpp"

namespace esfleet {
namespace {

using testing::asymmetric_room;
using testing::make_scan;
using testing::map_of;

/// The reference: every candidate scored, the first of the highest score, the rival over all.
std::optional<WindowMatch> search_window_brute_force(const GridMap& map, const ScanPoints& points,
                                                     const FitnessOptions& options,
                                                     const SearchWindow& w, double rival_distance) {
  HeadingScorer scorer(map, points, options);
  std::vector<float> scored;
  std::vector<Pose2> poses;
  for (int it = -w.n_theta; it <= w.n_theta; ++it) {
    const double theta = normalize_angle(w.centre.theta + it * w.step_theta);
    scorer.set_heading(theta);
    for (int iy = -w.n_xy; iy <= w.n_xy; ++iy) {
      for (int ix = -w.n_xy; ix <= w.n_xy; ++ix) {
        const Pose2 p{w.centre.x + ix * w.step_xy, w.centre.y + iy * w.step_xy, theta};
        scored.push_back(scorer.evaluate(p.x, p.y).fitness);
        poses.push_back(p);
      }
    }
  }
  const auto best_it = std::max_element(scored.begin(), scored.end());
  if (best_it == scored.end() || !(*best_it > 0.0f)) return std::nullopt;
  WindowMatch m;
  m.score = *best_it;
  m.index = static_cast<std::size_t>(best_it - scored.begin());
  m.pose = poses[m.index];
  for (std::size_t i = 0; i < scored.size(); ++i) {
    const Pose2& c = poses[i];
    if (std::hypot(c.x - m.pose.x, c.y - m.pose.y) > rival_distance) {
      m.rival = std::max(m.rival, scored[i]);
    }
  }
  m.scored = scored.size();
  return m;
}

void expect_same(const std::optional<WindowMatch>& bb, const std::optional<WindowMatch>& brute,
                 std::uint64_t seed) {
  ASSERT_EQ(bb.has_value(), brute.has_value()) << "seed " << seed;
  if (!bb) return;
  EXPECT_EQ(bb->index, brute->index) << "seed " << seed;
  EXPECT_EQ(bb->score, brute->score) << "seed " << seed;
  EXPECT_EQ(bb->rival, brute->rival) << "seed " << seed;
  EXPECT_EQ(bb->pose.x, brute->pose.x) << "seed " << seed;
  EXPECT_EQ(bb->pose.theta, brute->pose.theta) << "seed " << seed;
}

/// A scan of `world` from a random pose, a window around a pose near it, the coarse level
/// as the loop closure scores it; penalty and rival distance vary with `variant`.
struct Scene {
  ScanPoints points;
  SearchWindow w;
  FitnessOptions o;
  double rival_distance;
};
Scene random_scene(const std::vector<testing::Segment>& world, std::uint64_t rng_seed,
                   std::uint64_t variant) {
  Rng rng(rng_seed);
  Scene s;
  const Pose2 truth{1.0 + 10.0 * rng.uniform(), 1.0 + 6.0 * rng.uniform(),
                    (2.0 * rng.uniform() - 1.0) * std::numbers::pi};
  s.points = prepare_scan(make_scan(world, truth));
  s.w.centre = {truth.x + rng.uniform() - 0.5, truth.y + rng.uniform() - 0.5,
                truth.theta + 0.2 * (rng.uniform() - 0.5)};
  s.w.step_xy = 0.1;
  s.w.step_theta = std::atan2(0.2, 10.0);
  s.w.n_xy = 5 + static_cast<int>(rng.uniform() * 30);
  s.w.n_theta = 2 + static_cast<int>(rng.uniform() * 10);
  s.o.level = 2;
  s.o.stride = 2;
  s.o.use_penalty = variant % 2 == 0;
  s.rival_distance = variant % 3 == 0 ? 0.3 : 1.0;
  return s;
}

TEST(WindowSearch, BranchAndBoundEqualsBruteForce) {
  const auto world = asymmetric_room();
  const GridMap map = map_of(world, 12.0, 8.0);
  std::size_t scored = 0, total = 0;
  for (std::uint64_t seed = 1; seed <= 24; ++seed) {
    const auto [points, w, o, rival_distance] = random_scene(world, seed, seed);
    const auto bb = search_window(map, points, o, w, rival_distance);
    const auto brute = search_window_brute_force(map, points, o, w, rival_distance);
    expect_same(bb, brute, seed);
    ASSERT_TRUE(bb.has_value()) << "seed " << seed;
    scored += bb->scored;
    total += brute->scored;
  }
  // It prunes: most candidates are never scored.
  EXPECT_LT(scored * 4, total);
}

TEST(WindowSearch, ARivalRatioDecidesAsTheExactRivalWithLessWork) {
  // As a loop closure asks it: is the rival within a ratio of the best? The best is the same;
  // rival / score exceeds the ratio exactly when the brute-force rival's does, and the rival
  // reported is a score of the candidates that far (at most the brute-force rival).
  const auto world = asymmetric_room();
  const GridMap map = map_of(world, 12.0, 8.0);
  std::size_t work_ratio = 0, work_exact = 0, beyond = 0, within = 0;
  for (std::uint64_t seed = 1; seed <= 24; ++seed) {
    const auto [points, w, o, rival_distance] = random_scene(world, seed + 1000, seed);
    const auto exact = search_window(map, points, o, w, rival_distance);
    const auto brute = search_window_brute_force(map, points, o, w, rival_distance);
    ASSERT_TRUE(brute.has_value()) << "seed " << seed;
    const double brute_ratio = static_cast<double>(brute->rival) / brute->score;
    // Ratios on both sides of this scene's, and at it (the boundary: not beyond).
    for (const double ratio : {0.3, 0.7, 0.9, brute_ratio, brute_ratio * 0.999}) {
      const auto bb = search_window(map, points, o, w, rival_distance, ratio);
      ASSERT_TRUE(bb.has_value()) << "seed " << seed << " ratio " << ratio;
      EXPECT_EQ(bb->index, brute->index) << "seed " << seed << " ratio " << ratio;
      EXPECT_EQ(bb->score, brute->score) << "seed " << seed << " ratio " << ratio;
      const bool is_beyond = static_cast<double>(bb->rival) / bb->score > ratio;
      EXPECT_EQ(is_beyond, brute_ratio > ratio) << "seed " << seed << " ratio " << ratio;
      EXPECT_LE(bb->rival, brute->rival) << "seed " << seed << " ratio " << ratio;
      (is_beyond ? beyond : within) += 1;
      work_ratio += bb->scored + bb->bounded;
      work_exact += exact->scored + exact->bounded;
    }
  }
  // Both answers occur, and the ratio saves work (most of the rival's search).
  EXPECT_GT(beyond, 10U);
  EXPECT_GT(within, 10U);
  EXPECT_LT(work_ratio * 10, work_exact * 9);
}

TEST(WindowSearch, TiesGoToTheLowestIndexAndNothingScoresOffTheMap) {
  // A map of one wall seen from far: many poses put the same few points on it.
  GridMapConfig c;
  c.pyramid_levels = 2;
  GridMap map(c);
  const std::vector<testing::Segment> wall{{0, 0, 0, 20}};
  for (int i = 0; i < 10; ++i) {
    const Pose2 p{5.0, 2.0 + i, std::numbers::pi};
    update_map(map, prepare_scan(make_scan(wall, p)), p, MapUpdateConfig{});
  }
  map.commit_update();
  const Pose2 at{5.0, 10.0, std::numbers::pi};
  const ScanPoints points = prepare_scan(make_scan(wall, at));
  FitnessOptions o;
  o.level = 2;
  o.stride = 2;
  SearchWindow w{at, 0.1, std::atan2(0.2, 10.0), 20, 4};
  // The search scores the centre first; where it ties with candidates of lower index, the
  // lowest still wins. Centres moved along the wall (some off its grid of steps, some turned
  // by a step) make such ties.
  int centre_ties = 0;
  for (int k = -10; k <= 10; ++k) {
    const double dy = 0.1 * k + 0.03 * (k % 3);
    w.centre = {at.x, at.y + dy, at.theta - (k % 2) * w.step_theta};
    for (const bool penalty : {true, false}) {
      o.use_penalty = penalty;
      const auto brute = search_window_brute_force(map, points, o, w, 1.0);
      expect_same(search_window(map, points, o, w, 1.0), brute, penalty);
      ASSERT_TRUE(brute.has_value());
      HeadingScorer scorer(map, points, o);
      for (int it = -w.n_theta; it <= w.n_theta; ++it) {
        scorer.set_heading(normalize_angle(w.centre.theta + it * w.step_theta));
        const std::size_t centre_index = static_cast<std::size_t>(
            ((it + w.n_theta) * (2 * w.n_xy + 1) + w.n_xy) * (2 * w.n_xy + 1) + w.n_xy);
        if (scorer.evaluate(w.centre.x, w.centre.y).fitness == brute->score &&
            centre_index > brute->index) {
          ++centre_ties;
        }
      }
    }
  }
  EXPECT_GT(centre_ties, 0) << "no centre tied with a candidate of lower index";
  w.centre = at;
  // Far from every known cell: no candidate scores.
  w.centre = {500.0, 500.0, 0.0};
  EXPECT_FALSE(search_window(map, points, o, w, 1.0).has_value());
  EXPECT_FALSE(search_window_brute_force(map, points, o, w, 1.0).has_value());
}

}  // namespace
}  // namespace esfleet
