#include "app/scan_source.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <stdexcept>
#include <thread>
#include <utility>

#include "esfleet/core/relations.hpp"
#include "esfleet/dds/from_msg.hpp"

namespace esfleet::app {

namespace {
/// How often blocked waits look at the stop flag.
constexpr std::chrono::milliseconds kPoll{100};
}  // namespace

std::vector<LaserScan> read_log(const std::string& path, const CarmenReaderOptions& options,
                                std::size_t max_scans, bool use_odometry,
                                const std::atomic<bool>& stop) {
  CarmenReader reader(path, options);
  std::vector<LaserScan> scans = read_scans(reader, max_scans, &stop);
  if (const std::size_t bad = reader.bad_param_count(); bad > 0) {
    std::string lines;
    for (const std::size_t l : reader.bad_param_lines()) {
      lines += (lines.empty() ? "" : ", ") + std::to_string(l);
    }
    spdlog::warn("{}: skipped {} PARAM line(s) without a value (line {}{})", path, bad, lines,
                 bad > reader.bad_param_lines().size() ? ", ..." : "");
  }
  if (reader.saw_corrected_poses() && use_odometry) {
    spdlog::warn(
        "{} is a GMapping-corrected log: its odometry fields are corrected poses, so "
        "--odometry on makes the result meaningless. Run it laser-only.",
        path);
  }
  std::vector<double> stamps;
  stamps.reserve(scans.size());
  for (const LaserScan& s : scans) stamps.push_back(s.stamp);
  if (const StampOrder order = stamp_order(stamps); order.not_after > 0) {
    spdlog::warn(
        "{}: {} of {} scans are not stamped after the scan before them (the first: scan {}, "
        "stamp {:.6f}); rounded stamps? The motion prediction takes one step per scan there, "
        "and --rate cannot pace them",
        path, order.not_after, scans.size(), order.first + 1, scans[order.first].stamp);
  }
  return scans;
}

LogScanSource::LogScanSource(std::vector<LaserScan> scans, double rate)
    : scans_(std::move(scans)),
      first_stamp_(scans_.empty() ? 0.0 : scans_.front().stamp),
      rate_(rate) {}

std::chrono::steady_clock::time_point LogScanSource::due(std::size_t i) const {
  const double due_s = (scans_[i].stamp - first_stamp_) / rate_;
  return start_ + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                      std::chrono::duration<double>(due_s));
}

bool LogScanSource::ready() const {
  return next_ == 0 || next_ >= scans_.size() || rate_ <= 0.0 ||
         std::chrono::steady_clock::now() >= due(next_);
}

std::optional<LaserScan> LogScanSource::next(const std::atomic<bool>& stop) {
  if (next_ >= scans_.size() || stop.load()) return std::nullopt;
  if (next_ == 0) start_ = std::chrono::steady_clock::now();
  if (rate_ > 0.0) {
    const auto due = this->due(next_);
    while (std::chrono::steady_clock::now() < due) {
      if (stop.load()) return std::nullopt;
      std::this_thread::sleep_until(std::min(due, std::chrono::steady_clock::now() + kPoll));
    }
  }
  // Moved out: a scan handed over is never needed again, so the log's ranges are freed as the
  // consumer goes (CSAIL: 2.9 MB held to the end otherwise).
  return std::move(scans_[next_++]);
}

TopicScanSource::TopicScanSource(dds::Node& node, std::string robot_id, double idle_exit_s,
                                 bool latest_only)
    : robot_id_(std::move(robot_id)),
      idle_exit_s_(idle_exit_s),
      latest_only_(latest_only),
      // Subscribes to the robot's own partition only (scan writers publish in the partition named
      // after their robot id): other robots' scans never reach this process. The robot_id check
      // in on_message() stays for writers that set no partition.
      reader_(
          node, [this](const msg::LaserScanMsg& m, const dds::SampleMeta&) { on_message(m); },
          robot_id_) {}

void TopicScanSource::on_message(const msg::LaserScanMsg& m) {
  std::lock_guard lock(mutex_);
  if (m.robot_id() != robot_id_) {
    ++other_robots_;
    return;
  }
  const auto now = Clock::now();
  queue_.push_back({m, now});
  ++received_;
  max_queue_ = std::max(max_queue_, queue_.size());
  last_arrival_ = now;
  arrived_.notify_one();
}

bool TopicScanSource::ready() const {
  std::lock_guard lock(mutex_);
  return !queue_.empty() ||
         (idle_exit_s_ > 0.0 && last_arrival_ &&
          Clock::now() - *last_arrival_ >= std::chrono::duration<double>(idle_exit_s_));
}

std::optional<LaserScan> TopicScanSource::next(const std::atomic<bool>& stop) {
  while (!stop.load()) {
    std::unique_lock lock(mutex_);
    arrived_.wait_for(lock, kPoll, [this] { return !queue_.empty(); });
    if (!queue_.empty()) {
      std::size_t skipped = 0;
      std::optional<std::uint32_t> newest_skipped_seq;
      while (latest_only_ && queue_.size() > 1) {
        newest_skipped_seq = queue_.front().msg.seq();
        queue_.pop_front();
        ++skipped;
      }
      dropped_ += skipped;
      const Arrived a = std::move(queue_.front());
      queue_.pop_front();
      lock.unlock();
      // Skipped scans are not transport losses: move the seq bookkeeping past them.
      if (newest_skipped_seq && (!last_seq_ || *newest_skipped_seq > *last_seq_)) {
        last_seq_ = *newest_skipped_seq;
      }
      returned_arrival_ = a.at;
      if (auto scan = convert(a.msg)) return scan;
      continue;
    }
    if (idle_exit_s_ > 0.0 && last_arrival_ &&
        Clock::now() - *last_arrival_ >= std::chrono::duration<double>(idle_exit_s_)) {
      idle_ = true;
      return std::nullopt;
    }
  }
  return std::nullopt;
}

std::optional<LaserScan> TopicScanSource::convert(const msg::LaserScanMsg& m) {
  // Seq numbers only diagnose: a gap means the transport lost scans, a step back a restarted
  // publisher. Malformed scans still count, so that their own seq is not reported as a gap.
  if (last_seq_ && m.seq() <= *last_seq_) {
    ++seq_restarts_;
    spdlog::warn("scan seq went back from {} to {}: the publisher of '{}' restarted?", *last_seq_,
                 m.seq(), robot_id_);
  } else if (last_seq_ && m.seq() > *last_seq_ + 1) {
    const std::uint32_t missing = m.seq() - *last_seq_ - 1;
    seq_gaps_ += missing;
    spdlog::warn("{} scans of '{}' missing before seq {}", missing, robot_id_, m.seq());
  }
  last_seq_ = m.seq();
  try {
    return dds::scan_from_msg(m);
  } catch (const std::invalid_argument& e) {
    if (malformed_++ == 0) {
      spdlog::warn("dropping malformed scan seq {} of '{}': {} (further ones only counted)",
                   m.seq(), robot_id_, e.what());
    }
    return std::nullopt;
  }
}

TopicScanStats TopicScanSource::stats() const {
  TopicScanStats s;
  s.malformed = malformed_;
  s.seq_gaps = seq_gaps_;
  s.seq_restarts = seq_restarts_;
  std::lock_guard lock(mutex_);
  s.received = received_;
  s.other_robots = other_robots_;
  s.max_queue = max_queue_;
  s.dropped = dropped_;
  return s;
}

}  // namespace esfleet::app
