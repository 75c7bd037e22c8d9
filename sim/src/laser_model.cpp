#include "esfleet/sim/laser_model.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace esfleet::sim {

void LaserConfig::validate() const {
  if (beams < 2 || beams > 10000) throw std::invalid_argument("--beams must be in [2, 10000]");
  if (!(fov_deg > 0.0 && fov_deg <= 360.0))
    throw std::invalid_argument("--fov must be in (0, 360]");
  // 81.9 m is the CARMEN no-return level: longer hits could not be told from no-returns in a log.
  if (!(max_range > 0.0 && max_range < 81.9)) {
    throw std::invalid_argument("--max-range must be in (0, 81.9)");
  }
  if (!(range_noise >= 0.0 && range_noise <= 10.0)) {
    throw std::invalid_argument("--range-noise must be in [0, 10]");
  }
  if (!(dropout >= 0.0 && dropout <= 1.0))
    throw std::invalid_argument("--dropout must be in [0, 1]");
}

double LaserConfig::angle_min() const { return -deg_to_rad(fov_deg) / 2.0; }

double LaserConfig::angle_increment() const {
  const bool full_circle = fov_deg >= 360.0;
  return deg_to_rad(fov_deg) / (full_circle ? beams : beams - 1);
}

double cast_ray(const World& world, double x, double y, double angle, double max_range) {
  const double res = world.resolution();
  // Grid coordinates in cells: cell i spans [i, i + 1).
  const double u = (x - world.origin_x()) / res;
  const double v = (y - world.origin_y()) / res;
  const double dx = std::cos(angle), dy = std::sin(angle);
  Cell c{static_cast<int>(std::floor(u)), static_cast<int>(std::floor(v))};
  if (world.occupied(c)) return 0.0;

  constexpr double kInf = std::numeric_limits<double>::infinity();
  const int step_x = dx > 0 ? 1 : -1;
  const int step_y = dy > 0 ? 1 : -1;
  // Distance (m) along the ray to the next vertical / horizontal cell boundary, and between two.
  const double delta_x = dx != 0.0 ? res / std::abs(dx) : kInf;
  const double delta_y = dy != 0.0 ? res / std::abs(dy) : kInf;
  double next_x = dx != 0.0 ? (dx > 0 ? (c.x + 1 - u) : (u - c.x)) * delta_x : kInf;
  double next_y = dy != 0.0 ? (dy > 0 ? (c.y + 1 - v) : (v - c.y)) * delta_y : kInf;

  while (true) {
    double t;  // distance at which the ray enters the next cell
    if (next_x < next_y) {
      t = next_x;
      next_x += delta_x;
      c.x += step_x;
    } else {
      t = next_y;
      next_y += delta_y;
      c.y += step_y;
    }
    if (t >= max_range) return max_range;
    if (world.occupied(c)) return t;
    // Outside the image and moving away from it: nothing left to hit.
    if ((c.x < 0 && step_x < 0) || (c.x >= world.width() && step_x > 0) ||
        (c.y < 0 && step_y < 0) || (c.y >= world.height() && step_y > 0)) {
      return max_range;
    }
  }
}

LaserScan simulate_scan(const World& world, const LaserConfig& config, const Pose2& pose,
                        double stamp, Rng& rng) {
  LaserScan scan;
  scan.stamp = stamp;
  scan.angle_min = static_cast<float>(config.angle_min());
  scan.angle_increment = static_cast<float>(config.angle_increment());
  scan.max_range = static_cast<float>(config.max_range);
  scan.ranges.resize(static_cast<std::size_t>(config.beams));
  for (std::size_t i = 0; i < scan.ranges.size(); ++i) {
    // Beam angle from the float fields, so a reader of the scan computes the very same angle.
    const double angle = pose.theta + static_cast<double>(scan.angle(i));
    double r = config.max_range;
    if (rng.uniform() >= config.dropout) {
      const double exact = cast_ray(world, pose.x, pose.y, angle, config.max_range);
      if (exact < config.max_range) {
        r = std::max(0.0, exact + config.range_noise * rng.normal());
        if (r >= config.max_range) r = config.max_range;
      }
    }
    // float rounding must not turn a hit into a no-return or the other way round.
    float rf = static_cast<float>(r);
    if (r < config.max_range && rf >= scan.max_range) rf = std::nextafter(scan.max_range, 0.0f);
    scan.ranges[i] = r >= config.max_range ? scan.max_range : rf;
  }
  return scan;
}

}  // namespace esfleet::sim
