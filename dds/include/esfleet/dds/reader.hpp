#pragma once
// Typed DDS readers for the esfleet topics (TileReader, TileDeltaReader, MetaReader, PoseReader,
// ScanReader) that hand every received sample to a callback. Plain C++ API over the generated
// message classes; the Fast DDS entities live in dds/src/endpoints.cpp. QoS matches the writers
// (writer.hpp).
//
// Threading: the callback runs on a Fast DDS listener thread (the DataReader's
// on_data_available), never on the thread that created the reader. It must be short, must not
// block on DDS, and must not touch application state without synchronisation: hand the sample
// over through a locked queue (docs/architecture.md, "Threads"). Callbacks of one reader never
// overlap.
// A callback may write with a Writer, but must not create or destroy readers, writers or the
// Node (that waits for the callback itself). Exceptions thrown by the callback are caught and
// counted (callback_errors()).
//
// The listener sits on the DataReader, not on the participant: a participant listener with the
// default status mask would swallow on_data_available, and the reader's callback would never
// run (Fast DDS 2.9.1).

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>

#include <esfleet/msg/esfleet.h>

#include "esfleet/dds/node.hpp"

namespace esfleet::dds {

/// Where and when a sample came from.
struct SampleMeta {
  /// GUID of the DataWriter that published the sample ("prefix|entity"); its prefix is the
  /// writing Node's guid_prefix().
  std::string writer_guid;
  /// Writer's CLOCK_REALTIME when it wrote the sample, ns since the Unix epoch.
  std::int64_t source_timestamp_ns = 0;
  /// This process's CLOCK_REALTIME when the sample was received, ns since the Unix epoch.
  std::int64_t reception_ns = 0;
};

namespace detail {
template <class Msg>
struct ReaderImpl;
}

/// Subscribes to one esfleet topic (the topic and QoS follow from Msg) and calls back per sample.
/// Samples of an esfleet type whose protocol() != kProtocolVersion are dropped and counted,
/// never delivered (the ROS 2 types have no protocol field).
template <class Msg>
class Reader {
 public:
  /// Called on the DDS listener thread, once per valid received sample.
  using Callback = std::function<void(const Msg&, const SampleMeta&)>;

  /// Creates the DataReader on `node`'s subscriber of partition `partition`; callbacks may
  /// start before the constructor returns. `partition`: "" = the default partition (map topics;
  /// writers that set no partition), a robot id = that robot's pose/scans only, kAllPartitions
  /// ("*") = every robot's (Fast DDS 2.9 matches "*" against every writer partition, the default
  /// one included). Throws std::invalid_argument for an empty callback and std::runtime_error
  /// naming the topic if Fast DDS refuses (with security: also when the permissions forbid it).
  Reader(Node& node, Callback callback, const std::string& partition = {});
  /// The same on the topic and with the QoS of `endpoint` instead of Msg's own (ros.hpp).
  Reader(Node& node, Callback callback, const TopicQos& endpoint,
         const std::string& partition = {});
  /// Stops the callbacks (waits for a running one to finish), then deletes the DataReader.
  /// Must not be called from inside the callback.
  ~Reader();
  Reader(const Reader&) = delete;
  Reader& operator=(const Reader&) = delete;

  /// Topic name, e.g. "esfleet/map/tiles".
  std::string_view topic_name() const;
  /// Samples delivered to the callback.
  std::uint64_t samples_received() const;
  /// CDR bytes of the delivered samples (same measure as Writer::bytes_written()).
  std::uint64_t bytes_received() const;
  /// Samples dropped because their protocol field was not kProtocolVersion.
  std::uint64_t protocol_mismatches() const;
  /// Callback invocations that threw.
  std::uint64_t callback_errors() const;
  /// Writers currently matched with this reader.
  int matched_writers() const;
  /// Blocks until at least `count` writers are matched or `timeout` passes; true if matched.
  bool wait_for_matched(int count, std::chrono::milliseconds timeout) const;

 private:
  std::unique_ptr<detail::ReaderImpl<Msg>> impl_;
};

extern template class Reader<msg::MapTile>;
extern template class Reader<msg::MapTileDelta>;
extern template class Reader<msg::MapMeta>;
extern template class Reader<msg::RobotPose>;
extern template class Reader<msg::LaserScanMsg>;
extern template class Reader<msg::TruthPose>;
extern template class Reader<msg::ContributedScan>;
extern template class Reader<msg::ContributionStatus>;

/// Receives map tiles from kTileTopic.
using TileReader = Reader<msg::MapTile>;
/// Receives tile deltas from kTileDeltaTopic.
using TileDeltaReader = Reader<msg::MapTileDelta>;
/// Receives map summaries from kMetaTopic.
using MetaReader = Reader<msg::MapMeta>;
/// Receives robot poses from kPoseTopic.
using PoseReader = Reader<msg::RobotPose>;
/// Receives laser scans from kScanTopic.
using ScanReader = Reader<msg::LaserScanMsg>;
/// True poses of simulated robots on kTruthTopic (evaluation only).
using TruthReader = Reader<msg::TruthPose>;
/// Receives contributed scans from kContributionTopic (the leader, in every partition).
using ContributionReader = Reader<msg::ContributedScan>;
/// Receives the leader's answers to contributions from kContributionStatusTopic.
using ContributionStatusReader = Reader<msg::ContributionStatus>;

}  // namespace esfleet::dds
