#include "esfleet/core/odometry_noise.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include "esfleet/core/random.hpp"

namespace esfleet {
namespace {
/// A step shorter than this (m) and turning less (rad) is standing still: rounding only.
constexpr double kStill = 1e-9;
}  // namespace

void OdometryNoise::validate() const {
  const std::pair<const char*, double> fields[] = {{"distance_frac", distance_frac},
                                                   {"distance_base_m", distance_base_m},
                                                   {"turn_frac", turn_frac},
                                                   {"turn_base_deg", turn_base_deg},
                                                   {"turn_per_m_deg", turn_per_m_deg}};
  for (const auto& [name, v] : fields) {
    if (!std::isfinite(v) || v < 0.0) {
      throw std::invalid_argument(std::string("odometry noise ") + name +
                                  " must be finite and >= 0");
    }
  }
}

std::vector<Pose2> noisy_odometry(const std::vector<Pose2>& path, const OdometryNoise& noise,
                                  std::uint64_t seed) {
  noise.validate();
  std::vector<Pose2> out;
  if (path.empty()) return out;
  out.reserve(path.size());
  out.push_back(path.front());
  Rng rng(seed);
  for (std::size_t i = 1; i < path.size(); ++i) {
    Pose2 step = path[i].relative_to(path[i - 1]);
    const double d = std::hypot(step.x, step.y);
    if (d < kStill && std::abs(step.theta) < kStill) {
      out.push_back(out.back());  // standing still (up to rounding): no motion reported
      continue;
    }
    {
      const double sigma_t = noise.distance_frac * d + noise.distance_base_m;
      const double sigma_r = noise.turn_frac * std::abs(step.theta) +
                             deg_to_rad(noise.turn_base_deg) + deg_to_rad(noise.turn_per_m_deg) * d;
      step.x += sigma_t * rng.normal();
      step.y += sigma_t * rng.normal();
      step.theta = normalize_angle(step.theta + sigma_r * rng.normal());
    }
    out.push_back(out.back().compose(step));
  }
  return out;
}

}  // namespace esfleet
