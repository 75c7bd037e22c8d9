// The per-scan tracking step shared by the leader's SLAM and the follower's localiser: the
// motion prediction and its hypotheses, and the search that finds a scan's true pose in a map
// from a perturbed start (seeded; a failure names its seed).

#include "esfleet/core/tracking.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <random>

#include "esfleet/core/localiser.hpp"
#include "esfleet/core/map_update.hpp"
#include "esfleet/core/slam.hpp"
#include "synthetic_world.hpp"

namespace esfleet {
namespace {

using testing::asymmetric_room;
using testing::make_scan;

MotionState moving(const Pose2& before, const Pose2& last, double dt = 0.2) {
  MotionState m;
  m.previous = TimedPose{0.0, before};
  m.last = TimedPose{dt, last};
  return m;
}

LaserScan scan_at(double stamp) {
  LaserScan s;
  s.stamp = stamp;
  return s;
}

TEST(PredictPose, ConstantVelocityRepeatsTheLastMotionScaledByTime) {
  TrackingConfig c;
  const MotionState m = moving({0, 0, 0}, {0.1, 0, 0.05});
  const Pose2 p = predict_pose(c, m, scan_at(0.4), nullptr);  // same interval again
  EXPECT_NEAR(p.x, 0.1 + 0.1 * std::cos(0.05), 1e-9);
  EXPECT_NEAR(p.y, 0.1 * std::sin(0.05), 1e-9);
  EXPECT_NEAR(p.theta, 0.1, 1e-9);
  // Twice the interval: twice the motion.
  const Pose2 q = predict_pose(c, m, scan_at(0.6), nullptr);
  EXPECT_NEAR(q.theta, 0.15, 1e-9);
}

TEST(PredictPose, ThePapersPreviousPoseAndTheFirstScanStayPut) {
  TrackingConfig c;
  c.prediction = MotionPrediction::kPreviousPose;
  EXPECT_EQ(predict_pose(c, moving({0, 0, 0}, {0.1, 0, 0}), scan_at(0.4), nullptr),
            (Pose2{0.1, 0, 0}));
  TrackingConfig v;  // constant velocity, but nothing before the last pose
  MotionState first;
  first.last = TimedPose{0.0, {1, 2, 3}};
  EXPECT_EQ(predict_pose(v, first, scan_at(0.2), nullptr), (Pose2{1, 2, 3}));
}

TEST(PredictPose, OdometryWhenOnAndPresentAndThePreviousPoseIsThenNoHypothesis) {
  TrackingConfig c;
  c.use_odometry = true;
  MotionState m = moving({0, 0, 0}, {1, 1, 0});
  m.odometry = Pose2{10, 10, 0};
  LaserScan s = scan_at(0.4);
  s.odometry = Pose2{10.5, 10, 0};  // 0.5 m forward since the last scan
  std::vector<Pose2> alternatives;
  const Pose2 p = predict_pose(c, m, s, &alternatives);
  EXPECT_NEAR(p.x, 1.5, 1e-9);
  EXPECT_NEAR(p.y, 1.0, 1e-9);
  for (const Pose2& a : alternatives) EXPECT_FALSE(a == m.last.pose);
  // Without odometry in the scan it falls back to constant velocity.
  const Pose2 q = predict_pose(c, m, scan_at(0.4), nullptr);
  EXPECT_NEAR(q.x, 2.0, 1e-9);
}

TEST(PredictPose, TurningAddsTurnHypothesesUnlessSwitchedOff) {
  TrackingConfig c;
  const MotionState m = moving({0, 0, 0}, {0.1, 0, deg_to_rad(5)});
  std::vector<Pose2> with, without;
  (void)predict_pose(c, m, scan_at(0.4), &with);
  c.turn_hypotheses = false;
  (void)predict_pose(c, m, scan_at(0.4), &without);
  EXPECT_EQ(with.size(), without.size() + 4);  // +-1 and +-2 times the last turn
  EXPECT_EQ(without.front(), m.last.pose);     // laser only: the previous pose is one
}

TEST(TrackScan, FindsTheTruePoseFromAPerturbedPrediction) {
  const auto world = asymmetric_room();
  const GridMap map = testing::map_of(world, 12, 8);
  TrackingConfig c;
  const EvolutionStrategy es(c.es);
  for (unsigned seed = 1; seed <= 5; ++seed) {
    std::mt19937 gen(seed);
    std::uniform_real_distribution<double> x(2.0, 10.0), y(1.5, 6.5), th(-3.1, 3.1);
    std::normal_distribution<double> off_xy(0.0, 0.08), off_th(0.0, deg_to_rad(3.0));
    const Pose2 truth{x(gen), y(gen), th(gen)};
    // The prediction (the last pose, no motion) is off by a few centimetres and degrees.
    MotionState m;
    m.last = TimedPose{
        0.0,
        {truth.x + off_xy(gen), truth.y + off_xy(gen), normalize_angle(truth.theta + off_th(gen))}};
    const LaserScan scan = make_scan(world, truth, 0.2);
    Rng rng(seed);
    const TrackResult r = track_scan(c, es, rng, map, prepare_scan(scan), scan, m);
    EXPECT_EQ(r.predicted, m.last.pose) << "seed " << seed;
    EXPECT_LT(std::hypot(r.result.pose.x - truth.x, r.result.pose.y - truth.y), 0.05)  // a cell
        << "seed " << seed;
    EXPECT_LT(std::abs(normalize_angle(r.result.pose.theta - truth.theta)), deg_to_rad(1.0))
        << "seed " << seed;
    EXPECT_GT(r.result.value.agreement(), 0.9f) << "seed " << seed;
  }
}

TEST(TrackScan, TheSameSeedGivesTheSamePose) {
  const auto world = asymmetric_room();
  const GridMap map = testing::map_of(world, 12, 8);
  const TrackingConfig c;
  const EvolutionStrategy es(c.es);
  MotionState m;
  m.last = TimedPose{0.0, {5.05, 3.0, 0.4}};
  const LaserScan scan = make_scan(world, {5.0, 3.0, 0.42}, 0.2);
  Rng a(7), b(7);
  const TrackResult ra = track_scan(c, es, a, map, prepare_scan(scan), scan, m);
  const TrackResult rb = track_scan(c, es, b, map, prepare_scan(scan), scan, m);
  EXPECT_EQ(ra.result.pose, rb.result.pose);
}

TEST(TrackingConfig, ValidationNamesTheField) {
  TrackingConfig c;
  c.init_sigma_xy = -1.0;
  try {
    c.validate();
    FAIL() << "accepted a negative spread";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("init_sigma_xy"), std::string::npos) << e.what();
  }
  for (const double bad : {-0.1, std::nan(""), std::numeric_limits<double>::infinity()}) {
    TrackingConfig s;
    s.search_point_spacing = bad;
    try {
      s.validate();
      FAIL() << "accepted search_point_spacing " << bad;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("search_point_spacing"), std::string::npos) << e.what();
    }
  }
}

TEST(TrackScan, TheSearchScoresThinnedPointsAndReportsEveryOne) {
  // The paper's ES scores every end point; the default only those 0.1 m apart, and still
  // reports the fitness terms over all of them.
  EXPECT_EQ(SlamConfig::paper().tracking.search_point_spacing, 0.0);
  EXPECT_GT(TrackingConfig{}.search_point_spacing, 0.0);
  const auto world = asymmetric_room();
  const GridMap map = testing::map_of(world, 12, 8);
  const Pose2 truth{5.0, 3.0, 0.42};
  const LaserScan scan = make_scan(world, truth, 0.2);
  const ScanPoints points = prepare_scan(scan);
  ASSERT_LT(thin_scan(points, 0.1).size(), points.size() - 20);  // it thins here: 139 of 181
  MotionState m;
  m.last = TimedPose{0.0, {5.04, 2.97, 0.40}};
  for (const double spacing : {0.0, 0.1}) {
    TrackingConfig c;
    c.search_point_spacing = spacing;
    c.refine = false;  // the value then comes from the search itself
    const EvolutionStrategy es(c.es);
    Rng rng(3);
    const TrackResult r = track_scan(c, es, rng, map, points, scan, m);
    EXPECT_EQ(static_cast<std::size_t>(r.result.value.n_points), points.size())
        << "spacing " << spacing;
    EXPECT_LT(std::hypot(r.result.pose.x - truth.x, r.result.pose.y - truth.y), 0.05)
        << "spacing " << spacing;
    EXPECT_LT(std::abs(normalize_angle(r.result.pose.theta - truth.theta)), deg_to_rad(1.0))
        << "spacing " << spacing;
  }
}

/// A straight corridor 2 m wide and 200 m long, its ends beyond the scans' 30 m reach: a scan
/// fits equally well anywhere along it.
std::vector<testing::Segment> corridor() { return {{-100, 0, 100, 0}, {-100, 2, 100, 2}}; }

GridMap corridor_map() {
  GridMapConfig c;
  c.pyramid_levels = 3;
  GridMap map(c);
  for (double x = 0.0; x <= 40.0; x += 0.5) {
    for (const double y : {0.6, 1.0, 1.4}) {
      const Pose2 p{x, y, 0.0};
      update_map(map, prepare_scan(make_scan(corridor(), p)), p, MapUpdateConfig{});
    }
  }
  return map;
}

TEST(TrackScan, MotionHoldTakesTheCorridorPositionFromTheMotion) {
  // The robot drives at 0.3 m per scan (constant velocity predicts x = 20.3); the scan is
  // taken at x = 20.2 but cannot tell. With the hold the pose along the corridor is the
  // prediction's, exactly, and across it (y) the scan's. The motion prior is off: it would
  // pull the search towards the prediction too, and this is about the hold alone (without it
  // the search ends wherever its draws went, 0.06-0.09 m from the prediction for these seeds).
  const GridMap map = corridor_map();
  const Pose2 truth{20.2, 1.1, 0.0};
  const LaserScan scan = make_scan(corridor(), truth, 0.4);
  const MotionState m = moving({19.7, 1.0, 0.0}, {20.0, 1.0, 0.0});
  for (unsigned seed = 1; seed <= 5; ++seed) {
    TrackingConfig c;
    c.prior_sigma_xy = 0.0;
    c.motion_hold = 0.02;
    const EvolutionStrategy es(c.es);
    Rng rng(seed);
    const TrackResult r = track_scan(c, es, rng, map, prepare_scan(scan), scan, m);
    EXPECT_NEAR(r.predicted.x, 20.3, 1e-9);
    EXPECT_NEAR(r.result.pose.x, 20.3, 0.005) << "seed " << seed;
    EXPECT_NEAR(r.result.pose.y, truth.y, 0.03) << "seed " << seed;
    EXPECT_LT(std::abs(r.result.pose.theta), deg_to_rad(1.0)) << "seed " << seed;
    EXPECT_GT(r.result.value.agreement(), 0.9f) << "seed " << seed;
  }
}

TEST(TrackScan, MotionHoldLeavesAPoseTheMapConstrains) {
  // In a room every direction is constrained: a prediction 8 cm off is not taken, whether the
  // hold applies only where one direction is much flatter (the default ratio) or everywhere.
  const auto world = asymmetric_room();
  const GridMap map = testing::map_of(world, 12, 8);
  const Pose2 truth{5.0, 3.0, 0.42};
  const LaserScan scan = make_scan(world, truth, 0.4);
  // Constant velocity predicts truth + 8 cm along x.
  const MotionState m = moving({4.68, 3.0, 0.42}, {4.88, 3.0, 0.42});
  for (const double ratio : {TrackingConfig{}.motion_hold_ratio, 1.0}) {
    TrackingConfig c;
    c.motion_hold = 0.02;
    c.motion_hold_ratio = ratio;
    const EvolutionStrategy es(c.es);
    for (unsigned seed = 1; seed <= 5; ++seed) {
      Rng rng(seed);
      const TrackResult r = track_scan(c, es, rng, map, prepare_scan(scan), scan, m);
      EXPECT_NEAR(r.predicted.x, 5.08, 1e-9);
      EXPECT_LT(std::hypot(r.result.pose.x - truth.x, r.result.pose.y - truth.y), 0.03)
          << "seed " << seed << " ratio " << ratio;
    }
  }
}

TEST(TrackingConfig, MotionHoldIsOffForTheSlamAndOnForTheLocaliser) {
  EXPECT_EQ(TrackingConfig{}.motion_hold, 0.0);
  EXPECT_EQ(SlamConfig::paper().tracking.motion_hold, 0.0);
  EXPECT_GT(LocaliserConfig{}.motion_hold, 0.0);
  for (const double bad : {-0.1, 1.0, std::nan("")}) {
    TrackingConfig c;
    c.motion_hold = bad;
    EXPECT_THROW(c.validate(), std::invalid_argument) << bad;
  }
  for (const double bad : {-0.1, 1.5, std::nan("")}) {
    TrackingConfig c;
    c.motion_hold_ratio = bad;
    EXPECT_THROW(c.validate(), std::invalid_argument) << bad;
  }
}

}  // namespace
}  // namespace esfleet
