#include "esfleet/core/scan_icp.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace esfleet {

namespace {

/// A reference end point with the line through it and its neighbours.
struct Line {
  double px, py;      ///< a point on the line (the neighbours' mean)
  double nx, ny;      ///< unit normal
  double x, y;        ///< the end point itself (what pairing measures to)
  std::size_t index;  ///< of the end point in its scan
};

/// Lines through the reference end points whose neighbours along the scan lie on one.
std::vector<Line> fit_lines(const ScanPoints& ref, const IcpConfig& c) {
  constexpr std::ptrdiff_t kHalfWindow = 3;
  std::vector<Line> lines;
  const auto n = static_cast<std::ptrdiff_t>(ref.size());
  const double r2 = c.line_radius * c.line_radius;
  for (std::ptrdiff_t i = 0; i < n; ++i) {
    double sx = 0.0, sy = 0.0, sxx = 0.0, sxy = 0.0, syy = 0.0;
    int count = 0;
    for (std::ptrdiff_t j = std::max<std::ptrdiff_t>(0, i - kHalfWindow);
         j <= std::min(n - 1, i + kHalfWindow); ++j) {
      const double dx = ref.x[j] - ref.x[i], dy = ref.y[j] - ref.y[i];
      if (dx * dx + dy * dy > r2) continue;
      sx += dx;
      sy += dy;
      sxx += dx * dx;
      sxy += dx * dy;
      syy += dy * dy;
      ++count;
    }
    if (count < 3) continue;
    const double mx = sx / count, my = sy / count;
    const double cxx = sxx / count - mx * mx, cxy = sxy / count - mx * my,
                 cyy = syy / count - my * my;
    // Smallest eigenvalue of the 2x2 covariance and its eigenvector: the line's normal.
    const double tr = cxx + cyy, det = cxx * cyy - cxy * cxy;
    const double lmin = 0.5 * tr - std::sqrt(std::max(0.0, 0.25 * tr * tr - det));
    if (lmin > c.max_line_rms * c.max_line_rms) continue;
    double nx = cxy, ny = lmin - cxx;  // (A - lmin I) n = 0
    if (std::hypot(nx, ny) < 1e-12) {
      nx = lmin - cyy;
      ny = cxy;
    }
    const double len = std::hypot(nx, ny);
    if (len < 1e-12) continue;  // all points at one spot: no direction
    lines.push_back({ref.x[i] + mx, ref.y[i] + my, nx / len, ny / len, ref.x[i], ref.y[i],
                     static_cast<std::size_t>(i)});
  }
  return lines;
}

/// The lines bucketed by a grid of max_distance cells, for nearest-point look-ups.
class LineGrid {
 public:
  LineGrid(const std::vector<Line>& lines, double cell) : lines_(lines), cell_(cell) {
    cells_.reserve(lines.size());
    for (std::size_t i = 0; i < lines.size(); ++i) {
      cells_.emplace_back(key(cell_of(lines[i].x), cell_of(lines[i].y)), i);
    }
    std::sort(cells_.begin(), cells_.end());
  }

  /// The line whose end point is nearest (x, y) within max_distance, or nullptr.
  const Line* nearest(double x, double y, double max_distance) const {
    const std::int64_t cx = cell_of(x), cy = cell_of(y);
    const Line* best = nullptr;
    double best_d2 = max_distance * max_distance;
    for (std::int64_t dy = -1; dy <= 1; ++dy) {
      for (std::int64_t dx = -1; dx <= 1; ++dx) {
        const std::int64_t k = key(cx + dx, cy + dy);
        auto it = std::lower_bound(cells_.begin(), cells_.end(), std::make_pair(k, std::size_t{0}));
        for (; it != cells_.end() && it->first == k; ++it) {
          const Line& l = lines_[it->second];
          const double d2 = (l.x - x) * (l.x - x) + (l.y - y) * (l.y - y);
          if (d2 < best_d2) {
            best_d2 = d2;
            best = &l;
          }
        }
      }
    }
    return best;
  }

 private:
  std::int64_t cell_of(double v) const { return static_cast<std::int64_t>(std::floor(v / cell_)); }
  static std::int64_t key(std::int64_t cx, std::int64_t cy) { return cx * 4194304 + cy; }

  const std::vector<Line>& lines_;
  double cell_;
  std::vector<std::pair<std::int64_t, std::size_t>> cells_;
};

}  // namespace

void IcpConfig::validate() const {
  auto positive = [](double v, const char* name) {
    if (!(v > 0.0) || !std::isfinite(v)) {
      throw std::invalid_argument(std::string("icp.") + name + " must be > 0");
    }
  };
  positive(max_distance, "max_distance");
  positive(line_radius, "line_radius");
  positive(max_line_rms, "max_line_rms");
  positive(huber, "huber");
  positive(point_sigma, "point_sigma");
  positive(prior_sigma_xy, "prior_sigma_xy");
  positive(prior_sigma_theta_deg, "prior_sigma_theta_deg");
  positive(max_move_xy, "max_move_xy");
  positive(max_move_theta_deg, "max_move_theta_deg");
  if (max_iterations < 1) throw std::invalid_argument("icp.max_iterations must be >= 1");
  if (!(min_pair_share >= 0.0 && min_pair_share <= 1.0)) {
    throw std::invalid_argument("icp.min_pair_share must be in [0, 1]");
  }
  if (!(degenerate_ratio >= 0.0 && degenerate_ratio < 1.0)) {
    throw std::invalid_argument("icp.degenerate_ratio must be in [0, 1)");
  }
  if (!(min_normal_cos >= 0.0 && min_normal_cos <= 1.0)) {
    throw std::invalid_argument("icp.min_normal_cos must be in [0, 1]");
  }
}

std::optional<IcpResult> align_scans(const ScanPoints& reference, const ScanPoints& moving,
                                     const Pose2& start, const IcpConfig& c) {
  const std::vector<Line> lines = fit_lines(reference, c);
  if (lines.size() < c.min_pairs) return std::nullopt;
  const LineGrid grid(lines, c.max_distance);
  // The moving points' own line normals (0, 0: none), for the normal check.
  std::vector<std::pair<double, double>> own;
  if (c.min_normal_cos > 0.0) {
    own.assign(moving.size(), {0.0, 0.0});
    for (const Line& l : fit_lines(moving, c)) own[l.index] = {l.nx, l.ny};
  }
  const double w_point = 1.0 / (c.point_sigma * c.point_sigma);
  const double w_xy = 1.0 / (c.prior_sigma_xy * c.prior_sigma_xy);
  const double w_theta = 1.0 / std::pow(deg_to_rad(c.prior_sigma_theta_deg), 2);

  IcpResult out;
  Pose2 pose = start;
  // One pass over the moving points at `pose`: pairs, squared distances, and (when asked) the
  // Gauss-Newton system.
  auto pass = [&](Eigen::Matrix3d* h, Eigen::Vector3d* g, double* sum_sq) {
    const double cs = std::cos(pose.theta), sn = std::sin(pose.theta);
    std::size_t pairs = 0;
    for (std::size_t i = 0; i < moving.size(); ++i) {
      const double bx = moving.x[i], by = moving.y[i];
      const double qx = pose.x + cs * bx - sn * by, qy = pose.y + sn * bx + cs * by;
      const Line* l = grid.nearest(qx, qy, c.max_distance);
      if (l == nullptr) continue;
      if (!own.empty()) {
        const auto [ox, oy] = own[i];
        if (ox == 0.0 && oy == 0.0) continue;
        // Normals have no sign: compare the cosine's magnitude.
        if (std::abs(l->nx * (cs * ox - sn * oy) + l->ny * (sn * ox + cs * oy)) <
            c.min_normal_cos) {
          continue;
        }
      }
      const double r = l->nx * (qx - l->px) + l->ny * (qy - l->py);
      ++pairs;
      *sum_sq += r * r;
      if (h == nullptr) continue;
      const Eigen::Vector3d j(l->nx, l->ny,
                              l->nx * (-sn * bx - cs * by) + l->ny * (cs * bx - sn * by));
      const double ar = std::abs(r);
      const double w = w_point * (ar <= c.huber ? 1.0 : c.huber / ar);
      *h += w * j * j.transpose();
      *g += w * r * j;
    }
    return pairs;
  };
  for (out.iterations = 1; out.iterations <= c.max_iterations; ++out.iterations) {
    Eigen::Matrix3d h = Eigen::Vector3d(w_xy, w_xy, w_theta).asDiagonal();
    Eigen::Vector3d g(w_xy * (pose.x - start.x), w_xy * (pose.y - start.y),
                      w_theta * normalize_angle(pose.theta - start.theta));
    double sum_sq = 0.0;
    pass(&h, &g, &sum_sq);
    const Eigen::Vector3d step = -h.ldlt().solve(g);
    if (!step.allFinite()) return std::nullopt;
    pose = {pose.x + step.x(), pose.y + step.y(), normalize_angle(pose.theta + step.z())};
    if (std::hypot(step.x(), step.y()) < 1e-5 && std::abs(step.z()) < 1e-6) break;
  }
  out.iterations = std::min(out.iterations, c.max_iterations);
  if (c.degenerate_ratio > 0.0) {
    // How well the pairs alone (no prior) constrain the translation at the result.
    Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    double unused = 0.0;
    pass(&h, &g, &unused);
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(h.topLeftCorner<2, 2>());
    const double weakest = eig.eigenvalues()(0), strongest = eig.eigenvalues()(1);
    if (strongest > 0.0 && weakest < c.degenerate_ratio * strongest) {
      const Eigen::Vector2d weak = eig.eigenvectors().col(0);
      const Eigen::Vector2d moved(pose.x - start.x, pose.y - start.y);
      const Eigen::Vector2d kept = moved - weak * weak.dot(moved);
      pose.x = start.x + kept.x();
      pose.y = start.y + kept.y();
      out.held_along = true;
    }
  }
  double sum_sq = 0.0;
  out.pairs = pass(nullptr, nullptr, &sum_sq);
  const double needed = std::max(static_cast<double>(c.min_pairs),
                                 c.min_pair_share * static_cast<double>(moving.size()));
  if (static_cast<double>(out.pairs) < needed) return std::nullopt;
  out.rms = std::sqrt(sum_sq / static_cast<double>(out.pairs));
  if (!same_place(pose, start, c.max_move_xy, deg_to_rad(c.max_move_theta_deg))) {
    return std::nullopt;
  }
  out.relative = pose;
  return out;
}

}  // namespace esfleet
