#include "self_localisation.hpp"

#include <spdlog/spdlog.h>

#include <esfleet/msg/esfleet.h>

#include "app/summary.hpp"

namespace esfleet::follower {

std::uint8_t status_of(LocaliserState s) {
  switch (s) {
    case LocaliserState::kWaitingForMap:
      return msg::kStatusWaitingForMap;
    case LocaliserState::kLocalising:
      return msg::kStatusLocalising;
    case LocaliserState::kTracking:
      return msg::kStatusTracking;
    case LocaliserState::kLost:
      return msg::kStatusLost;
  }
  return msg::kStatusLost;
}

LocaliserStep SelfLocalisation::process(const mapshare::MapReplica& replica,
                                        const LaserScan& scan) {
  ++stats_.scans;
  if (replica.has_map() && epoch_ && replica.epoch() != *epoch_) {
    spdlog::warn("the leader's map changed (epoch {} -> {}): localising afresh", *epoch_,
                 replica.epoch());
    localiser_.reset();
  }
  if (replica.has_map()) epoch_ = replica.epoch();
  static const GridMap kEmpty;
  const LocaliserStep step = localiser_.process(replica.has_map() ? replica.map() : kEmpty, scan);
  last_ = step;
  stats_.cpu_s_total += step.cpu_ms * 1e-3;
  if (step.global_search) ++stats_.global_searches;
  if (step.state == LocaliserState::kWaitingForMap) {
    ++stats_.scans_waiting_for_map;
  } else if (step.state != LocaliserState::kTracking || step.declared) {
    cpu_s_localising_ += step.cpu_ms * 1e-3;
    ++scans_localising_;
  }
  if (step.declared) {
    ++stats_.declarations;
    if (!stats_.first_pose) {
      stats_.first_pose = TimedPose{scan.stamp, step.pose};
      stats_.cpu_s_to_first_pose = cpu_s_localising_;
      stats_.scans_to_first_pose = scans_localising_;
    }
    spdlog::info(
        "localised at ({:.2f}, {:.2f}, {:.1f} deg) after {} scans, {:.2f} s CPU "
        "(evidence {:.2f}, agreement {:.2f})",
        step.pose.x, step.pose.y, rad_to_deg(step.pose.theta), scans_localising_, cpu_s_localising_,
        step.score, step.value.agreement());
    cpu_s_localising_ = 0.0;
    scans_localising_ = 0;
  }
  if (step.lost) {
    ++stats_.lost_events;
    spdlog::warn("lost: the scans stopped matching the map; relocalising");
  }
  if (step.state == LocaliserState::kTracking) {
    trajectory_.push_back({scan.stamp, step.pose});
    if (!step.declared) stats_.tracking_cpu_ms.push_back(step.cpu_ms);
  }
  return step;
}

void SelfLocalisation::reset() {
  localiser_.reset();
  ++resets_;
  cpu_s_localising_ = 0.0;
  scans_localising_ = 0;
}

nlohmann::json SelfLocalisation::json(const std::string& robot_id) const {
  const app::Summary tr = app::summarize(stats_.tracking_cpu_ms);
  nlohmann::json j = {{"robot_id", robot_id},
                      {"state", to_string(localiser_.state())},
                      {"scans", stats_.scans},
                      {"scans_waiting_for_map", stats_.scans_waiting_for_map},
                      {"declarations", stats_.declarations},
                      {"lost_events", stats_.lost_events},
                      {"global_searches", stats_.global_searches},
                      {"cpu_s_total", stats_.cpu_s_total},
                      {"cpu_s_to_first_pose", stats_.cpu_s_to_first_pose},
                      {"scans_to_first_pose", stats_.scans_to_first_pose},
                      {"tracked_scans", trajectory_.size()},
                      {"resets", resets_},
                      {"tracking_cpu_ms_median", tr.median},
                      {"tracking_cpu_ms_p95", tr.p95}};
  if (stats_.first_pose) {
    j["first_pose"] = {{"stamp", stats_.first_pose->stamp},
                       {"x", stats_.first_pose->pose.x},
                       {"y", stats_.first_pose->pose.y},
                       {"theta", stats_.first_pose->pose.theta}};
  }
  return j;
}

}  // namespace esfleet::follower
