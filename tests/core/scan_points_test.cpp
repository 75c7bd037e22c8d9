// Preparing a scan for matching: which beams become end points, which count as no-returns, and
// where the end points lie in the sensor frame.

#include "esfleet/core/scan_points.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>

namespace esfleet {
namespace {

LaserScan scan_of(std::vector<float> ranges, float angle_min = 0.0f, float increment = 0.5f) {
  LaserScan s;
  s.angle_min = angle_min;
  s.angle_increment = increment;
  s.max_range = 30.0f;
  s.ranges = std::move(ranges);
  return s;
}

TEST(PrepareScan, EndPointsLieAlongTheirBeamsInTheSensorFrame) {
  const float pi = std::numbers::pi_v<float>;
  const ScanPoints p = prepare_scan(scan_of({2.0f, 3.0f, 4.0f}, -pi / 2, pi / 2));
  ASSERT_EQ(p.size(), 3u);
  EXPECT_NEAR(p.x[0], 0.0f, 1e-6f);  // -90 deg: to the right (y negative)
  EXPECT_NEAR(p.y[0], -2.0f, 1e-6f);
  EXPECT_NEAR(p.x[1], 3.0f, 1e-6f);  // straight ahead
  EXPECT_NEAR(p.y[1], 0.0f, 1e-6f);
  EXPECT_NEAR(p.x[2], 0.0f, 1e-6f);  // +90 deg: to the left
  EXPECT_NEAR(p.y[2], 4.0f, 1e-6f);
  EXPECT_EQ(p.range, (std::vector<float>{2.0f, 3.0f, 4.0f}));
  EXPECT_TRUE(p.no_return_angles.empty());
}

TEST(PrepareScan, ReadingsAtTheSensorMaximumAreNoReturnsWithTheirDirection) {
  const ScanPoints p = prepare_scan(scan_of({1.0f, 30.0f, 45.0f, 2.0f}, 0.1f, 0.5f));
  EXPECT_EQ(p.size(), 2u);
  ASSERT_EQ(p.no_return_angles.size(), 2u);
  EXPECT_FLOAT_EQ(p.no_return_angles[0], 0.6f);
  EXPECT_FLOAT_EQ(p.no_return_angles[1], 1.1f);
}

TEST(PrepareScan, MinAndMaxRangeDropBeamsWithoutMakingThemNoReturns) {
  const ScanPoints p = prepare_scan(scan_of({0.05f, 0.5f, 10.0f, 20.0f, 30.0f}), 0.1f, 15.0f);
  EXPECT_EQ(p.range, (std::vector<float>{0.5f, 10.0f}));
  EXPECT_EQ(p.no_return_angles.size(), 1u);  // only the sensor's own no-return
  // A max_range above the sensor's changes nothing; 0 means no extra limit.
  EXPECT_EQ(prepare_scan(scan_of({29.0f}), 0.0f, 100.0f).size(), 1u);
  EXPECT_EQ(prepare_scan(scan_of({29.0f}), 0.0f, 0.0f).size(), 1u);
}

TEST(PrepareScan, ReadingsOfAKilometreOrMoreAreNoReturnsWhateverTheScanMaximum) {
  // A scan message may declare any finite max_range; end points stop at kMaxBeamRange.
  LaserScan s = scan_of({999.0f, kMaxBeamRange, 1e7f, 3e38f, 2.0f});
  s.max_range = 3.4e38f;
  const ScanPoints p = prepare_scan(s);
  EXPECT_EQ(p.range, (std::vector<float>{999.0f, 2.0f}));
  EXPECT_EQ(p.no_return_angles.size(), 3u);
}

TEST(PrepareScan, NonFiniteAndNegativeReadingsAreDropped) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  const ScanPoints p = prepare_scan(scan_of({nan, -1.0f, inf, 3.0f, -inf}));
  EXPECT_EQ(p.range, (std::vector<float>{3.0f}));
  EXPECT_TRUE(p.no_return_angles.empty());  // an infinite reading is not trusted as one
}

TEST(BeamFill, ACoarseLaserGetsPointsBetweenAdjacentBeamsOfOneSurface) {
  const float deg = std::numbers::pi_v<float> / 180.0f;
  // A 1 deg laser: beams 0-1 on one surface (ranges 0.1 m apart), 1-2 across an edge (0.5 m),
  // 3 a no-return, 4 dropped (NaN), 5-6 on one surface again (0.15 m apart).
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const LaserScan s = scan_of({2.0f, 2.1f, 2.6f, 30.0f, nan, 3.0f, 3.15f}, 0.0f, deg);
  const BeamFill fill{0.5, 0.2};
  EXPECT_EQ(beam_fill_points(s, fill), 1);
  const ScanPoints p = prepare_scan(s, 0.0f, 0.0f, fill);
  // Beam order: 2.0, (2.05), 2.1, 2.6, 3.0, (3.075), 3.15; nothing next to the no-return or the
  // dropped beam, nothing across the edge.
  ASSERT_EQ(p.size(), 7u);
  const std::vector<float> ranges{2.0f, 2.05f, 2.1f, 2.6f, 3.0f, 3.075f, 3.15f};
  const std::vector<float> angles{0.0f, 0.5f, 1.0f, 2.0f, 5.0f, 5.5f, 6.0f};
  for (std::size_t i = 0; i < p.size(); ++i) {
    EXPECT_NEAR(p.range[i], ranges[i], 1e-5f) << i;
    EXPECT_NEAR(std::atan2(p.y[i], p.x[i]), angles[i] * deg, 1e-5f) << i;
    EXPECT_NEAR(std::hypot(p.x[i], p.y[i]), ranges[i], 1e-5f) << i;
  }
  EXPECT_EQ(p.no_return_angles.size(), 1u);
  // The same scan without the fill: its own five end points.
  EXPECT_EQ(prepare_scan(s).size(), 5u);
  // A wider gap allowed: the edge is filled too.
  EXPECT_EQ(prepare_scan(s, 0.0f, 0.0f, BeamFill{0.5, 0.6}).size(), 8u);
}

TEST(BeamFill, AsManyPointsAsBringTheSpacingDownAndNoneForAFineLaser) {
  const double deg = std::numbers::pi / 180.0;
  const BeamFill fill{0.5, 0.2};
  auto points = [&](double increment_deg) {
    return beam_fill_points(scan_of({1.0f, 1.0f}, 0.0f, static_cast<float>(increment_deg * deg)),
                            fill);
  };
  EXPECT_EQ(points(0.5), 0);   // the bundled logs' lasers: unchanged
  EXPECT_EQ(points(0.25), 0);  // finer
  EXPECT_EQ(points(1.0), 1);
  EXPECT_EQ(points(2.0), 3);
  EXPECT_EQ(points(0.6), 1);
  EXPECT_EQ(points(-1.0), 1);  // beams ordered clockwise
  EXPECT_EQ(beam_fill_points(scan_of({1.0f, 1.0f}, 0.0f, static_cast<float>(deg)), BeamFill{}),
            0);  // off
  // Two points 2 deg apart on a wall 1 m ahead, filled to 0.5 deg: three in between, evenly.
  const ScanPoints p =
      prepare_scan(scan_of({1.0f, 1.0f}, 0.0f, static_cast<float>(2.0 * deg)), 0.0f, 0.0f, fill);
  ASSERT_EQ(p.size(), 5u);
  for (std::size_t i = 0; i < p.size(); ++i) {
    EXPECT_NEAR(std::atan2(p.y[i], p.x[i]), 0.5 * deg * static_cast<double>(i), 1e-6) << i;
  }
}

TEST(ThinScan, KeepsPointsAtLeastTheSpacingFromTheLastOneKept) {
  ScanPoints p;
  // A near wall sampled every 3 cm, then a jump back to a far one and a point 4 cm past it.
  for (int i = 0; i < 9; ++i) {
    p.x.push_back(1.0f);
    p.y.push_back(0.03f * static_cast<float>(i));
    p.range.push_back(std::hypot(p.x.back(), p.y.back()));
  }
  p.x.insert(p.x.end(), {5.0f, 5.0f});
  p.y.insert(p.y.end(), {0.3f, 0.34f});
  p.range.insert(p.range.end(), {std::hypot(5.0f, 0.3f), std::hypot(5.0f, 0.34f)});
  p.no_return_angles = {0.5f, 0.6f};
  const ScanPoints t = thin_scan(p, 0.1);
  // 0, 0.12 and 0.24 m along the wall (each 0.12 m from the last kept), then the far wall.
  EXPECT_EQ(t.y, (std::vector<float>{0.0f, 0.12f, 0.24f, 0.3f}));
  EXPECT_EQ(t.x, (std::vector<float>{1.0f, 1.0f, 1.0f, 5.0f}));
  EXPECT_EQ(t.range, (std::vector<float>{p.range[0], p.range[4], p.range[8], p.range[9]}));
  EXPECT_EQ(t.no_return_angles, p.no_return_angles);
  // No spacing keeps every point; so does a spacing below the closest pair.
  EXPECT_EQ(thin_scan(p, 0.0).x, p.x);
  EXPECT_EQ(thin_scan(p, 0.01).size(), p.size());
  EXPECT_EQ(thin_scan(ScanPoints{}, 0.1).size(), 0u);
}

}  // namespace
}  // namespace esfleet
