// Point-to-line ICP between two scans of the synthetic room (scan_icp.hpp): it recovers the true
// relative pose from a perturbed start, keeps the start along a corridor it cannot see the ends
// of or sees along only through a few end points, and refuses what it cannot align.

#include "esfleet/core/scan_icp.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>
#include <vector>

#include "esfleet/core/random.hpp"
#include "synthetic_world.hpp"

namespace esfleet {
namespace {

using testing::asymmetric_room;
using testing::make_scan;
using testing::Segment;

ScanPoints scan_at(const std::vector<Segment>& world, const Pose2& pose, Rng* noise = nullptr,
                   double sigma = 0.0) {
  LaserScan s = make_scan(world, pose);
  if (noise != nullptr) {
    for (float& r : s.ranges) {
      if (r < 30.0f) r += static_cast<float>(sigma * noise->normal());
    }
  }
  return prepare_scan(s);
}

/// Distance from `p` to the nearest wall (over 72 directions).
double clearance(const std::vector<Segment>& world, const Pose2& p) {
  double d = 1e9;
  for (int k = 0; k < 72; ++k) d = std::min(d, testing::cast_ray(world, p.x, p.y, k * 0.0872665));
  return d;
}

TEST(ScanIcp, RecoversTheRelativePoseFromAPerturbedStart) {
  int aligned = 0;
  const auto world = asymmetric_room();
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    Rng rng(seed);
    const Pose2 a{rng.uniform(2.0, 10.0), rng.uniform(1.5, 6.5), rng.uniform(-3.0, 3.0)};
    // The next scan, 10-30 cm on and turned up to 10 degrees, as consecutive key scans are.
    const Pose2 motion{rng.uniform(0.1, 0.3), rng.uniform(-0.05, 0.05), rng.uniform(-0.17, 0.17)};
    const Pose2 b = a.compose(motion);
    if (clearance(world, a) < 0.5 || clearance(world, b) < 0.5) continue;  // inside or at a wall
    // Tracking error of a few centimetres and half a degree.
    const Pose2 start{motion.x + rng.uniform(-0.04, 0.04), motion.y + rng.uniform(-0.04, 0.04),
                      motion.theta + rng.uniform(-0.01, 0.01)};
    const auto r = align_scans(scan_at(world, a), scan_at(world, b), start);
    ASSERT_TRUE(r.has_value()) << "seed " << seed;
    const Pose2 e = r->relative.relative_to(motion);
    EXPECT_LT(std::hypot(e.x, e.y), 0.005) << "seed " << seed;
    EXPECT_LT(std::abs(e.theta), deg_to_rad(0.1)) << "seed " << seed;
    EXPECT_GT(r->pairs, 100u) << "seed " << seed;
    EXPECT_LT(r->rms, 0.02) << "seed " << seed;
    ++aligned;
  }
  EXPECT_GE(aligned, 12);
}

TEST(ScanIcp, NoisyRangesStillBeatTheStart) {
  const auto world = asymmetric_room();
  double start_error = 0.0, icp_error = 0.0;
  int runs = 0;
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    Rng rng(seed);
    const Pose2 a{rng.uniform(3.0, 9.0), rng.uniform(2.0, 6.0), rng.uniform(-3.0, 3.0)};
    const Pose2 motion{0.2, 0.0, rng.uniform(-0.1, 0.1)};
    if (clearance(world, a) < 0.5 || clearance(world, a.compose(motion)) < 0.5) continue;
    const Pose2 start{motion.x + 0.03, motion.y - 0.03, motion.theta + 0.008};
    const auto r = align_scans(scan_at(world, a, &rng, 0.01),
                               scan_at(world, a.compose(motion), &rng, 0.01), start);
    if (!r) continue;  // a view too poor to align: the caller keeps the start
    ++runs;
    const Pose2 e0 = start.relative_to(motion), e = r->relative.relative_to(motion);
    start_error += std::hypot(e0.x, e0.y);
    icp_error += std::hypot(e.x, e.y);
  }
  ASSERT_GE(runs, 10);
  // Beams with 1 cm range noise: the alignment lands well within the start's 4.2 cm.
  EXPECT_LT(icp_error / runs, 0.25 * start_error / runs);
}

TEST(ScanIcp, AlongACorridorTheStartStays) {
  // Two long parallel walls and nothing else in range: across the corridor and the heading
  // are seen, along it nothing is.
  const std::vector<Segment> corridor{{-100, 1, 100, 1}, {-100, -1, 100, -1}};
  const Pose2 a{0, 0, 0};
  const Pose2 motion{0.3, 0.02, 0.02};
  const Pose2 start{0.25, 0.05, 0.03};  // 5 cm short along the corridor, 3 cm across
  const auto r = align_scans(scan_at(corridor, a), scan_at(corridor, a.compose(motion)), start);
  ASSERT_TRUE(r.has_value());
  EXPECT_NEAR(r->relative.y, motion.y, 0.003);          // across: corrected
  EXPECT_NEAR(r->relative.theta, motion.theta, 0.002);  // heading: corrected
  EXPECT_NEAR(r->relative.x, start.x, 0.02);            // along: the start, not slid away
}

/// The alignment with nothing held (degenerate_ratio 0) and with the default; both must hold.
std::pair<IcpResult, IcpResult> free_and_held(const ScanPoints& ref, const ScanPoints& moving,
                                              const Pose2& start) {
  IcpConfig all_pairs;
  all_pairs.degenerate_ratio = 0.0;
  const auto free = align_scans(ref, moving, start, all_pairs);
  const auto held = align_scans(ref, moving, start);
  EXPECT_TRUE(free.has_value());
  EXPECT_TRUE(held.has_value());
  return {free.value_or(IcpResult{}), held.value_or(IcpResult{})};
}

TEST(ScanIcp, AlongANearlyBlindCorridorTheStartStays) {
  // The same corridor with a door jamb: a few end points now see along it. The ICP would take
  // its position along the corridor from those few; with degenerate_ratio it keeps the start's,
  // since on real scans such a handful is as often paired wrongly as rightly (docs/slam.md item 6).
  const std::vector<Segment> corridor{{-100, 1, 100, 1}, {-100, -1, 100, -1}, {2, 1, 2, 0.7}};
  const Pose2 a{0, 0, 0};
  const Pose2 motion{0.3, 0.02, 0.02};
  const Pose2 start{0.25, 0.05, 0.03};
  const auto [free, held] =
      free_and_held(scan_at(corridor, a), scan_at(corridor, a.compose(motion)), start);
  EXPECT_FALSE(free.held_along);
  EXPECT_TRUE(held.held_along);
  EXPECT_NEAR(free.relative.x, motion.x, 0.005);  // the jamb pulled it along
  EXPECT_NEAR(held.relative.x, start.x, 0.002);   // the start's, to the tilt of the walls
  for (const IcpResult& r : {free, held}) {
    EXPECT_NEAR(r.relative.y, motion.y, 0.003);
    EXPECT_NEAR(r.relative.theta, motion.theta, 0.002);
  }
}

TEST(ScanIcp, AWellConstrainedAlignmentIsNotHeld) {
  const auto world = asymmetric_room();
  const Pose2 a{6.0, 4.0, 0.3};
  const Pose2 motion{0.25, 0.03, 0.1};
  const Pose2 start{0.22, 0.05, 0.11};
  const auto [free, held] =
      free_and_held(scan_at(world, a), scan_at(world, a.compose(motion)), start);
  EXPECT_FALSE(held.held_along);
  EXPECT_EQ(held.relative.x, free.relative.x);
  EXPECT_EQ(held.relative.y, free.relative.y);
  EXPECT_EQ(held.relative.theta, free.relative.theta);
}

TEST(ScanIcp, RefusesWhatItCannotAlign) {
  const auto world = asymmetric_room();
  const Pose2 a{6.0, 4.0, 0.3};
  const ScanPoints ref = scan_at(world, a);
  // A scan from the other end of the room, started where the first one was: few pairs.
  const ScanPoints far = scan_at(world, Pose2{2.0, 7.0, 2.5});
  EXPECT_FALSE(align_scans(ref, far, Pose2{}).has_value());
  // An empty scan.
  EXPECT_FALSE(align_scans(ref, ScanPoints{}, Pose2{}).has_value());
  EXPECT_FALSE(align_scans(ScanPoints{}, ref, Pose2{}).has_value());
  // A true motion farther from the start than the config lets the result move.
  const Pose2 motion{0.3, 0.0, 0.0};
  IcpConfig tight;
  tight.max_move_xy = 0.02;
  EXPECT_FALSE(align_scans(ref, scan_at(world, a.compose(motion)), Pose2{0.25, 0.0, 0.0}, tight)
                   .has_value());
  EXPECT_TRUE(
      align_scans(ref, scan_at(world, a.compose(motion)), Pose2{0.25, 0.0, 0.0}).has_value());
}

TEST(ScanIcp, ConfigValidationNamesTheField) {
  IcpConfig c;
  EXPECT_NO_THROW(c.validate());
  c.max_distance = 0.0;
  try {
    c.validate();
    FAIL() << "no throw";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("icp.max_distance"), std::string::npos);
  }
  IcpConfig d;
  d.min_pair_share = 1.5;
  EXPECT_THROW(d.validate(), std::invalid_argument);
  IcpConfig r;
  r.degenerate_ratio = 1.0;
  EXPECT_THROW(r.validate(), std::invalid_argument);
  IcpConfig n;
  n.min_normal_cos = 1.5;
  EXPECT_THROW(n.validate(), std::invalid_argument);
}

TEST(ScanIcp, AnEndPointPairsOnlyWithALineLikeItsOwn) {
  const auto world = asymmetric_room();
  const Pose2 a{6.0, 4.0, 0.3};
  const Pose2 motion{0.2, 0.02, 0.05};
  const Pose2 start{0.18, 0.04, 0.06};
  const ScanPoints ref = scan_at(world, a);
  const ScanPoints moving = scan_at(world, a.compose(motion));
  // Every moving end point moved 3 cm to alternate sides of its wall: no line of its own fits
  // (they scatter more than max_line_rms about one), so with the check nothing pairs.
  ScanPoints zigzag = moving;
  for (std::size_t i = 0; i < zigzag.size(); ++i) {
    const float s = (i % 2 == 0 ? 0.03f : -0.03f) / std::max(zigzag.range[i], 0.1f);
    const float x = zigzag.x[i], y = zigzag.y[i];
    zigzag.x[i] = x - s * y;  // across the beam
    zigzag.y[i] = y + s * x;
  }
  IcpConfig off;
  off.min_normal_cos = 0.0;
  EXPECT_FALSE(align_scans(ref, zigzag, start).has_value());
  EXPECT_TRUE(align_scans(ref, zigzag, start, off).has_value());
  // Clean scans align as well with the check as without it.
  const auto on = align_scans(ref, moving, start);
  const auto without = align_scans(ref, moving, start, off);
  ASSERT_TRUE(on.has_value());
  ASSERT_TRUE(without.has_value());
  const Pose2 e = on->relative.relative_to(motion);
  EXPECT_LT(std::hypot(e.x, e.y), 0.005);
  EXPECT_LT(on->pairs, without->pairs);  // the corners' end points no longer pair
}

}  // namespace
}  // namespace esfleet
