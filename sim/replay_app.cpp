#include "replay_app.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <string>
#include <thread>

#include "app/program.hpp"
#include "esfleet/core/carmen_reader.hpp"
#include "esfleet/dds/to_msg.hpp"

namespace esfleet::sim {

using app::UsageError;

namespace {

using Clock = std::chrono::steady_clock;

/// How often blocked waits look at the stop flag.
constexpr std::chrono::milliseconds kPoll{100};
/// At the end, how long to wait for the readers to acknowledge the last scans.
constexpr std::chrono::seconds kFinalAckTimeout{10};

}  // namespace

double ReplayApp::wait_for_acks() {
  const auto start = Clock::now();
  bool warned = false;
  while (!acknowledged(kPoll) && !stop_.load()) {
    if (!warned && Clock::now() - start > std::chrono::seconds(5)) {
      spdlog::warn("scans up to seq {} not acknowledged for 5 s by {} reader(s); waiting", seq_ - 1,
                   matched_readers());
      warned = true;
    }
  }
  return std::chrono::duration<double>(Clock::now() - start).count();
}

int ReplayApp::matched_readers() const {
  return ros_ ? ros_->matched_scan_readers() : writer_->matched_readers();
}

std::string ReplayApp::scan_topic() const {
  return ros_ ? ros_->scan_topic() : std::string(writer_->topic_name());
}

bool ReplayApp::acknowledged(std::chrono::milliseconds timeout) const {
  return ros_ ? ros_->wait_for_acknowledgments(timeout)
              : writer_->wait_for_acknowledgments(timeout);
}

ReplayApp::ReplayApp(ReplayOptions options, const std::atomic<bool>& stop)
    : o_(std::move(options)), stop_(stop) {
  try {
    scans_ = read_carmen_log(o_.log, {}, o_.max_scans, &stop_);
  } catch (const std::exception& e) {
    throw UsageError(e.what());  // LogError: "<file>:<line>: ..."
  }
  if (o_.first_scan >= scans_.size()) {
    throw UsageError("--first-scan " + std::to_string(o_.first_scan) + ": " + o_.log +
                     " has only " + std::to_string(scans_.size()) + " scans" +
                     (o_.max_scans > 0 ? " (with --max-scans)" : ""));
  }
  scans_.erase(scans_.begin(), scans_.begin() + static_cast<std::ptrdiff_t>(o_.first_scan));
  spdlog::info("{}: {} scans over {:.1f} s of log; robot '{}', rate {}{}, odometry {}", o_.log,
               scans_.size(), scans_.back().stamp - scans_.front().stamp, o_.robot_id, o_.rate,
               o_.rate > 0.0 ? ""
               : o_.ros      ? " (500 scans/s at most: ROS scan readers are best-effort)"
                             : " (as fast as acknowledged)",
               o_.odometry ? "on" : "off");

  try {
    node_ = std::make_unique<dds::Node>(
        dds::NodeOptions{o_.domain, o_.profile, "esfleet-replay", o_.secure});
  } catch (const std::exception& e) {
    throw UsageError(fmt::format("DDS participant on domain {}: {}", o_.domain, e.what()));
  }
  if (o_.ros) {
    app::setup_step("DDS ROS 2 writers in namespace " + o_.ros_ns(), [&] {
      ros_ = std::make_unique<RosReplayWriter>(
          *node_, RosReplayWriter::Config{o_.ros_ns(), o_.odom_frame, o_.base_frame, o_.laser_frame,
                                          o_.laser_pose, o_.odometry});
    });
    spdlog::info("ROS 2: {} in frame {}{}; /tf_static {} -> {}", ros_->scan_topic(),
                 ros_->laser_frame(),
                 o_.odometry ? fmt::format(", {} and /tf {} -> {}", ros_->odom_topic(),
                                           ros_->odom_frame(), ros_->base_frame())
                             : std::string(),
                 ros_->base_frame(), ros_->laser_frame());
    return;
  }
  try {
    // In the robot's partition: readers of this robot get only its scans (docs/security.md).
    writer_ = std::make_unique<dds::ScanWriter>(*node_, o_.robot_id);
  } catch (const std::exception& e) {
    throw UsageError(fmt::format("DDS scan writer of {}: {}", o_.robot_id, e.what()));
  }
}

ReplayApp::~ReplayApp() {
  writer_.reset();  // before the node (node.hpp)
  ros_.reset();
  node_.reset();
}

int ReplayApp::run() {
  wait_for_readers();
  // The laser mount, once, stamped with the log's first time (transient-local: late joiners
  // get it too).
  if (ros_ && !stop_.load() && !ros_->publish_static(scans_.front().stamp)) {
    spdlog::warn("DDS refused the /tf_static transform");
  }
  const auto start = Clock::now();
  const double ack_wait_s = send_scans(start);
  const double send_s = std::chrono::duration<double>(Clock::now() - start).count();
  const bool interrupted = stop_.load();

  // Scans still in flight die with the process unless the readers have them; bounded wait.
  const auto final_timeout =
      interrupted ? std::chrono::milliseconds(1000) : std::chrono::milliseconds(kFinalAckTimeout);
  const bool acked = acknowledged(final_timeout);
  if (!acked) {
    spdlog::warn("{} reader(s) did not acknowledge every scan within {} s", matched_readers(),
                 final_timeout.count() / 1000);
  }
  const std::uint64_t sent = ros_ ? ros_->scans_written() : writer_->samples_written();
  const std::uint64_t bytes = ros_ ? ros_->bytes_written() : writer_->bytes_written();
  const std::uint64_t failures = ros_ ? ros_->write_failures() : writer_->write_failures();
  spdlog::info(
      "{}sent {} scans{}{} in {:.2f} s: {:.0f} scans/s, {:.1f} kB; {:.2f} s waiting for "
      "acknowledgments; {} write failures; {} reader(s){}, {}",
      interrupted ? "interrupted: " : "", sent,
      seq_ > 0 ? fmt::format(" (seq 0..{})", seq_ - 1) : std::string(),
      ros_ ? fmt::format(" on {} with {} odometry on {} and /tf", ros_->scan_topic(),
                         ros_->odometry_written(), ros_->odom_topic())
           : std::string(),
      send_s, send_s > 0 ? static_cast<double>(sent) / send_s : 0.0,
      static_cast<double>(bytes) / 1e3, ack_wait_s, failures, matched_readers(),
      ros_ ? " of " + ros_->scan_topic() : std::string(),
      acked ? "all acknowledged" : "NOT all acknowledged");
  writer_.reset();  // before the node (node.hpp)
  ros_.reset();
  return interrupted ? app::kExitInterrupted : app::kExitOk;
}

void ReplayApp::wait_for_readers() {
  if (o_.wait_subscribers <= 0) return;
  spdlog::info("waiting up to {} s for {} reader(s) of {} on domain {}", o_.wait_timeout,
               o_.wait_subscribers, scan_topic(), o_.domain);
  const auto deadline = Clock::now() + std::chrono::duration<double>(o_.wait_timeout);
  while (!stop_.load() && Clock::now() < deadline &&
         !(ros_ ? ros_->wait_for_scan_readers(o_.wait_subscribers, kPoll)
                : writer_->wait_for_matched(o_.wait_subscribers, kPoll))) {
  }
  if (stop_.load()) {
    // Stopped before the first scan: nothing was sent.
  } else if (matched_readers() < o_.wait_subscribers) {
    spdlog::warn("only {} of {} reader(s) matched after {} s: starting anyway", matched_readers(),
                 o_.wait_subscribers, o_.wait_timeout);
  } else {
    spdlog::info("{} reader(s) matched: starting", matched_readers());
  }
}

namespace {
/// --ros at --rate 0: the gap between two scans (at most 500 scans per second).
constexpr auto kRosGap = std::chrono::milliseconds(2);
}  // namespace

double ReplayApp::send_scans(std::chrono::steady_clock::time_point start) {
  const std::size_t every = std::max<std::size_t>(1, scans_.size() / 10);
  double ack_wait_s = 0.0;
  for (std::size_t i = 0; i < scans_.size() && !stop_.load(); ++i) {
    if (o_.rate > 0.0) {
      const auto due =
          start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(
                      (scans_[i].stamp - scans_.front().stamp) / o_.rate));
      while (Clock::now() < due && !stop_.load()) {
        std::this_thread::sleep_until(std::min(due, Clock::now() + kPoll));
      }
      if (stop_.load()) break;
    } else if (ros_ && i > 0) {
      // ROS scan readers are best-effort: nothing throttles the writer, so --rate 0 means at
      // most 500 scans per second (a burst would overflow the transport's buffers).
      std::this_thread::sleep_for(kRosGap);
    }
    if (!o_.odometry) scans_[i].odometry.reset();
    const bool written = ros_ ? ros_->publish(scans_[i])
                              : writer_->write(dds::scan_to_msg(o_.robot_id, seq_, scans_[i]));
    if (!written) spdlog::warn("DDS refused scan seq {}", seq_);
    ++seq_;
    if (seq_ % kAckWindow == 0) ack_wait_s += wait_for_acks();
    if (seq_ % every == 0 || seq_ == scans_.size()) {
      spdlog::info("scan {}/{} (log time {:.1f} s), {} reader(s)", seq_, scans_.size(),
                   scans_[i].stamp - scans_.front().stamp, matched_readers());
    }
  }
  return ack_wait_s;
}

}  // namespace esfleet::sim
