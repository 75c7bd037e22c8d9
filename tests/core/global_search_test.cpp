// The localiser's global grid search on scans ray-cast in a synthetic room: what its coarse
// stage scores and keeps.

#include "esfleet/core/global_search.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "synthetic_world.hpp"

namespace esfleet {
namespace {

using testing::asymmetric_room;
using testing::make_scan;
using testing::map_of;

/// The stages of the grid search for `scan` in `map` (no hint), as a localiser with seed 2
/// runs it on its first scan.
SearchStages grid_search_stages(const GlobalSearchConfig& c, const GridMap& map,
                                const LaserScan& scan) {
  const TrackingConfig tracking;
  const GlobalSearch search(c, tracking);
  Rng rng(2);
  SearchStages stages;
  search.run(map, prepare_scan(scan, tracking.min_range, tracking.max_range), nullptr,
             GlobalSearchMethod::kGrid, rng, &stages);
  return stages;
}

TEST(GlobalSearch, TheCoarseScoreIsThePenalisedFitnessOrTheSumOfMapValues) {
  const auto world = asymmetric_room();
  const GridMap map = map_of(world, 12, 8);
  const LaserScan scan = make_scan(world, {2.0, 1.5, 0.3});
  for (const bool penalty : {true, false}) {
    GlobalSearchConfig c;
    c.coarse_score = penalty ? CoarseScore::kFitness : CoarseScore::kSum;
    const SearchStages st = grid_search_stages(c, map, scan);
    ASSERT_FALSE(st.samples.empty());
    const ScanPoints pts = prepare_scan(scan);
    // Each sample's score is the fitness (Condition 1 or 2) on the coarse level at the heading
    // recorded for it.
    FitnessOptions o;
    o.use_penalty = penalty;
    o.level = c.coarse_level;
    o.stride = std::max(1, static_cast<int>(pts.size()) / c.coarse_points);
    EXPECT_EQ(st.coarse_options.use_penalty, o.use_penalty);
    EXPECT_EQ(st.coarse_options.level, o.level);
    EXPECT_EQ(st.coarse_options.stride, o.stride);
    const FitnessEvaluator coarse(map, pts, o);
    o.use_penalty = !penalty;
    const FitnessEvaluator other(map, pts, o);
    int differ = 0;
    for (std::size_t i = 0; i < st.samples.size(); ++i) {
      EXPECT_FLOAT_EQ(st.sample_score[i], coarse.fitness(st.samples[i])) << "sample " << i;
      differ += other.fitness(st.samples[i]) != st.sample_score[i];
    }
    EXPECT_GT(differ, 0) << "penalty " << penalty << ": p_occ was 1 everywhere";
  }
}

TEST(GlobalSearch, CoarseScoreBothKeepsTheBestPosesOfEachRanking) {
  const auto world = asymmetric_room();
  const GridMap map = map_of(world, 12, 8);
  const LaserScan scan = make_scan(world, {2.0, 1.5, 0.3});
  auto coarse_of = [&](CoarseScore by) {
    GlobalSearchConfig c;
    c.coarse_keep = 40;  // fewer than the room's distinct coarse poses: the rankings differ
    c.coarse_score = by;
    return grid_search_stages(c, map, scan).coarse;
  };
  const std::vector<Pose2> fit = coarse_of(CoarseScore::kFitness);
  const std::vector<Pose2> sum = coarse_of(CoarseScore::kSum);
  const std::vector<Pose2> both = coarse_of(CoarseScore::kBoth);
  ASSERT_EQ(fit.size(), 40u);
  ASSERT_EQ(sum.size(), 40u);
  auto same = [](const Pose2& a, const Pose2& b) {
    return a.x == b.x && a.y == b.y && a.theta == b.theta;
  };
  auto count_in = [&](const std::vector<Pose2>& of, const std::vector<Pose2>& in) {
    return std::count_if(of.begin(), of.end(), [&](const Pose2& p) {
      return std::any_of(in.begin(), in.end(), [&](const Pose2& q) { return same(p, q); });
    });
  };
  EXPECT_LT(count_in(sum, fit), 40) << "the two rankings kept the same poses";
  // The fitness ranking's poses first, then the sum's best 40 not already near one of them.
  ASSERT_GT(both.size(), fit.size());
  EXPECT_LE(both.size(), 80u);
  for (std::size_t i = 0; i < fit.size(); ++i) EXPECT_TRUE(same(both[i], fit[i])) << i;
  EXPECT_EQ(count_in(both, fit), 40);
  // Each of the sum ranking's poses is kept, or lies beside a kept pose (the coarse poses'
  // spacing: twice the 0.3 m sample step and distinct_theta_deg, 10 degrees).
  const long beside = std::count_if(sum.begin(), sum.end(), [&](const Pose2& p) {
    return std::any_of(both.begin(), both.end(), [&](const Pose2& q) {
      return std::hypot(p.x - q.x, p.y - q.y) < 0.6 + 1e-9 &&
             std::abs(normalize_angle(p.theta - q.theta)) < deg_to_rad(10.0) + 1e-9;
    });
  });
  EXPECT_GE(beside, 38) << "of 40";
}

}  // namespace
}  // namespace esfleet
