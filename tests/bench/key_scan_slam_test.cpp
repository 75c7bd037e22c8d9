// The SLAM on the CSAIL key-scan log (data/mit-csail/csail-corrected.log.gz: 406 scans 0.6-1.0 m
// and up to 78 degrees apart), laser only, given its scans as esfleet-bench generalise gives them.
// Each step is scored against the log's corrected poses (evaluation only).

#include <gtest/gtest.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <numeric>
#include <string>
#include <vector>

#include "esfleet/core/slam.hpp"
#include "generalise_data.hpp"

namespace esfleet::bench {
namespace {

// One run of the SLAM over the first key scans, as esfleet-bench generalise gives them.
struct KeyScanRun {
  std::uint64_t seed = 1;
  std::size_t beam_step = 1;  ///< every beam_step-th beam kept
  GeneraliseMode mode = GeneraliseMode::kLaserOnly;
  float max_range = 0.0f;     ///< tracking.max_range (0 = all beams)
  std::size_t first = 366;    ///< the first key scan whose step is checked
  std::size_t last = 375;     ///< the run ends at this key scan
  double max_error_xy = 0.3;  ///< metres, each checked step against the reference's
  double max_error_deg = 10.0;
  RecoveryConfig recovery{};
};

// Each step of `run` from key scan `first` to `last` must be within max_error_xy and
// max_error_deg of the reference's.
void expect_tracked_through(const KeyScanRun& run) {
  const std::string dir = std::string(ESFLEET_DATA_DIR) + "/mit-csail/";
  const std::vector<LaserScan> raw = read_carmen_log(dir + "mit-csail.clf.gz", {});
  const std::vector<LaserScan> keys = read_carmen_log(dir + "csail-corrected.log.gz", {});
  const GeneraliseLog log = make_key_scan_log(keys, raw, {}, "keys", "raw");
  std::vector<std::size_t> kept(run.last + 1);
  std::iota(kept.begin(), kept.end(), std::size_t{0});
  std::vector<LaserScan> scans = slam_input(log, kept, run.mode, OdometryNoise{}, run.seed);
  for (LaserScan& scan : scans) scan = keep_every_beam(std::move(scan), run.beam_step);
  SlamConfig config;
  config.seed = run.seed;
  config.tracking.use_odometry = run.mode == GeneraliseMode::kNoisyOdometry;
  config.tracking.max_range = run.max_range;
  config.recovery = run.recovery;
  Slam slam(config);
  for (const LaserScan& scan : scans) slam.process(scan);
  const std::vector<TimedPose>& path = slam.trajectory();
  ASSERT_EQ(path.size(), run.last + 1);
  for (std::size_t i = run.first - 1; i < run.last; ++i) {
    const Pose2 truth = log.reference[i + 1]->relative_to(*log.reference[i]);
    const Pose2 step = path[i + 1].pose.relative_to(path[i].pose);
    const Pose2 error = step.relative_to(truth);
    EXPECT_LT(std::hypot(error.x, error.y), run.max_error_xy)
        << "key scan " << i + 1 << ", seed " << run.seed;
    EXPECT_LT(std::abs(rad_to_deg(normalize_angle(error.theta))), run.max_error_deg)
        << "key scan " << i + 1 << ", seed " << run.seed;
  }
}

// Key scans 369-373: the robot drives a metre per scan into a room it has not seen, turning
// 15-44 degrees, and half of each scan's end points fall on unknown cells. At key scan 370 the
// recovery search's max-pooled coarse stage ranked poses that put end points near the walls
// behind it above the true pose (its 16th distinct pose, seed 4). Refining only the best 8,
// none consistent with the map, the run kept a tracked pose turned by 96 degrees and wrote the
// rest of the log rotated (RecoveryConfig::more_candidates).
TEST(KeyScanSlam, ARoomEnteredAtAMetrePerScanIsTrackedThrough) {
  expect_tracked_through({.seed = 4});
}

// The same with a 1 degree laser (every other beam), seed 7: there the true pose was the 33rd
// distinct coarse pose, and refining up to 32 took one 1.9 m off.
TEST(KeyScanSlam, ARoomEnteredAtAMetrePerScanIsTrackedThroughWithAOneDegreeLaser) {
  expect_tracked_through({.seed = 7, .beam_step = 2});
}

// With noisy wheel odometry and an 8 m laser, seed 3: by key scan 217 the map of the loop since
// key scan 122 has drifted, the tracked pose matches weakly, and the recovery search (centred
// on the previous heading, +-90 degrees) took a pose turned 88 degrees from the odometry's,
// which the rest of the log was written from. Bounded by what odometry can be off by
// (RecoveryConfig::odometry_window_*), it keeps the odometry's heading; the step into the
// drifted map is 0.45 m off the reference's (1.40 m before, and 0.86 m at key scan 222).
TEST(KeyScanSlam, WithOdometryTheRecoveryStaysWithinWhatOdometryCanBeOffBy) {
  expect_tracked_through({.seed = 3,
                          .mode = GeneraliseMode::kNoisyOdometry,
                          .max_range = 8.0,
                          .first = 212,
                          .last = 222,
                          .max_error_xy = 0.6});
}

}  // namespace
}  // namespace esfleet::bench
