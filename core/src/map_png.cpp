#include "esfleet/core/map_png.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <stdexcept>
#include <utility>
#include <vector>

#include "esfleet/core/file_io.hpp"
#include "map_raster.hpp"
#include "png_io.hpp"

namespace esfleet {
namespace {

struct Point {
  double x = 0.0;
  double y = 0.0;
};

using Rgb = std::array<std::uint8_t, 3>;

/// Clips the segment a-b to the rectangle [0, w] x [0, h] (Liang-Barsky); false if it misses.
bool clip_segment(Point& a, Point& b, double w, double h) {
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
  const Point a0 = a;
  a = {a0.x + t0 * dx, a0.y + t0 * dy};
  b = {a0.x + t1 * dx, a0.y + t1 * dy};
  // Poses near the double range can overflow on the way: drop such segments.
  return std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(b.x) && std::isfinite(b.y);
}

/// What the map PNG draws over the map: the pixels set (index row * width + col, colour), in
/// drawing order, a later one covering an earlier one. Kept sparse, so that the colour image is
/// never held whole (CSAIL: 1142 x 1709 pixels, 5.9 MB as RGB; its trajectory sets a few
/// thousand).
class Overlay {
 public:
  Overlay(int width, int height) : width_(width), height_(height) {}

  void set(int col, int row, const Rgb& c) {
    if (col < 0 || row < 0 || col >= width_ || row >= height_) return;
    pixels_.emplace_back(static_cast<std::size_t>(row) * width_ + col, c);
  }

  /// An 8-connected 1-pixel line from (c0, r0) to (c1, r1), both ends included (Bresenham).
  /// The pixel choice is OpenCV's cv::line (LINE_8), which drew these maps before: traversed
  /// from the left end, a step along the minor axis is taken while the error term is negative.
  void line(int c0, int r0, int c1, int r1, const Rgb& colour) {
    if (c1 < c0) {
      std::swap(c0, c1);
      std::swap(r0, r1);
    }
    const int dc = c1 - c0, dr = std::abs(r1 - r0), step_r = r1 < r0 ? -1 : 1;
    const bool steep = dr > dc;
    const int major = steep ? dr : dc, minor = steep ? dc : dr;
    int err = major - 2 * minor;
    int c = c0, r = r0;
    for (int i = 0; i <= major; ++i) {
      set(c, r, colour);
      const bool minor_step = err < 0;
      err -= 2 * minor;
      if (minor_step) err += 2 * major;
      if (steep) {
        r += step_r;
        if (minor_step) ++c;
      } else {
        ++c;
        if (minor_step) r += step_r;
      }
    }
  }

  /// A filled disc: the pixels within `radius` of the centre pixel (dx^2 + dy^2 <= radius^2;
  /// for radius 3 the same pixels as OpenCV's filled cv::circle).
  void disc(int col, int row, int radius, const Rgb& colour) {
    for (int dr = -radius; dr <= radius; ++dr) {
      for (int dc = -radius; dc <= radius; ++dc) {
        if (dc * dc + dr * dr <= radius * radius) set(col + dc, row + dr, colour);
      }
    }
  }

  /// After drawing: orders the pixels by index, keeping the last colour drawn at each.
  void finish() {
    std::stable_sort(pixels_.begin(), pixels_.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    std::size_t kept = 0;
    for (std::size_t i = 0; i < pixels_.size(); ++i) {
      if (i + 1 < pixels_.size() && pixels_[i + 1].first == pixels_[i].first) continue;
      pixels_[kept++] = pixels_[i];
    }
    pixels_.resize(kept);
  }

  /// The colour drawn at pixel i, if any. After finish(), with i growing from call to call.
  const Rgb* at(std::size_t i) {
    while (next_ < pixels_.size() && pixels_[next_].first < i) ++next_;
    return next_ < pixels_.size() && pixels_[next_].first == i ? &pixels_[next_].second : nullptr;
  }

 private:
  int width_;
  int height_;
  std::vector<std::pair<std::size_t, Rgb>> pixels_;
  std::size_t next_ = 0;  ///< at(): the first pixel not behind the last index asked for
};

/// The trajectory over the map: red polyline, green disc at the first pose, blue at the last.
Overlay draw_trajectory(const detail::Raster& r, double cell_size,
                        const std::vector<TimedPose>& trajectory) {
  Overlay img(r.width, r.height);
  // Continuous image coordinates of a pose: pixel (c, r) covers [c, c+1) x [r, r+1).
  const double cs = cell_size;
  const auto to_image = [&](const Pose2& p) {
    return Point{p.x / cs - r.min.x, (r.max_y + 1.0) - p.y / cs};
  };
  const auto finite = [](const Point& p) { return std::isfinite(p.x) && std::isfinite(p.y); };
  const auto col_of = [&](const Point& p) {
    return std::clamp(static_cast<int>(std::floor(p.x)), 0, r.width - 1);
  };
  const auto row_of = [&](const Point& p) {
    return std::clamp(static_cast<int>(std::floor(p.y)), 0, r.height - 1);
  };
  const auto inside = [&](const Point& p) {
    return p.x >= 0.0 && p.x < r.width && p.y >= 0.0 && p.y < r.height;
  };
  const double w = r.width, h = r.height;
  constexpr Rgb kRed{255, 0, 0}, kGreen{0, 255, 0}, kBlue{0, 0, 255};
  constexpr int kMarkerRadius = 3;
  bool have_prev = false, have_first = false;
  Point prev, first, last;
  for (const TimedPose& tp : trajectory) {
    const Point p = to_image(tp.pose);
    if (!finite(p)) {
      have_prev = false;
      continue;
    }
    if (!have_first) {
      first = p;
      have_first = true;
    }
    last = p;
    Point a = have_prev ? prev : p, b = p;
    if (clip_segment(a, b, w, h)) img.line(col_of(a), row_of(a), col_of(b), row_of(b), kRed);
    prev = p;
    have_prev = true;
  }
  if (have_first && inside(first)) img.disc(col_of(first), row_of(first), kMarkerRadius, kGreen);
  if (have_first && inside(last)) img.disc(col_of(last), row_of(last), kMarkerRadius, kBlue);
  img.finish();
  return img;
}

}  // namespace

void save_map_png(const GridMap& map, const std::vector<TimedPose>& trajectory,
                  const std::string& path, const OccupancyThresholds& th) {
  const detail::Raster r = detail::render(map, th, path);
  Overlay overlay = draw_trajectory(r, map.cell_size(), trajectory);
  const int u = kUnknownLevel;
  const Rgb tint{static_cast<std::uint8_t>(std::max(u - 15, 0)), static_cast<std::uint8_t>(u),
                 static_cast<std::uint8_t>(std::min(u + 15, 255))};
  // Row by row: each cell in its grey level (the unknown tint if never observed), unless the
  // overlay covers it.
  const auto fill_row = [&](int row, std::uint8_t* out) {
    for (int col = 0; col < r.width; ++col) {
      const auto j = static_cast<std::size_t>(row) * r.width + col;
      const std::uint8_t x = r.grey[j];
      const Rgb* drawn = overlay.at(j);
      const Rgb c = drawn != nullptr ? *drawn : r.known[j] ? Rgb{x, x, x} : tint;
      std::copy(c.begin(), c.end(), out + 3 * col);
    }
  };
  std::string png;
  try {
    png = detail::write_png(r.width, r.height, 3, fill_row);
  } catch (const std::exception& e) {
    throw std::runtime_error("cannot write '" + path + "': " + e.what());
  }
  write_file_atomically(path, png);
}

}  // namespace esfleet
