#include "contributor.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

#include "esfleet/dds/from_msg.hpp"
#include "esfleet/dds/topics.hpp"

namespace esfleet::follower {

void ContributorConfig::validate() const {
  send.validate();
  if (max_rejections < 1) throw std::invalid_argument("--contribute-max-rejections must be >= 1");
  if (!std::isfinite(pose_offset.x) || !std::isfinite(pose_offset.y) ||
      !std::isfinite(pose_offset.theta)) {
    throw std::invalid_argument("--contribute-pose-offset must be finite");
  }
  if (!(settle_s >= 0.0)) throw std::invalid_argument("contribution settle_s must be >= 0");
}

Contributor::Contributor(dds::Node& node, std::string robot_id, ContributorConfig config)
    : robot_id_(std::move(robot_id)), config_(config) {
  writer_ = std::make_unique<dds::ContributionWriter>(node, robot_id_);
  reader_ = std::make_unique<dds::ContributionStatusReader>(
      node,
      [this](const msg::ContributionStatus& m, const dds::SampleMeta&) {
        if (m.robot_id().to_string() != robot_id_) return;
        std::lock_guard lock(mutex_);
        try {
          status_ = dds::contribution_status_from_msg(m);
        } catch (const std::exception&) {
          ++malformed_;
        }
      },
      robot_id_);
}

// The reader first: its callback uses the members.
Contributor::~Contributor() {
  reader_.reset();
  writer_.reset();
}

bool Contributor::after_scan(const LaserScan& scan, const LocaliserStep& step, bool was_tracking,
                             const mapshare::MapReplica& replica) {
  if (!was_tracking || step.state != LocaliserState::kTracking || step.declared) return false;
  if (!replica.has_map()) return false;
  if (!worth_contributing(config_.send, step.value, step.pose, last_sent_)) return false;
  Contribution c;
  c.robot = robot_id_;
  c.seq = seq_ + 1;
  c.scan = scan;
  c.pose = Pose2{step.pose.x + config_.pose_offset.x, step.pose.y + config_.pose_offset.y,
                 normalize_angle(step.pose.theta + config_.pose_offset.theta)};
  const dds::ContributionClaim claim{replica.map_id(), replica.epoch(), step.value.agreement(),
                                     static_cast<float>(step.value.known_share())};
  if (!writer_->write(dds::contribution_to_msg(c, claim))) return false;
  seq_ = c.seq;
  ++sent_;
  last_sent_ = step.pose;
  return true;
}

bool Contributor::take_relocalise() {
  dds::ContributionTally s;
  {
    std::lock_guard lock(mutex_);
    if (!status_ || status_->stamp_ns == acted_stamp_) return false;
    s = *status_;
  }
  acted_stamp_ = s.stamp_ns;
  // Only the rejections of contributions made since the last relocalisation count: the
  // leader's row may still hold the ones before.
  const std::uint32_t since = s.last_seq > reset_seq_ ? s.last_seq - reset_seq_ : 0;
  const std::uint32_t in_row = std::min(s.rejected_in_row, since);
  if (in_row < static_cast<std::uint32_t>(config_.max_rejections)) return false;
  ++relocalisations_;
  reset_seq_ = seq_;
  last_sent_.reset();
  spdlog::warn(
      "the leader refused this robot's last {} contributed scans (the last as {}; {} accepted, "
      "{} refused in all): its pose is likely wrong; localising afresh",
      in_row, to_string(s.last_verdict), s.accepted, s.rejected);
  return true;
}

bool Contributor::answered() const {
  if (seq_ == 0) return true;
  std::lock_guard lock(mutex_);
  return status_ && status_->last_seq >= seq_;
}

nlohmann::json Contributor::json() const {
  std::lock_guard lock(mutex_);
  nlohmann::json j = {{"sent", sent_},
                      {"bytes", writer_->bytes_written()},
                      {"accepted", status_ ? status_->accepted : 0},
                      {"rejected", status_ ? status_->rejected : 0},
                      {"relocalisations", relocalisations_},
                      {"min_agreement", config_.send.min_agreement},
                      {"min_known", config_.send.min_known},
                      {"min_travel_m", config_.send.min_travel},
                      {"min_turn_deg", config_.send.min_turn_deg},
                      {"max_rejections", config_.max_rejections},
                      {"malformed_status", malformed_}};
  if (status_) j["last_verdict"] = to_string(status_->last_verdict);
  return j;
}

}  // namespace esfleet::follower
