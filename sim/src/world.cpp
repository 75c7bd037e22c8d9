#include "esfleet/sim/world.hpp"

#include <cmath>
#include <numbers>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <utility>

namespace esfleet::sim {

World::World(OccupancyImage image) : image_(std::move(image)) {
  if (image_.width <= 0 || image_.height <= 0) throw std::invalid_argument("world: empty image");
  const std::size_t n = static_cast<std::size_t>(image_.width) * image_.height;
  if (image_.cells.size() != n) throw std::invalid_argument("world: cells do not match the size");
  if (!(image_.resolution > 0.0) || !std::isfinite(image_.resolution)) {
    throw std::invalid_argument("world: resolution must be > 0");
  }
  if (std::abs(image_.origin_theta) > 1e-9) {
    throw std::invalid_argument("world: a rotated origin (non-zero yaw) is not supported");
  }
  flags_.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const int v = image_.cells[i];
    flags_[i] = v >= kOccupiedPercent ? kOccupied : (v == 0 ? kFree : kUnknown);
  }

  // Distance transform: free cells non-zero, everything else (and a 1-pixel frame standing for
  // the unknown outside the image) zero. Rows are flipped relative to the image file, which
  // does not matter for distances.
  cv::Mat mask(image_.height + 2, image_.width + 2, CV_8U, cv::Scalar(0));
  for (int y = 0; y < image_.height; ++y) {
    for (int x = 0; x < image_.width; ++x) {
      if (flags_[index({x, y})] == kFree) mask.at<std::uint8_t>(y + 1, x + 1) = 255;
    }
  }
  cv::Mat dist;
  cv::distanceTransform(mask, dist, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
  clearance_.resize(n);
  for (int y = 0; y < image_.height; ++y) {
    for (int x = 0; x < image_.width; ++x) {
      const double centre_cells = dist.at<float>(y + 1, x + 1);
      clearance_[index({x, y})] =
          static_cast<float>((centre_cells - std::numbers::sqrt2) * image_.resolution);
    }
  }
}

Cell World::cell_at(double x, double y) const {
  return {static_cast<int>(std::floor((x - image_.origin_x) / image_.resolution)),
          static_cast<int>(std::floor((y - image_.origin_y) / image_.resolution))};
}

void World::centre_of(Cell c, double& x, double& y) const {
  x = image_.origin_x + (c.x + 0.5) * image_.resolution;
  y = image_.origin_y + (c.y + 0.5) * image_.resolution;
}

World load_world(const std::string& yaml_path) {
  try {
    return World(load_ros_map(yaml_path));
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(yaml_path + ": " + e.what());
  }
}

}  // namespace esfleet::sim
