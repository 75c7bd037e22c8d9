#include "esfleet/core/map_png.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "esfleet/core/file_io.hpp"
#include "map_raster.hpp"

namespace esfleet {
namespace {

/// Clips the segment a-b to the rectangle [0, w] x [0, h] (Liang-Barsky); false if it misses.
bool clip_segment(cv::Point2d& a, cv::Point2d& b, double w, double h) {
  const double dx = b.x - a.x, dy = b.y - a.y;
  double t0 = 0.0, t1 = 1.0;
  const double p[4] = {-dx, dx, -dy, dy};
  const double q[4] = {a.x, w - a.x, a.y, h - a.y};
  for (int i = 0; i < 4; ++i) {
    if (p[i] == 0.0) {
      if (q[i] < 0.0) return false;
      continue;
    }
    const double t = q[i] / p[i];
    if (p[i] < 0.0) {
      t0 = std::max(t0, t);
    } else {
      t1 = std::min(t1, t);
    }
    if (t0 > t1) return false;
  }
  const cv::Point2d a0 = a;
  a = a0 + t0 * (b - a0);
  b = a0 + t1 * (b - a0);
  // Poses near the double range can overflow on the way: drop such segments.
  return std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(b.x) && std::isfinite(b.y);
}

cv::Mat draw_map(const GridMap& map, const std::vector<TimedPose>& trajectory,
                 const OccupancyThresholds& th, const std::string& path) {
  const detail::Raster r = detail::render(map, th, path);
  cv::Mat img(r.height, r.width, CV_8UC3);
  const int u = kUnknownLevel;
  const cv::Vec3b tint(static_cast<std::uint8_t>(std::min(u + 15, 255)),
                       static_cast<std::uint8_t>(u),
                       static_cast<std::uint8_t>(std::max(u - 15, 0)));  // BGR
  for (int row = 0; row < r.height; ++row) {
    auto* out = img.ptr<cv::Vec3b>(row);
    for (int col = 0; col < r.width; ++col) {
      const auto j = static_cast<std::size_t>(row) * r.width + col;
      const std::uint8_t x = r.grey[j];
      out[col] = r.known[j] ? cv::Vec3b(x, x, x) : tint;
    }
  }

  // Continuous image coordinates of a pose: pixel (c, r) covers [c, c+1) x [r, r+1).
  const double cs = map.cell_size();
  const auto to_image = [&](const Pose2& p) {
    return cv::Point2d(p.x / cs - r.min.x, (r.max_y + 1.0) - p.y / cs);
  };
  const auto finite = [](const cv::Point2d& p) { return std::isfinite(p.x) && std::isfinite(p.y); };
  const auto pixel = [&](const cv::Point2d& p) {
    return cv::Point(std::clamp(static_cast<int>(std::floor(p.x)), 0, r.width - 1),
                     std::clamp(static_cast<int>(std::floor(p.y)), 0, r.height - 1));
  };
  const auto inside = [&](const cv::Point2d& p) {
    return p.x >= 0.0 && p.x < r.width && p.y >= 0.0 && p.y < r.height;
  };
  const double w = r.width, h = r.height;
  const cv::Scalar red(0, 0, 255), green(0, 255, 0), blue(255, 0, 0);
  bool have_prev = false, have_first = false;
  cv::Point2d prev, first, last;
  for (const TimedPose& tp : trajectory) {
    const cv::Point2d p = to_image(tp.pose);
    if (!finite(p)) {
      have_prev = false;
      continue;
    }
    if (!have_first) {
      first = p;
      have_first = true;
    }
    last = p;
    cv::Point2d a = have_prev ? prev : p, b = p;
    if (clip_segment(a, b, w, h)) cv::line(img, pixel(a), pixel(b), red, 1, cv::LINE_8);
    prev = p;
    have_prev = true;
  }
  if (have_first && inside(first)) cv::circle(img, pixel(first), 3, green, cv::FILLED, cv::LINE_8);
  if (have_first && inside(last)) cv::circle(img, pixel(last), 3, blue, cv::FILLED, cv::LINE_8);
  return img;
}

}  // namespace

void save_map_png(const GridMap& map, const std::vector<TimedPose>& trajectory,
                  const std::string& path, const OccupancyThresholds& th) {
  const cv::Mat img = draw_map(map, trajectory, th, path);
  std::vector<std::uint8_t> png;
  try {
    if (!cv::imencode(".png", img, png)) {
      throw std::runtime_error("cannot write '" + path + "': PNG encoding failed");
    }
  } catch (const cv::Exception& e) {
    throw std::runtime_error("cannot write '" + path + "': PNG encoding failed: " + e.what());
  }
  write_file_atomically(path, std::string(png.begin(), png.end()));
}

}  // namespace esfleet
