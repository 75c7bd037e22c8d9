#pragma once
// Typed DDS writers for the esfleet topics (TileWriter, TileDeltaWriter, MetaWriter, PoseWriter,
// ScanWriter). Plain C++ API over the generated message classes; the Fast DDS entities live in
// dds/src/endpoints.cpp.
//
// QoS (readers use the same, see reader.hpp):
//   TileWriter, MetaWriter: RELIABLE, TRANSIENT_LOCAL, KEEP_LAST 1 per key, so a follower that
//     joins late gets exactly the newest version of every tile / map summary.
//   TileDeltaWriter: RELIABLE, VOLATILE, KEEP_LAST 64 per key (deltas only make sense in order
//     after the full tile they build on; late joiners get full tiles instead).
//   PoseWriter: RELIABLE, VOLATILE, KEEP_LAST 1 per robot.
//   ScanWriter: RELIABLE, VOLATILE, KEEP_LAST 50 per robot.
//   ContributionWriter: RELIABLE, VOLATILE, KEEP_LAST 32 per robot.
//   ContributionStatusWriter: RELIABLE, VOLATILE, KEEP_LAST 1 per robot.
//   All: resource limits unlimited (Fast DDS's default max_instances = 10 silently drops writes
//   to the 11th tile), heartbeat period 100 ms (a lost last sample is repaired within ~100 ms
//   instead of 3 s). With KEEP_LAST, write() never blocks.
//
// Byte counters count the CDR serialized size of each sample including the 4-byte encapsulation
// header, computed with the generated PubSubType's getSerializedSizeProvider (walks the sample,
// does not serialize it). Readers count the same way, so the two sides agree sample for sample.

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include <esfleet/msg/esfleet.h>

#include "esfleet/dds/node.hpp"

namespace esfleet::dds {

namespace detail {
template <class Msg>
struct WriterImpl;
}

/// Publishes samples of one esfleet topic (the topic and QoS follow from Msg, see above).
/// Thread-safe: write() may be called from several threads.
template <class Msg>
class Writer {
 public:
  /// Creates the DataWriter on `node`'s publisher of partition `partition` ("" = the default
  /// partition). Robot topics (pose, scan, truth) are published in the partition named after
  /// the robot id, so that readers can pick one robot and DDS Security permissions can allow a
  /// robot its own partition only (docs/security.md); the map topics use the default partition.
  /// Throws std::runtime_error naming the topic if Fast DDS refuses (with security: also when
  /// the permissions do not allow this topic in this partition). The node must outlive the
  /// writer's use (see node.hpp).
  explicit Writer(Node& node, const std::string& partition = {});
  /// The same on the topic and with the QoS of `endpoint` instead of Msg's own (ros.hpp: the
  /// ROS 2 topics, whose names depend on the robot's namespace).
  Writer(Node& node, const TopicQos& endpoint, const std::string& partition = {});
  ~Writer();
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;

  /// Publishes one sample. Returns false, and publishes nothing, when sample.protocol() !=
  /// kProtocolVersion (esfleet types), when the node is already destroyed, or when Fast DDS refuses
  /// the write.
  bool write(const Msg& sample);

  /// Topic name, e.g. "esfleet/map/tiles".
  std::string_view topic_name() const;
  /// Samples accepted by write().
  std::uint64_t samples_written() const;
  /// CDR bytes of the samples accepted by write() (see the file comment).
  std::uint64_t bytes_written() const;
  /// Calls of write() that returned false.
  std::uint64_t write_failures() const;
  /// Readers currently matched with this writer.
  int matched_readers() const;
  /// Blocks until at least `count` readers are matched or `timeout` passes; true if matched.
  bool wait_for_matched(int count, std::chrono::milliseconds timeout) const;
  /// Blocks until every matched reliable reader acknowledged every sample written so far, or
  /// `timeout` passes; true if all were acknowledged. Call before exiting so the last samples
  /// are not lost with the process.
  bool wait_for_acknowledgments(std::chrono::milliseconds timeout) const;

 private:
  std::unique_ptr<detail::WriterImpl<Msg>> impl_;
};

extern template class Writer<msg::MapTile>;
extern template class Writer<msg::MapTileDelta>;
extern template class Writer<msg::MapMeta>;
extern template class Writer<msg::RobotPose>;
extern template class Writer<msg::LaserScanMsg>;
extern template class Writer<msg::TruthPose>;
extern template class Writer<msg::ContributedScan>;
extern template class Writer<msg::ContributionStatus>;

/// Publishes map tiles on kTileTopic.
using TileWriter = Writer<msg::MapTile>;
/// Publishes tile deltas on kTileDeltaTopic.
using TileDeltaWriter = Writer<msg::MapTileDelta>;
/// Publishes map summaries on kMetaTopic.
using MetaWriter = Writer<msg::MapMeta>;
/// Publishes robot poses on kPoseTopic.
using PoseWriter = Writer<msg::RobotPose>;
/// Publishes laser scans on kScanTopic.
using ScanWriter = Writer<msg::LaserScanMsg>;
/// True poses of simulated robots on kTruthTopic (evaluation only).
using TruthWriter = Writer<msg::TruthPose>;
/// A follower's contributed scans on kContributionTopic (in its robot's partition).
using ContributionWriter = Writer<msg::ContributedScan>;
/// The leader's answers to a robot's contributions on kContributionStatusTopic.
using ContributionStatusWriter = Writer<msg::ContributionStatus>;

}  // namespace esfleet::dds
