#pragma once
// 2D rigid-body poses: the one geometry type shared by the log reader, the SLAM, the
// localiser and the accuracy metric.

#include <cmath>
#include <numbers>

namespace esfleet {

/// Wraps an angle to (-pi, pi].
inline double normalize_angle(double a) {
  // Most angles are in range already, and remainder() returns those unchanged (a quotient
  // |a| / 2 pi <= 1/2 rounds to 0, the tie at pi to the even 0): skip the library call.
  if (a > -std::numbers::pi && a <= std::numbers::pi) return a;
  a = std::remainder(a, 2.0 * std::numbers::pi);
  return a <= -std::numbers::pi ? a + 2.0 * std::numbers::pi : a;
}

inline constexpr double deg_to_rad(double d) { return d * std::numbers::pi / 180.0; }
inline constexpr double rad_to_deg(double r) { return r * 180.0 / std::numbers::pi; }

/// A pose in the plane: position in metres, heading in radians (counter-clockwise from +x).
struct Pose2 {
  double x = 0.0;
  double y = 0.0;
  double theta = 0.0;

  /// this ⊕ other: `other` expressed in this pose's frame, mapped to the world.
  Pose2 compose(const Pose2& other) const {
    const double c = std::cos(theta), s = std::sin(theta);
    return {x + c * other.x - s * other.y, y + s * other.x + c * other.y,
            normalize_angle(theta + other.theta)};
  }
  /// The inverse transform: inverse().compose(*this) is the identity.
  Pose2 inverse() const {
    const double c = std::cos(theta), s = std::sin(theta);
    return {-c * x - s * y, s * x - c * y, normalize_angle(-theta)};
  }
  /// This pose seen from `from`: from.inverse() ⊕ this.
  Pose2 relative_to(const Pose2& from) const { return from.inverse().compose(*this); }

  friend bool operator==(const Pose2&, const Pose2&) = default;
};

/// Whether `a` and `b` are one place: closer than `xy` metres and `theta` radians.
inline bool same_place(const Pose2& a, const Pose2& b, double xy, double theta) {
  return std::hypot(a.x - b.x, a.y - b.y) < xy &&
         std::abs(normalize_angle(a.theta - b.theta)) < theta;
}

/// A pose with the time it belongs to (seconds, the log's clock).
struct TimedPose {
  double stamp = 0.0;
  Pose2 pose;
};

}  // namespace esfleet
