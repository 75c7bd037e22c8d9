#include "app/ros_scan_source.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <thread>
#include <vector>

#include "esfleet/dds/ros_msg.hpp"

namespace esfleet::app {
namespace {

constexpr auto kPoll = std::chrono::milliseconds(50);
/// Most messages of one kind waiting for the main thread; beyond, the oldest is dropped.
constexpr std::size_t kMaxQueued = 10000;
/// Most odometry poses kept for interpolation.
constexpr std::size_t kMaxOdometry = 5000;
/// A scan waits this long (wall time) for odometry at or after its stamp.
constexpr auto kOdometryWait = std::chrono::milliseconds(200);
/// Odometry this close (s) to a scan's stamp stands for it when none brackets the stamp.
constexpr double kOdometrySlack = 0.1;

/// Pose at `t` between a (at ta) and b (at tb), ta <= t <= tb.
Pose2 interpolate(const TimedPose& a, const TimedPose& b, double t) {
  const double span = b.stamp - a.stamp;
  const double f = span > 0.0 ? (t - a.stamp) / span : 0.0;
  return Pose2{a.pose.x + f * (b.pose.x - a.pose.x), a.pose.y + f * (b.pose.y - a.pose.y),
               normalize_angle(a.pose.theta + f * normalize_angle(b.pose.theta - a.pose.theta))};
}

template <class T>
void push_bounded(std::deque<T>& q, T&& v) {
  if (q.size() >= kMaxQueued) q.pop_front();
  q.push_back(std::forward<T>(v));
}

}  // namespace

nlohmann::json RosScanStats::json() const {
  return {{"scans_received", scans_received},
          {"scans_used", scans_used},
          {"odometry_received", odometry_received},
          {"scans_skipped", scans_skipped},
          {"dropped", dropped},
          {"laser_frame", laser_frame},
          {"mount_from", mount_from},
          {"mount", {{"x", mount.x}, {"y", mount.y}, {"theta", mount.theta}}}};
}

RosScanSource::RosScanSource(dds::Node& node, const RosNames& names, const RosOptions& options,
                             double idle_exit_s, bool latest_only)
    : names_(names),
      options_(options),
      idle_exit_s_(idle_exit_s),
      latest_only_(latest_only),
      laser_frame_(options.laser_frame) {
  if (options_.laser_pose) {
    mount_ = *options_.laser_pose;
    mount_from_ = "flag";
  } else if (names_.odom_topic.empty() && !names_.odom_from_tf) {
    mount_from_ = "identity";  // laser only: the SLAM tracks the laser itself
  }
  if (!names_.odom_topic.empty()) {
    odom_reader_ = std::make_unique<dds::RosOdomReader>(
        node,
        [this](const nav_msgs::msg::Odometry& m, const dds::SampleMeta& meta) {
          std::lock_guard lock(mutex_);
          push_bounded(odoms_, std::pair{m, meta.writer_guid});
        },
        dds::ros_odom_endpoint(names_.odom_topic, true));
  }
  if (names_.odom_from_tf) {
    tf_reader_ = std::make_unique<dds::RosTfReader>(
        node,
        [this](const tf2_msgs::msg::TFMessage& m, const dds::SampleMeta& meta) {
          std::lock_guard lock(mutex_);
          push_bounded(tfs_, std::pair{m, meta.writer_guid});
        },
        dds::ros_tf_endpoint());
  }
  if (!options_.laser_pose && mount_from_.empty()) {
    tf_static_reader_ = std::make_unique<dds::RosTfReader>(
        node,
        [this](const tf2_msgs::msg::TFMessage& m, const dds::SampleMeta& meta) {
          std::lock_guard lock(mutex_);
          push_bounded(tf_statics_, std::pair{m, meta.writer_guid});
        },
        dds::ros_tf_static_endpoint(true));
  }
  scan_reader_ = std::make_unique<dds::RosScanReader>(
      node,
      [this](const sensor_msgs::msg::LaserScan& m, const dds::SampleMeta& meta) {
        std::lock_guard lock(mutex_);
        ++received_;
        const auto now = Clock::now();
        last_arrival_ = now;
        if (m.ranges().size() > dds::kMaxRosScanBeams) {
          // Not queued whole: the main thread refuses (and counts) it from a stand-in of
          // kMaxRosScanBeams + 1 zero readings.
          sensor_msgs::msg::LaserScan huge;
          huge.header(m.header());
          huge.angle_min(m.angle_min());
          huge.angle_max(m.angle_max());
          huge.angle_increment(m.angle_increment());
          huge.range_min(m.range_min());
          huge.range_max(m.range_max());
          huge.ranges().resize(dds::kMaxRosScanBeams + 1);
          push_bounded(scans_, Arrived{std::move(huge), meta.writer_guid, now});
        } else {
          push_bounded(scans_, Arrived{m, meta.writer_guid, now});
        }
        arrived_.notify_one();
      },
      dds::ros_scan_endpoint(names_.scan_topic, true));
}

RosScanSource::~RosScanSource() {
  scan_reader_.reset();
  tf_static_reader_.reset();
  tf_reader_.reset();
  odom_reader_.reset();
}

int RosScanSource::matched_writers() const { return scan_reader_->matched_writers(); }

bool RosScanSource::ready() const {
  std::lock_guard lock(mutex_);
  return !scans_.empty() ||
         (idle_exit_s_ > 0.0 && last_arrival_ &&
          Clock::now() - *last_arrival_ >= std::chrono::duration<double>(idle_exit_s_));
}

void RosScanSource::drop(const std::string& kind, const std::string& sender,
                         const std::string& why) {
  ++dropped_[kind];
  if (logged_.insert({sender, kind}).second) {
    spdlog::warn("dropping {} from {}: {} (further ones of this kind from it only counted)", kind,
                 sender, why);
  }
}

void RosScanSource::add_odometry(const TimedPose& p) {
  ++odometry_received_;
  if (!odometry_.empty() && p.stamp <= odometry_.back().stamp) return;  // old or repeated
  odometry_.push_back(p);
  if (odometry_.size() > kMaxOdometry) odometry_.pop_front();
}

void RosScanSource::on_transforms(const tf2_msgs::msg::TFMessage& m, const std::string& sender,
                                  bool is_static) {
  for (const auto& t : m.transforms()) {
    try {
      if (is_static) {
        statics_[t.child_frame_id()] = {t.header().frame_id(), dds::pose2_from_ros(t.transform())};
      } else if (t.header().frame_id() == names_.odom_frame &&
                 t.child_frame_id() == names_.base_frame) {
        add_odometry(
            TimedPose{dds::seconds_of(t.header().stamp()), dds::pose2_from_ros(t.transform())});
      }
    } catch (const dds::RosMessageError& e) {
      drop(e.kind(), sender, e.what());
    }
  }
}

void RosScanSource::drain_side_queues() {
  decltype(odoms_) odoms;
  decltype(tfs_) tfs;
  decltype(tf_statics_) statics;
  {
    std::lock_guard lock(mutex_);
    odoms.swap(odoms_);
    tfs.swap(tfs_);
    statics.swap(tf_statics_);
  }
  for (const auto& [m, sender] : odoms) {
    try {
      if (m.header().frame_id() != names_.odom_frame || m.child_frame_id() != names_.base_frame) {
        drop("odom_wrong_frame", sender,
             "odometry of " + m.header().frame_id() + " -> " + m.child_frame_id() + ", expected " +
                 names_.odom_frame + " -> " + names_.base_frame);
        continue;
      }
      add_odometry(dds::odom_from_ros(m));
    } catch (const dds::RosMessageError& e) {
      drop(e.kind(), sender, e.what());
    }
  }
  for (const auto& [m, sender] : tfs) on_transforms(m, sender, false);
  for (const auto& [m, sender] : statics) on_transforms(m, sender, true);
}

std::optional<Pose2> RosScanSource::odometry_at(double stamp) const {
  if (odometry_.empty()) return std::nullopt;
  const auto after = std::lower_bound(odometry_.begin(), odometry_.end(), stamp,
                                      [](const TimedPose& p, double t) { return p.stamp < t; });
  if (after != odometry_.end() && after->stamp == stamp) return after->pose;
  if (after != odometry_.end() && after != odometry_.begin()) {
    return interpolate(*std::prev(after), *after, stamp);
  }
  const TimedPose& nearest = after == odometry_.end() ? odometry_.back() : *after;
  if (std::abs(nearest.stamp - stamp) <= kOdometrySlack) return nearest.pose;
  return std::nullopt;
}

std::optional<LaserScan> RosScanSource::check(const Arrived& a) {
  LaserScan scan;
  try {
    scan = dds::scan_from_ros(a.msg);
  } catch (const dds::RosMessageError& e) {
    drop(e.kind(), a.sender, e.what());
    return std::nullopt;
  }
  const std::string& frame = a.msg.header().frame_id();
  if (laser_frame_.empty()) {
    laser_frame_ = frame;
    spdlog::info("laser frame '{}' (from the first scan)", frame);
  }
  if (frame != laser_frame_) {
    drop("scan_wrong_frame", a.sender,
         "frame '" + frame + "' is not the laser's ('" + laser_frame_ + "')");
    return std::nullopt;
  }
  if (last_stamp_ && !(scan.stamp > *last_stamp_)) {
    drop("scan_stamp_backwards", a.sender,
         "stamp " + std::to_string(scan.stamp) + " s is not after the last scan's " +
             std::to_string(*last_stamp_) + " s");
    return std::nullopt;
  }
  last_stamp_ = scan.stamp;
  return scan;
}

std::optional<LaserScan> RosScanSource::convert(const Arrived& a) {
  std::optional<LaserScan> scan = check(a);
  if (!scan) return std::nullopt;
  if (mount_from_.empty()) {
    // Walk /tf_static from the laser up to the base.
    Pose2 laser_in_base;
    std::string f = laser_frame_;
    for (int depth = 0; depth < 16 && f != names_.base_frame; ++depth) {
      const auto it = statics_.find(f);
      if (it == statics_.end()) break;
      laser_in_base = it->second.second.compose(laser_in_base);
      f = it->second.first;
    }
    if (f == names_.base_frame) {
      mount_ = laser_in_base;
      mount_from_ = "tf_static";
      spdlog::info("laser mount {} -> {} from /tf_static: ({:.3f}, {:.3f}, {:.1f} deg)",
                   names_.base_frame, laser_frame_, mount_.x, mount_.y, rad_to_deg(mount_.theta));
    }
  }
  if (!names_.odom_topic.empty() || names_.odom_from_tf) {
    const std::optional<Pose2> base = odometry_at(scan->stamp);
    if (!base) {
      drop("scan_without_odometry", a.sender,
           "no odometry near stamp " + std::to_string(scan->stamp) + " s");
      return std::nullopt;
    }
    scan->odometry = base->compose(mount_);  // the laser's odometry
  }
  ++used_;
  return scan;
}

std::optional<LaserScan> RosScanSource::next(const std::atomic<bool>& stop) {
  return take(stop, /*wait=*/true);
}

std::optional<LaserScan> RosScanSource::poll(const std::atomic<bool>& stop) {
  return take(stop, /*wait=*/false);
}

std::optional<LaserScan> RosScanSource::take(const std::atomic<bool>& stop, bool wait) {
  const bool needs_odometry = !names_.odom_topic.empty() || names_.odom_from_tf;
  while (!stop.load()) {
    std::unique_lock lock(mutex_);
    if (wait) arrived_.wait_for(lock, kPoll, [this] { return !scans_.empty(); });
    if (!scans_.empty()) {
      std::vector<Arrived> skipped;
      while (latest_only_ && scans_.size() > 1) {
        skipped.push_back(std::move(scans_.front()));
        scans_.pop_front();
      }
      // Copies, not a reference: a full queue drops its oldest entry from the DDS thread.
      const Clock::time_point front_at = scans_.front().at;
      const auto& st = scans_.front().msg.header().stamp();
      const double front_stamp = static_cast<double>(st.sec()) + 1e-9 * st.nanosec();
      lock.unlock();
      // Skipped scans are still checked: every broken message is counted.
      for (const Arrived& a : skipped) skipped_ += check(a) ? 1 : 0;
      drain_side_queues();
      const bool may_wait = Clock::now() - front_at < kOdometryWait;
      if (needs_odometry && may_wait &&
          (mount_from_.empty() || odometry_.empty() || odometry_.back().stamp < front_stamp)) {
        // Odometry at or after the scan's stamp (and /tf_static) may still be on its way.
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
        continue;
      }
      lock.lock();
      if (scans_.empty()) continue;
      const Arrived a = std::move(scans_.front());
      scans_.pop_front();
      lock.unlock();
      returned_arrival_ = a.at;
      if (needs_odometry && mount_from_.empty()) {
        mount_from_ = "identity";
        spdlog::warn("no /tf_static transform {} -> {} came: taking the laser at the base",
                     names_.base_frame, laser_frame_.empty() ? "laser" : laser_frame_);
      }
      if (auto scan = convert(a)) return scan;
      continue;
    }
    if (idle_exit_s_ > 0.0 && last_arrival_ &&
        Clock::now() - *last_arrival_ >= std::chrono::duration<double>(idle_exit_s_)) {
      idle_ = true;
      return std::nullopt;
    }
    if (!wait) return std::nullopt;
  }
  return std::nullopt;
}

RosScanStats RosScanSource::stats() const {
  RosScanStats s;
  s.scans_used = used_;
  s.odometry_received = odometry_received_;
  s.dropped = dropped_;
  s.laser_frame = laser_frame_;
  s.mount_from = mount_from_;
  s.mount = mount_;
  s.scans_skipped = skipped_;
  std::lock_guard lock(mutex_);
  s.scans_received = received_;
  return s;
}

}  // namespace esfleet::app
