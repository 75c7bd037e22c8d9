#pragma once
// The follower's side of contributed scans (esfleet-follower --contribute; core
// contribution.hpp): while the robot tracks its pose in the leader's map, a scan whose pose has
// strong evidence and lies far enough from the last contributed one is sent to the leader with
// that pose (esfleet/robots/contribution, in the robot's partition). The leader checks it and
// answers per robot (esfleet/robots/contribution_status); when it has refused this robot's
// scans `max_rejections` times in a row, the robot's pose is likely wrong and the follower is
// told to localise afresh (take_relocalise()).
//
// The status reader's callback only stores the newest status under a mutex; everything else
// runs on the application thread.

#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "esfleet/core/contribution.hpp"
#include "esfleet/core/geometry.hpp"
#include "esfleet/core/laser_scan.hpp"
#include "esfleet/core/localiser.hpp"
#include "esfleet/dds/node.hpp"
#include "esfleet/dds/reader.hpp"
#include "esfleet/dds/to_msg.hpp"
#include "esfleet/dds/writer.hpp"
#include "esfleet/mapshare/map_replica.hpp"

namespace esfleet::follower {

struct ContributorConfig {
  /// Contribute at all (--contribute).
  bool enabled = false;
  /// Which tracked scans are sent: evidence of the pose and spacing (core contribution.hpp,
  /// the rule esfleet-bench contribute uses too).
  esfleet::ContributorConfig send;
  /// Relocalise after this many rejections in a row (of contributions made since the last
  /// relocalisation).
  int max_rejections = 5;
  /// Tests only: added to the claimed pose (map frame; theta in radians), a robot whose pose
  /// is wrong.
  Pose2 pose_offset;
  /// After the scans end: wait at most this long for the leader's answer to the last
  /// contribution and its map with it (seconds).
  double settle_s = 10.0;
  /// Throws std::invalid_argument naming the flag.
  void validate() const;
};

class Contributor {
 public:
  /// Creates the contribution writer and the status reader in partition `robot_id`. Throws
  /// std::runtime_error naming the topic if Fast DDS refuses.
  Contributor(dds::Node& node, std::string robot_id, ContributorConfig config);
  ~Contributor();
  Contributor(const Contributor&) = delete;
  Contributor& operator=(const Contributor&) = delete;

  /// After a scan: `step` is the localiser's result for `scan`, `was_tracking` whether it was
  /// tracking before. Sends the scan when it was tracked (not the declaring scan), the evidence
  /// is strong enough, the robot moved enough since the last one, and the replica has a map.
  /// Returns true when sent.
  bool after_scan(const LaserScan& scan, const LocaliserStep& step, bool was_tracking,
                  const mapshare::MapReplica& replica);
  /// True once when the leader's newest status says this robot's contributions since the
  /// last relocalisation were refused max_rejections times in a row (logged as a warning):
  /// the caller then relocalises.
  bool take_relocalise();
  /// Blocks until a leader's contribution reader is matched with this robot's writer, or
  /// `timeout` passes; true if matched. (Contributions are VOLATILE: one sent before then is
  /// lost, as a scan is, and the next one goes.)
  bool wait_for_leader(std::chrono::milliseconds timeout) const {
    return writer_->wait_for_matched(1, timeout);
  }
  /// The leader has answered the last contribution sent (or none was sent).
  bool answered() const;
  std::uint64_t sent() const { return sent_; }
  std::uint64_t relocalisations() const { return relocalisations_; }
  /// stats.json "contribution": sent, bytes, accepted, rejected (the leader's last status),
  /// relocalisations.
  nlohmann::json json() const;

 private:
  std::string robot_id_;
  ContributorConfig config_;
  std::unique_ptr<dds::ContributionWriter> writer_;
  std::uint32_t seq_ = 0;  ///< seq of the last contribution sent (0 = none)
  std::uint64_t sent_ = 0;
  std::optional<Pose2> last_sent_;
  std::uint32_t reset_seq_ = 0;    ///< seq_ at the last relocalisation
  std::uint64_t acted_stamp_ = 0;  ///< stamp_ns of the last status acted on
  std::uint64_t relocalisations_ = 0;

  mutable std::mutex mutex_;                      ///< guards status_ and malformed_
  std::optional<dds::ContributionTally> status_;  ///< the leader's newest answer
  std::uint64_t malformed_ = 0;
  std::unique_ptr<dds::ContributionStatusReader> reader_;  ///< last: its callback uses the above
};

}  // namespace esfleet::follower
