#include "fleet_monitor.hpp"

#include <cmath>
#include <sstream>

namespace esfleet::fleet {

namespace {
/// Stamps travel as the same double from the scan to both the truth and the pose sample; the
/// tolerance only guards against a future conversion through float.
bool same_stamp(double a, double b) { return std::abs(a - b) < 1e-6; }
}  // namespace

double angle_diff(double a, double b) {
  double d = std::remainder(a - b, 2.0 * M_PI);
  if (d <= -M_PI) d += 2.0 * M_PI;
  return d;
}

void FleetMonitor::add_robot(const std::string& id) {
  robots_[id].id = id;
  buffers_[id];
}

bool FleetMonitor::all_tracking() const {
  if (robots_.empty()) return false;
  for (const auto& [id, r] : robots_) {
    if (r.status != kStatusTracking) return false;
  }
  return true;
}

void FleetMonitor::start_window() {
  window_ = true;
  for (auto& [id, r] : robots_) {
    r.window_truth = 0;
    r.window_tracking_poses = 0;
  }
}

void FleetMonitor::score(RobotReport& r, const Pending& p, const TruthSample& t) {
  const double exy = std::hypot(p.pose.x - t.x, p.pose.y - t.y);
  const double eth = std::abs(angle_diff(p.pose.theta, t.theta));
  ++r.matched;
  r.error_xy_m.push_back(exy);
  r.error_theta_rad.push_back(eth);
  r.last_error_xy_m = exy;
  if (p.declaration) {
    if (!r.first_error_xy_m) {
      r.first_error_xy_m = exy;
      r.first_error_theta_rad = eth;
    }
    if (exy > tolerance_.xy_m || eth > tolerance_.theta_rad) ++r.wrong_declarations;
  }
}

void FleetMonitor::on_truth(const TruthSample& t) {
  auto b = buffers_.find(t.robot_id);
  if (b == buffers_.end()) {
    ++ignored_;
    return;
  }
  if (window_) ++robots_[t.robot_id].window_truth;
  auto& pending = b->second.pending;
  for (auto it = pending.begin(); it != pending.end();) {
    if (same_stamp(it->pose.stamp, t.stamp)) {
      score(robots_[t.robot_id], *it, t);
      it = pending.erase(it);
    } else {
      ++it;
    }
  }
  auto& truth = b->second.truth;
  truth.push_back(t);
  if (truth.size() > kTruthKept) truth.pop_front();
}

void FleetMonitor::on_pose(const PoseSample& p, double now_s) {
  auto rit = robots_.find(p.robot_id);
  if (rit == robots_.end()) {
    ++ignored_;
    return;
  }
  RobotReport& r = rit->second;
  const bool declaration = p.status == kStatusTracking && r.status != kStatusTracking;
  if (p.status == kStatusLost && r.status != kStatusLost) ++r.lost_events;
  r.status = p.status;
  ++r.poses;
  if (!r.first_pose_s) r.first_pose_s = now_s;
  if (p.status != kStatusTracking) return;
  ++r.tracking_poses;
  if (window_) ++r.window_tracking_poses;
  if (declaration) {
    ++r.declarations;
    if (!r.localised_s) r.localised_s = now_s;
  }
  Buffers& b = buffers_[p.robot_id];
  const Pending pending{p, declaration};
  // Newest first: the truth of a just-processed scan is near the back.
  for (auto it = b.truth.rbegin(); it != b.truth.rend(); ++it) {
    if (same_stamp(it->stamp, p.stamp)) {
      score(r, pending, *it);
      return;
    }
  }
  b.pending.push_back(pending);
  if (b.pending.size() > kPendingKept) b.pending.pop_front();
}

std::optional<std::uint64_t> parse_proc_stat_ticks(const std::string& stat) {
  const auto close = stat.rfind(')');
  if (close == std::string::npos) return std::nullopt;
  std::istringstream in(stat.substr(close + 1));
  // Fields after the command: state(3) ppid pgrp session tty_nr tpgid flags minflt cminflt
  // majflt cmajflt utime(14) stime(15).
  std::string field;
  std::uint64_t utime = 0, stime = 0;
  for (int i = 3; i <= 15; ++i) {
    if (!(in >> field)) return std::nullopt;
    try {
      if (i == 14) utime = std::stoull(field);
      if (i == 15) stime = std::stoull(field);
    } catch (const std::exception&) {
      return std::nullopt;
    }
  }
  return utime + stime;
}

std::optional<std::uint64_t> parse_proc_status_rss_kb(const std::string& status) {
  std::istringstream in(status);
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("VmRSS:", 0) == 0) {
      try {
        return std::stoull(line.substr(6));
      } catch (const std::exception&) {
        return std::nullopt;
      }
    }
  }
  return std::nullopt;
}

}  // namespace esfleet::fleet
