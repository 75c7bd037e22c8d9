#include "initial_pose_input.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>

#include "esfleet/dds/ros_msg.hpp"

namespace esfleet::follower {
namespace {
constexpr std::size_t kMaxQueued = 100;
}

PoseHint hint_window(const Pose2& pose, double sigma_xy, double sigma_theta) {
  return PoseHint{pose, std::max(0.1, 2.0 * sigma_xy),
                  std::clamp(rad_to_deg(2.0 * sigma_theta), 5.0, 180.0)};
}

InitialPoseInput::InitialPoseInput(dds::Node& node, const std::string& topic, std::string map_frame)
    : map_frame_(std::move(map_frame)),
      reader_(std::make_unique<dds::RosPoseReader>(
          node,
          [this](const geometry_msgs::msg::PoseWithCovarianceStamped& m,
                 const dds::SampleMeta& meta) {
            std::lock_guard lock(mutex_);
            ++received_;
            if (queue_.size() >= kMaxQueued) queue_.pop_front();
            queue_.emplace_back(m, meta.writer_guid);
          },
          dds::ros_initialpose_endpoint(topic))) {}

InitialPoseInput::~InitialPoseInput() { reader_.reset(); }

void InitialPoseInput::drop(const std::string& kind, const std::string& sender,
                            const std::string& why) {
  ++dropped_[kind];
  if (logged_.insert({sender, kind}).second) {
    spdlog::warn("dropping /initialpose from {}: {} (further ones only counted)", sender, why);
  }
}

std::optional<PoseHint> InitialPoseInput::take() {
  decltype(queue_) arrived;
  {
    std::lock_guard lock(mutex_);
    arrived.swap(queue_);
  }
  std::optional<PoseHint> hint;
  for (const auto& [m, sender] : arrived) {
    try {
      const dds::RosPoseHint h = dds::hint_from_ros(m);
      if (h.frame != map_frame_) {
        drop("initialpose_wrong_frame", sender,
             "frame '" + h.frame + "' is not the map's ('" + map_frame_ + "')");
        continue;
      }
      hint = hint_window(h.pose, h.sigma_xy, h.sigma_theta);
      ++used_;
    } catch (const dds::RosMessageError& e) {
      drop(e.kind(), sender, e.what());
    }
  }
  return hint;
}

nlohmann::json InitialPoseInput::json() const {
  std::lock_guard lock(mutex_);
  return {{"received", received_}, {"used", used_}, {"dropped", dropped_}};
}

}  // namespace esfleet::follower
