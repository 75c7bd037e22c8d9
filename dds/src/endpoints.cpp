// Writer<Msg> and Reader<Msg> for the esfleet topics and the ROS 2 topics: QoS per topic,
// DataWriter/DataReader creation and deletion, the DataReader listener that hands samples to the
// callback, counters. One of the two translation units of esfleet_dds that include Fast DDS
// headers; the templates are instantiated here for the esfleet message types and the ROS 2 types of
// ros.hpp only.

#include <algorithm>
#include <atomic>
#include <chrono>
#include <mutex>
#include <set>
#include <sstream>
#include <stdexcept>
#include <thread>

#include <esfleet/msg/esfleetPubSubTypes.h>
#include <esfleet/msg/ros2PubSubTypes.h>
#include <fastdds/rtps/common/InstanceHandle.h>
#include <spdlog/spdlog.h>
#include <fastdds/dds/core/status/PublicationMatchedStatus.hpp>
#include <fastdds/dds/core/status/SubscriptionMatchedStatus.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/qos/DataWriterQos.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/qos/DataReaderQos.hpp>

#include "esfleet/core/clock.hpp"
#include "esfleet/dds/reader.hpp"
#include "esfleet/dds/writer.hpp"
#include "node_impl.hpp"

namespace esfleet::dds {

namespace {

namespace fdds = eprosima::fastdds::dds;
using eprosima::fastrtps::types::ReturnCode_t;

/// Topic and QoS of each message type. The esfleet types carry a protocol field and are
/// reliable; the ROS 2 types (ros.hpp) have no protocol field and a QoS of ROS's.
struct EsfleetTraits {
  static constexpr bool kHasProtocol = true;
  static constexpr bool kReliable = true;
};
struct RosTraits {
  static constexpr bool kHasProtocol = false;  // topic and QoS per endpoint: ros.hpp
};
template <class Msg>
struct Traits;
template <>
struct Traits<msg::MapTile> : EsfleetTraits {
  using PubSub = msg::MapTilePubSubType;
  static constexpr std::string_view kTopic = kTileTopic;
  static constexpr bool kTransientLocal = true;
  static constexpr std::int32_t kDepth = 1;
  static constexpr std::int32_t kReaderDepth = 1;
  static constexpr std::int32_t kMaxInstances = kMaxTileKeys;
};
template <>
struct Traits<msg::MapTileDelta> : EsfleetTraits {
  using PubSub = msg::MapTileDeltaPubSubType;
  static constexpr std::string_view kTopic = kTileDeltaTopic;
  static constexpr bool kTransientLocal = false;
  static constexpr std::int32_t kDepth = 64;  // a gap in a tile's chain costs a full tile
  // The reader takes each delta at once and holds one only while a lost packet before it is
  // repaired (100 ms heartbeats); a tile changes at most once per publish, so 2 per key never
  // drop one there, and the reader's bound is 2 x kMaxTileKeys samples instead of 64 x.
  static constexpr std::int32_t kReaderDepth = 2;
  static constexpr std::int32_t kMaxInstances = kMaxTileKeys;
};
template <>
struct Traits<msg::MapMeta> : EsfleetTraits {
  using PubSub = msg::MapMetaPubSubType;
  static constexpr std::string_view kTopic = kMetaTopic;
  static constexpr bool kTransientLocal = true;
  static constexpr std::int32_t kDepth = 1;
  static constexpr std::int32_t kReaderDepth = 1;
  static constexpr std::int32_t kMaxInstances = kMaxMaps;
};
template <>
struct Traits<msg::RobotPose> : EsfleetTraits {
  using PubSub = msg::RobotPosePubSubType;
  static constexpr std::string_view kTopic = kPoseTopic;
  static constexpr bool kTransientLocal = false;
  static constexpr std::int32_t kDepth = 1;
  static constexpr std::int32_t kReaderDepth = 1;
  static constexpr std::int32_t kMaxInstances = kMaxRobots;
};
template <>
struct Traits<msg::LaserScanMsg> : EsfleetTraits {
  using PubSub = msg::LaserScanMsgPubSubType;
  static constexpr std::string_view kTopic = kScanTopic;
  static constexpr bool kTransientLocal = false;
  static constexpr std::int32_t kDepth = 50;
  static constexpr std::int32_t kReaderDepth = 50;
  static constexpr std::int32_t kMaxInstances = kMaxRobots;
};
template <>
struct Traits<msg::TruthPose> : EsfleetTraits {
  using PubSub = msg::TruthPosePubSubType;
  static constexpr std::string_view kTopic = kTruthTopic;
  static constexpr bool kTransientLocal = false;
  static constexpr std::int32_t kDepth = 50;
  static constexpr std::int32_t kReaderDepth = 50;
  static constexpr std::int32_t kMaxInstances = kMaxRobots;
};

template <>
struct Traits<msg::ContributedScan> : EsfleetTraits {
  using PubSub = msg::ContributedScanPubSubType;
  static constexpr std::string_view kTopic = kContributionTopic;
  static constexpr bool kTransientLocal = false;
  // The leader takes each at once onto its own queue; 32 cover a mapping thread busy for a
  // few seconds (a follower contributes a few scans a second).
  static constexpr std::int32_t kDepth = 32;
  static constexpr std::int32_t kReaderDepth = 32;
  static constexpr std::int32_t kMaxInstances = kMaxRobots;
};
template <>
struct Traits<msg::ContributionStatus> : EsfleetTraits {
  using PubSub = msg::ContributionStatusPubSubType;
  static constexpr std::string_view kTopic = kContributionStatusTopic;
  static constexpr bool kTransientLocal = false;
  static constexpr std::int32_t kDepth = 1;
  static constexpr std::int32_t kReaderDepth = 1;
  static constexpr std::int32_t kMaxInstances = kMaxRobots;
};

template <>
struct Traits<nav_msgs::msg::OccupancyGrid> : RosTraits {
  using PubSub = nav_msgs::msg::OccupancyGridPubSubType;
};
template <>
struct Traits<map_msgs::msg::OccupancyGridUpdate> : RosTraits {
  using PubSub = map_msgs::msg::OccupancyGridUpdatePubSubType;
};
template <>
struct Traits<geometry_msgs::msg::PoseWithCovarianceStamped> : RosTraits {
  using PubSub = geometry_msgs::msg::PoseWithCovarianceStampedPubSubType;
};
template <>
struct Traits<tf2_msgs::msg::TFMessage> : RosTraits {
  using PubSub = tf2_msgs::msg::TFMessagePubSubType;
};
template <>
struct Traits<sensor_msgs::msg::LaserScan> : RosTraits {
  using PubSub = sensor_msgs::msg::LaserScanPubSubType;
};
template <>
struct Traits<nav_msgs::msg::Odometry> : RosTraits {
  using PubSub = nav_msgs::msg::OdometryPubSubType;
};

/// The endpoint of an esfleet type's own topic and QoS. The ROS 2 types have none: their
/// endpoints name topic and QoS (ros.hpp).
template <class Msg>
TopicQos default_endpoint() {
  using T = Traits<Msg>;
  if constexpr (T::kHasProtocol) {
    return TopicQos{std::string(T::kTopic), T::kReliable,   T::kTransientLocal, T::kDepth,
                    T::kMaxInstances,       T::kReaderDepth};
  } else {
    throw std::logic_error("esfleet::dds: a ROS 2 endpoint needs its topic and QoS (ros.hpp)");
  }
}

/// Sets the QoS both sides share: reliability, durability, KEEP_LAST `depth` (the writer's
/// depth, or the reader's) and the resource limits of the endpoint (topics.hpp, TopicQos).
/// Never the Fast DDS default resource limits: their max_instances = 10 makes writes to an 11th
/// key fail silently. Once one limit is unlimited, max_samples must be too, and max_samples must
/// not be below max_instances x max_samples_per_instance, or the entity is not created.
template <class Qos>
void set_common_qos(Qos& qos, const TopicQos& e, std::int32_t depth) {
  qos.reliability().kind =
      e.reliable ? fdds::RELIABLE_RELIABILITY_QOS : fdds::BEST_EFFORT_RELIABILITY_QOS;
  qos.durability().kind =
      e.transient_local ? fdds::TRANSIENT_LOCAL_DURABILITY_QOS : fdds::VOLATILE_DURABILITY_QOS;
  qos.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
  qos.history().depth = depth;
  auto& limits = qos.resource_limits();
  if (e.max_instances > 0) {
    // Bounded (esfleet) types make a writer's pool PREALLOCATED, so a sample longer than the
    // bound fails to serialize and write() returns false. Data sharing, which Fast DDS would
    // consider for bounded types, is off: our types are keyed (which rules it out in 2.9), and
    // the transports are the profile's choice (deploy/fastdds), never an implicit one.
    qos.data_sharing().off();
    limits.max_instances = e.max_instances;
    limits.max_samples_per_instance = depth;
    limits.max_samples = e.max_instances * depth;
    // Preallocated at creation (default 100), each at the type's bound (a scan: 40 kB): only a
    // few, the pool grows on demand up to max_samples. 50 per scan writer took the simulator
    // with 16 robots from 46 to 74 MB.
    constexpr std::int32_t kInitialSamples = 4;
    limits.allocated_samples = std::min({depth, kInitialSamples, limits.allocated_samples});
  } else {
    limits.max_samples = 0;
    limits.max_instances = 0;
    limits.max_samples_per_instance = 0;
  }
}

/// " in partition 'X'" for error messages, "" for the default partition.
std::string partition_suffix(const std::string& partition) {
  return partition.empty() ? std::string() : " in partition '" + partition + "'";
}

/// Polls `count_now` every 10 ms until it reaches `count` or `timeout` passes.
template <class F>
bool poll_until(int count, std::chrono::milliseconds timeout, F count_now) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (true) {
    if (count_now() >= count) return true;
    if (std::chrono::steady_clock::now() >= deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

}  // namespace

namespace detail {

template <class Msg>
struct WriterImpl {
  std::shared_ptr<NodeImpl> node;
  std::string topic_name;
  typename Traits<Msg>::PubSub type;     ///< for getSerializedSizeProvider
  fdds::Publisher* publisher = nullptr;  ///< the node's publisher of the writer's partition
  fdds::DataWriter* writer = nullptr;
  std::atomic<std::uint64_t> samples{0};
  std::atomic<std::uint64_t> bytes{0};
  std::atomic<std::uint64_t> failures{0};
};

/// The DataReader's listener: the only place samples are taken. Only data_available is enabled.
template <class Msg>
struct ReaderImpl : fdds::DataReaderListener {
  std::shared_ptr<NodeImpl> node;
  std::string topic_name;
  typename Traits<Msg>::PubSub type;  ///< for getSerializedSizeProvider
  typename Reader<Msg>::Callback callback;
  fdds::Subscriber* subscriber = nullptr;  ///< the node's subscriber of the reader's partition
  fdds::DataReader* reader = nullptr;

  std::mutex callback_mutex;           ///< held while taking and delivering; serialises callbacks
  bool stopped = false;                ///< guarded by callback_mutex
  Msg sample;                          ///< reused for every take; guarded by callback_mutex
  fdds::InstanceHandle_t last_writer;  ///< cache for writer_guid, guarded by callback_mutex
  std::string last_writer_guid;

  std::atomic<std::uint64_t> samples{0};
  std::atomic<std::uint64_t> bytes{0};
  std::atomic<std::uint64_t> mismatches{0};
  std::atomic<std::uint64_t> errors{0};
  std::set<std::string> mismatch_logged;  ///< writers named in a warning; guarded by callback_mutex

  /// Warns once per writer (last_writer_guid) that it speaks another protocol: a robot left on
  /// an older release is otherwise silently ignored. The samples of a protocol-2 peer reach
  /// this check: its unbounded types have the same names and wire format, so Fast DDS matches
  /// them (idl/esfleet.idl). At most 1000 writers are remembered, so a peer with ever new
  /// writers cannot grow the set or flood the log.
  void report_mismatch(std::uint16_t protocol) {
    constexpr std::size_t kMaxLogged = 1000;
    if (mismatch_logged.size() >= kMaxLogged || !mismatch_logged.insert(last_writer_guid).second) {
      return;
    }
    spdlog::warn(
        "{}: writer {} speaks esfleet protocol {}, this node protocol {}: its samples are dropped "
        "(further ones counted, not logged); upgrade {} so that both speak the same protocol",
        topic_name, last_writer_guid, protocol, kProtocolVersion,
        protocol < kProtocolVersion ? "that robot's esfleet" : "this node's esfleet");
  }

  void on_data_available(fdds::DataReader* r) override {
    std::lock_guard lock(callback_mutex);
    if (stopped) return;
    fdds::SampleInfo info;
    while (r->take_next_sample(&sample, &info) == ReturnCode_t::RETCODE_OK) {
      if (!info.valid_data) continue;  // dispose / unregister notifications carry no data
      if (info.publication_handle != last_writer || last_writer_guid.empty()) {
        std::ostringstream guid;
        guid << eprosima::fastrtps::rtps::iHandle2GUID(info.publication_handle);
        last_writer = info.publication_handle;
        last_writer_guid = guid.str();
      }
      if constexpr (Traits<Msg>::kHasProtocol) {
        if (sample.protocol() != kProtocolVersion) {
          mismatches.fetch_add(1, std::memory_order_relaxed);
          report_mismatch(sample.protocol());
          continue;
        }
      }
      SampleMeta meta;
      meta.writer_guid = last_writer_guid;
      meta.source_timestamp_ns = info.source_timestamp.to_ns();
      meta.reception_ns = info.reception_timestamp.to_ns();
      if (meta.reception_ns <= 0) meta.reception_ns = realtime_ns();
      const std::uint32_t size = type.getSerializedSizeProvider(&sample)();
      try {
        callback(sample, meta);
      } catch (...) {
        errors.fetch_add(1, std::memory_order_relaxed);
      }
      // Counted after the callback: whoever sees samples_received() == n knows that n
      // callbacks have returned.
      bytes.fetch_add(size, std::memory_order_relaxed);
      samples.fetch_add(1, std::memory_order_release);
    }
  }
};

}  // namespace detail

// ---------------------------------------------------------------------------------------------
// Writer

template <class Msg>
Writer<Msg>::Writer(Node& node, const std::string& partition)
    : Writer(node, default_endpoint<Msg>(), partition) {}

template <class Msg>
Writer<Msg>::Writer(Node& node, const TopicQos& endpoint, const std::string& partition)
    : impl_(std::make_unique<detail::WriterImpl<Msg>>()) {
  using T = Traits<Msg>;
  impl_->node = node.impl_;
  impl_->topic_name = endpoint.topic;
  detail::NodeImpl& n = *impl_->node;
  std::lock_guard lock(n.entity_mutex);
  if (n.participant == nullptr) {
    throw std::runtime_error("esfleet::dds: cannot create a writer of " + endpoint.topic +
                             ": the node is closed");
  }
  fdds::Topic* topic = n.topic(endpoint.topic, fdds::TypeSupport(new typename T::PubSub()));
  fdds::Publisher* publisher = impl_->publisher = n.publisher_in(partition);
  fdds::DataWriterQos qos = publisher->get_default_datawriter_qos();
  set_common_qos(qos, endpoint, endpoint.depth);
  // Heartbeat every 100 ms (default 3 s): a lost last sample is repaired within ~100 ms.
  qos.reliable_writer_qos().times.heartbeatPeriod = eprosima::fastrtps::Duration_t(0, 100'000'000);
  impl_->writer = publisher->create_datawriter(topic, qos, nullptr, fdds::StatusMask::none());
  if (impl_->writer == nullptr) {
    throw std::runtime_error("esfleet::dds: cannot create the DataWriter of " + endpoint.topic +
                             partition_suffix(partition) +
                             (n.secure ? " (with security: do the permissions allow it?)" : ""));
  }
}

template <class Msg>
Writer<Msg>::~Writer() {
  if (!impl_) return;
  detail::NodeImpl& n = *impl_->node;
  std::lock_guard lock(n.entity_mutex);
  if (n.participant != nullptr && impl_->writer != nullptr) {
    impl_->publisher->delete_datawriter(impl_->writer);
  }
}

template <class Msg>
bool Writer<Msg>::write(const Msg& sample) {
  auto fail = [this] {
    impl_->failures.fetch_add(1, std::memory_order_relaxed);
    return false;
  };
  if constexpr (Traits<Msg>::kHasProtocol) {
    if (sample.protocol() != kProtocolVersion) return fail();
  }
  // Fast DDS takes a non-const pointer but only reads the sample.
  void* data = const_cast<Msg*>(&sample);
  std::shared_lock lock(impl_->node->state_mutex);
  if (impl_->node->closed) return fail();
  if (impl_->writer->write(data, fdds::HANDLE_NIL) != ReturnCode_t::RETCODE_OK) return fail();
  impl_->bytes.fetch_add(impl_->type.getSerializedSizeProvider(data)(), std::memory_order_relaxed);
  impl_->samples.fetch_add(1, std::memory_order_relaxed);
  return true;
}

template <class Msg>
std::string_view Writer<Msg>::topic_name() const {
  return impl_->topic_name;
}

template <class Msg>
std::uint64_t Writer<Msg>::samples_written() const {
  return impl_->samples.load(std::memory_order_relaxed);
}

template <class Msg>
std::uint64_t Writer<Msg>::bytes_written() const {
  return impl_->bytes.load(std::memory_order_relaxed);
}

template <class Msg>
std::uint64_t Writer<Msg>::write_failures() const {
  return impl_->failures.load(std::memory_order_relaxed);
}

template <class Msg>
int Writer<Msg>::matched_readers() const {
  std::shared_lock lock(impl_->node->state_mutex);
  if (impl_->node->closed) return 0;
  fdds::PublicationMatchedStatus status;
  impl_->writer->get_publication_matched_status(status);
  return status.current_count;
}

template <class Msg>
bool Writer<Msg>::wait_for_matched(int count, std::chrono::milliseconds timeout) const {
  return poll_until(count, timeout, [this] { return matched_readers(); });
}

template <class Msg>
bool Writer<Msg>::wait_for_acknowledgments(std::chrono::milliseconds timeout) const {
  std::shared_lock lock(impl_->node->state_mutex);
  if (impl_->node->closed) return false;
  const auto ns = std::chrono::nanoseconds(timeout).count();
  const eprosima::fastrtps::Duration_t max_wait(static_cast<std::int32_t>(ns / 1'000'000'000),
                                                static_cast<std::uint32_t>(ns % 1'000'000'000));
  return impl_->writer->wait_for_acknowledgments(max_wait) == ReturnCode_t::RETCODE_OK;
}

// ---------------------------------------------------------------------------------------------
// Reader

template <class Msg>
Reader<Msg>::Reader(Node& node, Callback callback, const std::string& partition)
    : Reader(node, std::move(callback), default_endpoint<Msg>(), partition) {}

template <class Msg>
Reader<Msg>::Reader(Node& node, Callback callback, const TopicQos& endpoint,
                    const std::string& partition)
    : impl_(std::make_unique<detail::ReaderImpl<Msg>>()) {
  using T = Traits<Msg>;
  if (!callback) {
    throw std::invalid_argument("esfleet::dds: the callback of a reader of " + endpoint.topic +
                                " is empty");
  }
  impl_->callback = std::move(callback);
  impl_->node = node.impl_;
  impl_->topic_name = endpoint.topic;
  detail::NodeImpl& n = *impl_->node;
  std::lock_guard lock(n.entity_mutex);
  if (n.participant == nullptr) {
    throw std::runtime_error("esfleet::dds: cannot create a reader of " + endpoint.topic +
                             ": the node is closed");
  }
  fdds::Topic* topic = n.topic(endpoint.topic, fdds::TypeSupport(new typename T::PubSub()));
  fdds::Subscriber* subscriber = impl_->subscriber = n.subscriber_in(partition);
  fdds::DataReaderQos qos = subscriber->get_default_datareader_qos();
  set_common_qos(qos, endpoint, endpoint.reader_depth > 0 ? endpoint.reader_depth : endpoint.depth);
  if constexpr (T::kHasProtocol) {
    // Every esfleet type is bounded (idl/esfleet.idl), so its payload pool can hold samples of
    // exactly the type's maximum serialized size, and Fast DDS 2.9 refuses a longer sample
    // (ReaderHistory::can_change_be_added_nts) before reserving memory for it or reassembling
    // its fragments, and marks it irrelevant so that the writer does not resend it. Fast DDS
    // 2.9 also turns the default PREALLOCATED_WITH_REALLOC into this for a type whose
    // is_bounded() is true (DataReaderImpl::get_payload_pool), as fastddsgen's code says for
    // these types; set here so that the guarantee does not rest on that. For an unbounded type
    // the default grows the payload to any size a peer announces.
    qos.endpoint().history_memory_policy = eprosima::fastrtps::rtps::PREALLOCATED_MEMORY_MODE;
  }
  // The listener is attached to the DataReader with only data_available enabled (pitfall 1).
  impl_->reader =
      subscriber->create_datareader(topic, qos, impl_.get(), fdds::StatusMask::data_available());
  if (impl_->reader == nullptr) {
    throw std::runtime_error("esfleet::dds: cannot create the DataReader of " + endpoint.topic +
                             partition_suffix(partition) +
                             (n.secure ? " (with security: do the permissions allow it?)" : ""));
  }
}

template <class Msg>
Reader<Msg>::~Reader() {
  if (!impl_) return;
  {
    std::lock_guard lock(impl_->callback_mutex);  // waits for a running callback
    impl_->stopped = true;
  }
  detail::NodeImpl& n = *impl_->node;
  std::lock_guard lock(n.entity_mutex);
  if (n.participant != nullptr && impl_->reader != nullptr) {
    impl_->subscriber->delete_datareader(impl_->reader);
  }
}

template <class Msg>
std::string_view Reader<Msg>::topic_name() const {
  return impl_->topic_name;
}

template <class Msg>
std::uint64_t Reader<Msg>::samples_received() const {
  return impl_->samples.load(std::memory_order_acquire);
}

template <class Msg>
std::uint64_t Reader<Msg>::bytes_received() const {
  return impl_->bytes.load(std::memory_order_relaxed);
}

template <class Msg>
std::uint64_t Reader<Msg>::protocol_mismatches() const {
  return impl_->mismatches.load(std::memory_order_relaxed);
}

template <class Msg>
std::uint64_t Reader<Msg>::callback_errors() const {
  return impl_->errors.load(std::memory_order_relaxed);
}

template <class Msg>
int Reader<Msg>::matched_writers() const {
  std::shared_lock lock(impl_->node->state_mutex);
  if (impl_->node->closed) return 0;
  fdds::SubscriptionMatchedStatus status;
  impl_->reader->get_subscription_matched_status(status);
  return status.current_count;
}

template <class Msg>
bool Reader<Msg>::wait_for_matched(int count, std::chrono::milliseconds timeout) const {
  return poll_until(count, timeout, [this] { return matched_writers(); });
}

template class Writer<msg::MapTile>;
template class Writer<msg::MapTileDelta>;
template class Writer<msg::MapMeta>;
template class Writer<msg::RobotPose>;
template class Writer<msg::LaserScanMsg>;
template class Writer<msg::TruthPose>;
template class Writer<msg::ContributedScan>;
template class Writer<msg::ContributionStatus>;
template class Reader<msg::MapTile>;
template class Reader<msg::MapTileDelta>;
template class Reader<msg::MapMeta>;
template class Reader<msg::RobotPose>;
template class Reader<msg::LaserScanMsg>;
template class Reader<msg::TruthPose>;
template class Reader<msg::ContributedScan>;
template class Reader<msg::ContributionStatus>;
template class Writer<nav_msgs::msg::OccupancyGrid>;
template class Writer<map_msgs::msg::OccupancyGridUpdate>;
template class Writer<geometry_msgs::msg::PoseWithCovarianceStamped>;
template class Writer<tf2_msgs::msg::TFMessage>;
template class Writer<sensor_msgs::msg::LaserScan>;
template class Writer<nav_msgs::msg::Odometry>;
template class Reader<nav_msgs::msg::OccupancyGrid>;
template class Reader<map_msgs::msg::OccupancyGridUpdate>;
template class Reader<geometry_msgs::msg::PoseWithCovarianceStamped>;
template class Reader<tf2_msgs::msg::TFMessage>;
template class Reader<sensor_msgs::msg::LaserScan>;
template class Reader<nav_msgs::msg::Odometry>;

}  // namespace esfleet::dds
