// The SLAM on simulated scans with their true poses: a robot in the MIT CSAIL world (the
// esfleet-sim model) scanning once a second at up to 1 m/s, laser only. Its first motion is a
// turn in place toward its first goal, 60 degrees in one scan, that the prediction (no motion
// seen yet) misses; the scan after it looks mostly into space the first scan did not see.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "esfleet/core/slam.hpp"
#include "esfleet/sim/fleet.hpp"
#include "esfleet/sim/world.hpp"

namespace esfleet::sim {
namespace {

struct Errors {
  double worst_xy = 0.0;         ///< metres, over the first `scans` poses
  double worst_theta_deg = 0.0;  ///< degrees
  double first_turn_deg = 0.0;   ///< the true turn between the first two scans
};

/// Simulation seed 1 (its robot turns before it drives), `scans` scans at 1 Hz, the SLAM with
/// `min_hits` and SLAM seed `seed`; errors of the poses relative to the first one.
Errors run(const World& world, double min_hits, std::uint64_t seed, int scans) {
  FleetConfig fc;
  fc.seed = 1;
  fc.rate = 1.0;
  fc.motion.speed = 1.0;
  Fleet fleet(world, fc);
  SlamConfig config;
  config.seed = seed;
  config.tracking.use_odometry = false;
  config.recovery.min_hits = min_hits;
  Slam slam(config);
  Errors r;
  Pose2 first_truth;
  for (int i = 0; i < scans; ++i) {
    const RobotSample& s = fleet.tick().front();
    LaserScan scan = s.scan;
    scan.odometry.reset();  // laser only
    const SlamStep step = slam.process(scan);
    if (i == 0) first_truth = s.truth.pose;
    const Pose2 truth = s.truth.pose.relative_to(first_truth);
    if (i == 1) r.first_turn_deg = rad_to_deg(truth.theta);
    r.worst_xy = std::max(r.worst_xy, std::hypot(step.pose.x - truth.x, step.pose.y - truth.y));
    r.worst_theta_deg = std::max(
        r.worst_theta_deg, std::abs(rad_to_deg(normalize_angle(step.pose.theta - truth.theta))));
  }
  return r;
}

TEST(SlamOnSim, AMissedTurnInPlaceIntoNewSpaceIsFound) {
  const World world = load_world(std::string(ESFLEET_DATA_DIR) + "/worlds/mit-csail/map.yaml");
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    const Errors with = run(world, SlamConfig{}.recovery.min_hits, seed, 12);
    // The premise: a large turn in place first (the simulation's, not the SLAM's).
    EXPECT_GT(std::abs(with.first_turn_deg), 45.0) << "seed " << seed;
    EXPECT_LT(with.worst_xy, 0.1) << "seed " << seed;
    EXPECT_LT(with.worst_theta_deg, 2.0) << "seed " << seed;
    // Without it the recovery found the turn but refused it: 21 % of that scan's end points
    // fall on observed cells, fewer than the 30 % asked of a recovered pose.
    const Errors without = run(world, 0.0, seed, 12);
    EXPECT_GT(without.worst_theta_deg, 20.0) << "seed " << seed;
  }
}

}  // namespace
}  // namespace esfleet::sim
