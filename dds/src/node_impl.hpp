#pragma once
// Internal: the Fast DDS side of esfleet::dds::Node, shared by node.cpp and endpoints.cpp.
// Includes Fast DDS headers; never include it from a public header.

#include <map>
#include <mutex>
#include <shared_mutex>
#include <string>
#include <string_view>

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/Topic.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>

namespace esfleet::dds::detail {

namespace fdds = eprosima::fastdds::dds;

/// The participant and its contained entities. Two locks, so that a reader callback that writes
/// (shared state lock) can never deadlock against a destructor that waits for that callback while
/// deleting entities (entity lock only):
///   state_mutex:    `closed`; writers hold it shared for the duration of a DataWriter::write.
///   entity_mutex:   creation and deletion of entities, `topics`, and `participant` itself.
struct NodeImpl {
  fdds::DomainParticipant* participant = nullptr;
  fdds::Publisher* publisher = nullptr;
  fdds::Subscriber* subscriber = nullptr;
  bool secure = false;  ///< DDS Security on (NodeOptions::secure_dir set); for error messages

  std::shared_mutex state_mutex;
  bool closed = false;  ///< guarded by state_mutex; set once the node is being destroyed

  std::mutex entity_mutex;
  std::map<std::string, fdds::Topic*, std::less<>> topics;  ///< guarded by entity_mutex
  /// Publishers and Subscribers of non-default partitions, by partition name; created on first
  /// use. Partition QoS lives on the Publisher/Subscriber (this is also what DDS Security access
  /// control checks). Guarded by entity_mutex.
  std::map<std::string, fdds::Publisher*, std::less<>> partition_publishers;
  std::map<std::string, fdds::Subscriber*, std::less<>> partition_subscribers;

  /// The topic `name` of type `type`, created (and the type registered) on first use.
  /// Caller holds entity_mutex. Throws std::runtime_error if Fast DDS refuses.
  fdds::Topic* topic(std::string_view name, fdds::TypeSupport type);

  /// The Publisher (Subscriber) of partition `partition`: the node's default one for "", else
  /// one with that single partition name, created on first use. Caller holds entity_mutex.
  /// Throws std::runtime_error if Fast DDS refuses (with security: the permissions do not allow
  /// this partition for any topic).
  fdds::Publisher* publisher_in(const std::string& partition);
  fdds::Subscriber* subscriber_in(const std::string& partition);

  /// Deletes every contained entity and the participant; idempotent.
  void close();
};

}  // namespace esfleet::dds::detail
