// Noisy wheel odometry from a clean path (core/odometry_noise.hpp).

#include "esfleet/core/odometry_noise.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <vector>

namespace esfleet {
namespace {

/// A straight drive of n steps of `step` metres along +x, then a turn on the spot.
std::vector<Pose2> drive(int n, double step) {
  std::vector<Pose2> path;
  for (int i = 0; i <= n; ++i) path.push_back({i * step, 0.0, 0.0});
  return path;
}

TEST(OdometryNoise, ZeroNoiseGivesThePathBack) {
  const std::vector<Pose2> path = {{1, 2, 0.3}, {1.5, 2.2, 0.5}, {2.0, 2.1, -0.2}};
  const std::vector<Pose2> out = noisy_odometry(path, OdometryNoise{0, 0, 0, 0, 0}, 7);
  ASSERT_EQ(out.size(), path.size());
  for (std::size_t i = 0; i < path.size(); ++i) {
    EXPECT_NEAR(out[i].x, path[i].x, 1e-12);
    EXPECT_NEAR(out[i].y, path[i].y, 1e-12);
    EXPECT_NEAR(out[i].theta, path[i].theta, 1e-12);
  }
}

TEST(OdometryNoise, SeededAndStartsAtTheFirstPose) {
  const std::vector<Pose2> path = drive(50, 0.1);
  const auto a = noisy_odometry(path, {}, 3), b = noisy_odometry(path, {}, 3);
  const auto c = noisy_odometry(path, {}, 4);
  EXPECT_EQ(a, b);
  EXPECT_NE(a, c);
  EXPECT_EQ(a.front(), path.front());
}

TEST(OdometryNoise, StandingStillReportsNoMotion) {
  const std::vector<Pose2> path(20, Pose2{3, 4, 1});
  for (const Pose2& p : noisy_odometry(path, {}, 1)) EXPECT_EQ(p, path.front());
}

TEST(OdometryNoise, StepErrorsHaveTheConfiguredSize) {
  // 20 000 steps of 0.1 m straight: per step sigma_t = 0.05 * 0.1 + 0.005 = 0.01 m and
  // sigma_r = 0.5 deg + 1 deg/m * 0.1 m = 0.6 deg; measured from the noisy steps.
  const std::vector<Pose2> path = drive(20000, 0.1);
  const std::vector<Pose2> noisy = noisy_odometry(path, {}, 11);
  double sx = 0, sxx = 0, st = 0, stt = 0;
  const int n = static_cast<int>(path.size()) - 1;
  for (int i = 1; i <= n; ++i) {
    const Pose2 s = noisy[i].relative_to(noisy[i - 1]);
    sx += s.x - 0.1;
    sxx += (s.x - 0.1) * (s.x - 0.1);
    st += s.theta;
    stt += s.theta * s.theta;
  }
  EXPECT_NEAR(sx / n, 0.0, 0.0005);
  EXPECT_NEAR(std::sqrt(sxx / n), 0.01, 0.0005);
  EXPECT_NEAR(std::sqrt(stt / n), deg_to_rad(0.6), deg_to_rad(0.03));
  // The heading drifts: after 2 km it is off by far more than one step's error.
  EXPECT_GT(std::abs(noisy.back().theta) + std::abs(noisy.back().y), 0.1);
}

TEST(OdometryNoise, TurnsAddTheirShare) {
  // Turning 10 deg per step on the spot: sigma_r = 0.05 * 10 deg + 0.5 deg = 1 deg.
  std::vector<Pose2> path;
  for (int i = 0; i <= 20000; ++i) path.push_back({0, 0, normalize_angle(deg_to_rad(10.0 * i))});
  const std::vector<Pose2> noisy = noisy_odometry(path, {}, 5);
  double stt = 0;
  for (std::size_t i = 1; i < path.size(); ++i) {
    const double e = normalize_angle(noisy[i].relative_to(noisy[i - 1]).theta - deg_to_rad(10));
    stt += e * e;
  }
  EXPECT_NEAR(std::sqrt(stt / 20000), deg_to_rad(1.0), deg_to_rad(0.05));
}

TEST(OdometryNoise, NegativeOrNanParametersAreRefusedNamingTheField) {
  OdometryNoise bad;
  bad.turn_frac = -0.1;
  try {
    noisy_odometry(drive(2, 1.0), bad, 1);
    FAIL() << "accepted a negative turn_frac";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("turn_frac"), std::string::npos);
  }
  bad = {};
  bad.distance_base_m = std::nan("");
  EXPECT_THROW(noisy_odometry(drive(2, 1.0), bad, 1), std::invalid_argument);
}

}  // namespace
}  // namespace esfleet
