#include "status_table.hpp"

#include <spdlog/fmt/fmt.h>

#include <cmath>
#include <sstream>

#include "app/summary.hpp"

namespace esfleet::fleet {

namespace {
double mb(std::uint64_t kb) { return static_cast<double>(kb) / 1024.0; }
double median_of(std::vector<double> v) { return app::summarize(std::move(v)).median; }
}  // namespace

const char* status_name(std::uint8_t s) {
  switch (s) {
    case kStatusMapping:
      return "mapping";
    case kStatusWaitingForMap:
      return "waiting-map";
    case kStatusLocalising:
      return "localising";
    case kStatusTracking:
      return "tracking";
    case kStatusLost:
      return "lost";
    default:
      return "-";
  }
}

std::string StatusTable::legend(const Tolerance& wrong) {
  return fmt::format(
      "Robot columns: state = what the follower reports (waiting-map, localising, tracking, "
      "lost); localised = time from the followers' start to its first declared pose; err m = "
      "distance of its last pose from the simulator's truth; med m = median of that while "
      "tracking; CPU % and MB = the follower process over the last second; poses/s = poses it "
      "published per second. WRONG POSE DECLARED: a declared pose more than {:.1f} m or {:.0f} "
      "deg from the truth.\n",
      wrong.xy_m, wrong.theta_rad * 180.0 / M_PI);
}

std::string StatusTable::render(const StatusHeader& h, const ChildProcess& leader,
                                const ChildProcess& sim, const std::vector<ChildProcess>& followers,
                                const FleetMonitor& monitor, double dt) {
  std::ostringstream o;
  o << fmt::format("esfleet fleet: {} robots, domain {}, {:.0f} s{}\n", h.robots, h.domain, h.now_s,
                   h.duration_s > 0 ? fmt::format(" of {:.0f}", h.duration_s) : "");
  const auto& m = h.map;
  o << fmt::format(
      "  leader  {:>4.0f}% CPU {:>5.0f} MB  map: {}\n", leader.cpu_percent, mb(leader.rss_kb),
      m ? fmt::format("{} tiles, {} scans{}", m->tiles, m->scans, m->complete ? ", complete" : "")
        : std::string("none yet"));
  o << fmt::format("  sim     {:>4.0f}% CPU {:>5.0f} MB\n", sim.cpu_percent, mb(sim.rss_kb));
  o << fmt::format("  {:<10} {:<11} {:>9} {:>7} {:>7} {:>6} {:>6} {:>7}\n", "robot", "state",
                   "localised", "err m", "med m", "CPU %", "MB", "poses/s");
  for (const ChildProcess& f : followers) {
    const RobotReport& r = monitor.robots().at(f.name);
    const std::size_t before = poses_at_last_render_[f.name];
    poses_at_last_render_[f.name] = r.poses;
    o << fmt::format(
        "  {:<10} {:<11} {:>9} {:>7} {:>7} {:>6.0f} {:>6.0f} {:>7.1f}{}\n", f.name,
        f.exited ? "EXITED" : status_name(r.status),
        r.localised_s ? fmt::format("{:.1f} s", *r.localised_s - h.followers_start_s) : "-",
        r.last_error_xy_m ? fmt::format("{:.2f}", *r.last_error_xy_m) : "-",
        r.error_xy_m.empty() ? "-" : fmt::format("{:.2f}", median_of(r.error_xy_m)), f.cpu_percent,
        mb(f.rss_kb), dt > 0 ? static_cast<double>(r.poses - before) / dt : 0.0,
        r.wrong_declarations > 0 ? "  WRONG POSE DECLARED" : "");
  }
  return o.str();
}

}  // namespace esfleet::fleet
