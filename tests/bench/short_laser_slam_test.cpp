// The SLAM on the MIT CSAIL log with a short laser (beams of 8 m and beyond ignored) and noisy
// wheel odometry, given its scans as esfleet-bench generalise gives them; scored on the log's
// Kümmerle relations (evaluation only).

#include <gtest/gtest.h>

#include <cstddef>
#include <cstdint>
#include <numeric>
#include <string>
#include <vector>

#include "esfleet/core/relations.hpp"
#include "esfleet/core/slam.hpp"
#include "generalise_data.hpp"

namespace esfleet::bench {
namespace {

// An 8 m laser sees no end of CSAIL's corridors. With seed 4 the scans in the corridor of raw
// scans 1535-1545 slid up to 0.66 m against the odometry over half a metre of driving, towards
// where the map of an earlier pass (raw scans 622-634), drifted by then, pulled them, and the
// revisit was written about 3 m off (relations mean 0.185 m over the whole log). The short
// laser's hold (SlamConfig::short_view_motion_hold) keeps those steps on the odometry.
TEST(ShortLaserSlam, ACorridorPastTheLasersRangeFollowsTheOdometry) {
  const std::string dir = std::string(ESFLEET_DATA_DIR) + "/mit-csail/";
  GeneraliseLog log;
  log.scans = read_carmen_log(dir + "mit-csail.clf.gz", {});
  constexpr std::size_t kScans = 1620;  // past the corridor and the revisit
  ASSERT_GT(log.scans.size(), kScans);
  std::vector<std::size_t> kept(kScans);
  std::iota(kept.begin(), kept.end(), std::size_t{0});
  constexpr std::uint64_t kSeed = 4;
  const std::vector<LaserScan> scans =
      slam_input(log, kept, GeneraliseMode::kNoisyOdometry, OdometryNoise{}, kSeed);
  SlamConfig config;
  config.seed = kSeed;
  config.tracking.use_odometry = true;
  config.tracking.max_range = 8.0f;
  Slam slam(config);
  for (const LaserScan& scan : scans) slam.process(scan);
  const RelationsResult r =
      evaluate_relations(slam.trajectory(), read_relations(dir + "mit-csail.relations"));
  ASSERT_GT(r.matched, 900u);
  EXPECT_LT(r.trans_mean, 0.05) << "seed " << kSeed;
  EXPECT_EQ(r.outliers, 0u) << "seed " << kSeed << ", worst " << r.trans_max << " m";
}

}  // namespace
}  // namespace esfleet::bench
