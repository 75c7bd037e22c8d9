#include "fleet_summary.hpp"

#include <spdlog/fmt/fmt.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <thread>

#include "app/summary.hpp"
#include "status_table.hpp"

namespace esfleet::fleet {

namespace {

double mb(std::uint64_t kb) { return static_cast<double>(kb) / 1024.0; }

/// CPU share of a core over the window, percent; -1 when the window is too short to say.
double window_cpu_percent(const ChildProcess& c, double window_s) {
  return window_s > 1.0 ? 100.0 * (c.cpu_s() - c.cpu_s_at_window) / window_s : -1.0;
}

nlohmann::json process_summary(const ChildProcess& c, double window_s) {
  return {{"cpu_s", c.cpu_s()},
          {"rss_mb_max", mb(c.rss_kb_max)},
          {"cpu_percent_window", window_cpu_percent(c, window_s)},
          {"exit_code", c.exit_code},
          {"restarts", c.restarts},
          {"exit_codes_before_restarts", c.deaths}};
}

}  // namespace

nlohmann::json follower_summary(const ChildProcess& f, const RobotReport& r,
                                const nlohmann::json& stats, const FleetTimes& t, double rate_hz) {
  const double window_s = t.window_s();
  const double period_ms = 1000.0 / rate_hz;
  const nlohmann::json loc = stats.value("localisation", nlohmann::json::object());
  const std::uint64_t dropped = loc.value("scans_dropped_tracking", std::uint64_t{0});
  const double lag_p95 = loc.value("tracking_lag_ms_p95", 0.0);
  // Real time: in the window where all track, (almost) every scan the simulator sent got a
  // pose (>= 98 %), and 95 % of them within one scan period of the scan's arrival.
  const double processed = r.window_truth > 0 ? static_cast<double>(r.window_tracking_poses) /
                                                    static_cast<double>(r.window_truth)
                                              : 0.0;
  const bool rt = window_s >= 10.0 && processed >= 0.98 && lag_p95 < period_ms;
  const app::Summary exy = app::summarize(r.error_xy_m);
  std::vector<double> eth_deg;
  for (double e : r.error_theta_rad) eth_deg.push_back(e * 180.0 / M_PI);
  const app::Summary eth = app::summarize(eth_deg);
  return {
      {"robot_id", f.name},
      {"final_state", status_name(r.status)},
      {"last_error_m", r.last_error_xy_m ? *r.last_error_xy_m : -1.0},
      {"localised", r.localised_s.has_value()},
      {"time_to_localise_s", r.localised_s ? *r.localised_s - t.followers_start_s : -1.0},
      {"first_pose_error_m", r.first_error_xy_m ? *r.first_error_xy_m : -1.0},
      {"first_pose_error_deg",
       r.first_error_theta_rad ? *r.first_error_theta_rad * 180.0 / M_PI : -1.0},
      {"declarations", r.declarations},
      {"wrong_declarations", r.wrong_declarations},
      {"lost_events", r.lost_events},
      {"tracking_poses_scored", r.matched},
      {"tracking_error_m_median", exy.median},
      {"tracking_error_m_p95", exy.p95},
      {"tracking_error_m_max", exy.max},
      {"tracking_error_deg_median", eth.median},
      {"tracking_error_deg_p95", eth.p95},
      {"cpu_s", f.cpu_s()},
      {"cpu_percent_window", window_cpu_percent(f, window_s)},
      {"window_scans", r.window_truth},
      {"window_poses", r.window_tracking_poses},
      {"window_processed", processed},
      {"rss_mb_max", mb(f.rss_kb_max)},
      {"bytes_received", stats.value("bytes_received", std::uint64_t{0})},
      {"map_tiles", stats.value("tiles", std::uint64_t{0})},
      {"scans_processed", loc.value("scans", std::size_t{0})},
      {"scans_dropped", loc.value("scans_dropped", std::uint64_t{0})},
      {"scans_dropped_tracking", dropped},
      {"tracking_lag_ms_median", loc.value("tracking_lag_ms_median", 0.0)},
      {"tracking_lag_ms_p95", lag_p95},
      {"tracking_cpu_ms_median", loc.value("tracking_cpu_ms_median", 0.0)},
      {"realtime", rt},
      {"started", f.started()},
      {"exit_code", f.started() ? f.exit_code : -1},
      {"restarts", f.restarts},
      {"exit_codes_before_restarts", f.deaths},
  };
}

FleetSummary build_summary(const FleetOptions& o, const FleetTimes& t, const std::string& failure,
                           const ChildProcess& leader, const ChildProcess& sim,
                           const std::vector<ChildProcess>& followers, const FleetMonitor& monitor,
                           const std::vector<nlohmann::json>& follower_stats) {
  FleetSummary s;
  nlohmann::json jf = nlohmann::json::array();
  for (std::size_t i = 0; i < followers.size(); ++i) {
    const ChildProcess& f = followers[i];
    const RobotReport& r = monitor.robots().at(f.name);
    const nlohmann::json stats =
        i < follower_stats.size() ? follower_stats[i] : nlohmann::json::object();
    nlohmann::json j = follower_summary(f, r, stats, t, o.rate);
    s.localised += r.localised_s ? 1 : 0;
    s.realtime += j["realtime"].get<bool>() ? 1 : 0;
    s.wrong += r.wrong_declarations > 0 ? 1 : 0;
    jf.push_back(std::move(j));
  }
  int restarts = 0;
  for (const ChildProcess& f : followers) restarts += f.restarts;
  s.json = {
      {"robots", o.robots},
      {"follower_restarts", restarts},
      {"leader_restarts", leader.restarts},
      {"duration_s", t.end_s},
      {"followers_started_s", t.followers_start_s},
      {"all_tracking_s", t.window_start_s >= 0 ? t.window_start_s - t.followers_start_s : -1.0},
      {"window_s", t.window_s()},
      {"rate_hz", o.rate},
      {"domain", o.domain},
      {"profile", o.profile},
      {"seed", o.seed},
      {"cores", std::thread::hardware_concurrency()},
      {"localised", s.localised},
      {"realtime", s.realtime},
      {"robots_with_wrong_pose", s.wrong},
      {"all_localised", s.localised == o.robots},
      {"all_realtime", s.realtime == o.robots},
      {"failure", failure},
      {"leader", process_summary(leader, t.window_s())},
      {"sim", process_summary(sim, t.window_s())},
      {"followers", jf},
  };
  return s;
}

std::string summary_line(const FleetSummary& s, int robots, const std::string& path) {
  return fmt::format("fleet of {}: {} localised, {} in real time, {} with a wrong pose; summary {}",
                     robots, s.localised, s.realtime, s.wrong, path);
}

nlohmann::json read_stats_json(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  try {
    return nlohmann::json::parse(ss.str());
  } catch (const std::exception&) {
    return nlohmann::json::object();
  }
}

}  // namespace esfleet::fleet
