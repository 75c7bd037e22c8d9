#include "esfleet/sim/fleet.hpp"

#include <cmath>
#include <stdexcept>

namespace esfleet::sim {

void FleetConfig::validate() const {
  if (robots < 1 || robots > 1000) throw std::invalid_argument("--robots must be in [1, 1000]");
  // Ids go on the wire as string<64>; the number takes up to 4 characters.
  if (id_prefix.size() > 60) throw std::invalid_argument("--id-prefix: at most 60 characters");
  for (const char ch : id_prefix) {
    if (std::isspace(static_cast<unsigned char>(ch)) ||
        !std::isprint(static_cast<unsigned char>(ch))) {
      throw std::invalid_argument("--id-prefix must not hold spaces or control characters");
    }
  }
  if (!(rate > 0.0 && rate <= 100.0)) throw std::invalid_argument("--rate must be in (0, 100]");
  if (!(start_stamp >= 0.0) || !std::isfinite(start_stamp)) {
    throw std::invalid_argument("--start-stamp must be finite and >= 0");
  }
  motion.validate();
  laser.validate();
  odometry.validate();
}

Fleet::Fleet(const World& world, FleetConfig config)
    : world_(&world),
      config_((config.validate(), std::move(config))),
      grid_(make_plan_grid(world, config_.motion)) {
  robots_.reserve(static_cast<std::size_t>(config_.robots));
  for (int k = 1; k <= config_.robots; ++k) {
    const auto index = static_cast<std::uint64_t>(k);
    robots_.emplace_back(config_.id_prefix + std::to_string(k), world, grid_, config_.motion,
                         config_.odometry, stream_seed(config_.seed, index, 0));
    laser_rngs_.emplace_back(stream_seed(config_.seed, index, 3));
  }
  samples_.resize(robots_.size());
}

const std::vector<RobotSample>& Fleet::tick() {
  ++ticks_;
  const double dt = 1.0 / config_.rate;
  const double stamp = config_.start_stamp + sim_time();
  for (std::size_t i = 0; i < robots_.size(); ++i) {
    Robot& robot = robots_[i];
    robot.step(dt);
    RobotSample& s = samples_[i];
    s.robot = &robot;
    s.truth = {stamp, robot.truth()};
    s.scan = simulate_scan(*world_, config_.laser, robot.truth(), stamp, laser_rngs_[i]);
    s.scan.odometry = robot.odometry();
  }
  return samples_;
}

}  // namespace esfleet::sim
