// esfleet::dds::Node: creates the DomainParticipant (from the default participant profile of an
// optional Fast DDS XML file), its Publisher and Subscriber, and tears them down in reverse.
// One of the two translation units of esfleet_dds that include Fast DDS headers.

#include "esfleet/dds/node.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string_view>
#include <system_error>

#include <esfleet/msg/esfleet.h>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/domain/qos/DomainParticipantQos.hpp>
#include <fastdds/dds/publisher/qos/PublisherQos.hpp>
#include <fastdds/dds/subscriber/qos/SubscriberQos.hpp>

#include "node_impl.hpp"

namespace esfleet::dds {

static_assert(kProtocolVersion == msg::kProtocolVersion,
              "topics.hpp and idl/esfleet.idl disagree on the protocol version");

namespace {

namespace fdds = eprosima::fastdds::dds;
using eprosima::fastrtps::types::ReturnCode_t;

[[noreturn]] void fail(const std::string& what) {
  throw std::runtime_error("esfleet::dds::Node: " + what);
}

/// True if `xml` holds an attribute is_default_profile="true" (or 'true').
bool has_default_profile(const std::string& xml) {
  const std::string_view attribute = "is_default_profile";
  for (auto at = xml.find(attribute); at != std::string::npos; at = xml.find(attribute, at + 1)) {
    auto i = xml.find_first_not_of(" \t\r\n", at + attribute.size());
    if (i == std::string::npos || xml[i] != '=') continue;
    i = xml.find_first_not_of(" \t\r\n", i + 1);
    if (i == std::string::npos || (xml[i] != '"' && xml[i] != '\'')) continue;
    if (xml.compare(i + 1, 5, "true" + std::string(1, xml[i])) == 0) return true;
  }
  return false;
}

/// Participant QoS of a profile file, or of the built-in defaults for an empty name.
///
/// Fast DDS keeps one process-wide default participant profile (that of the XML file loaded
/// last; reloading a file is a no-op), and load_XML_profiles_file() does not even apply it to the
/// factory's default QoS. So each file is loaded once, its default profile turned into a QoS and
/// cached here; the factory default is then put back to the built-in one, so a Node without a
/// profile never inherits another Node's file.
fdds::DomainParticipantQos participant_qos(const std::string& profile_file) {
  static std::mutex mutex;
  static std::optional<fdds::DomainParticipantQos> builtin;
  static std::map<std::string, fdds::DomainParticipantQos> by_file;
  std::lock_guard lock(mutex);

  fdds::DomainParticipantFactory* factory = fdds::DomainParticipantFactory::get_instance();
  if (!builtin) {
    // load_profiles() (which also reads $FASTRTPS_DEFAULT_PROFILES_FILE) must run before
    // get_default_participant_qos(), or Fast DDS 2.9.1 ignores the file's default profile.
    factory->load_profiles();
    builtin = factory->get_default_participant_qos();
  }
  if (profile_file.empty()) return *builtin;

  std::error_code ec;
  const std::filesystem::path path(profile_file);
  if (!std::filesystem::is_regular_file(path, ec)) {
    fail("Fast DDS profile file '" + profile_file + "' does not exist or is not a regular file");
  }
  const std::string key = std::filesystem::weakly_canonical(path, ec).string();
  if (auto it = by_file.find(key); it != by_file.end()) return it->second;

  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  if (!in) fail("cannot read Fast DDS profile file '" + profile_file + "'");
  if (!has_default_profile(text.str())) {
    fail("Fast DDS profile file '" + profile_file +
         "' has no participant profile with is_default_profile=\"true\"");
  }
  if (factory->load_XML_profiles_file(profile_file) != ReturnCode_t::RETCODE_OK) {
    fail("Fast DDS could not load profile file '" + profile_file +
         "' (invalid XML or a duplicate profile name; Fast DDS printed details on stdout)");
  }
  // load_XML_profiles_file() does not touch the factory's default participant QoS (only the
  // first load_profiles() does): re-derive it from the XML default profile just loaded, take a
  // copy, and put the built-in default back.
  factory->set_default_participant_qos(fdds::PARTICIPANT_QOS_DEFAULT);
  fdds::DomainParticipantQos qos = factory->get_default_participant_qos();
  factory->set_default_participant_qos(*builtin);
  return by_file.emplace(key, std::move(qos)).first->second;
}

/// Turns on DDS Security with the files in `dir` (NodeOptions::secure_dir): PKI-DH
/// authentication, AES-GCM-GMAC crypto, Access-Permissions access control. Every file is checked
/// here first, because Fast DDS only prints a generic error to stdout and returns no participant.
/// URIs must be file:///absolute (Fast DDS 2.9.1 refuses file:/absolute).
void add_security_properties(fdds::DomainParticipantQos& qos, const std::string& dir) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path base = fs::absolute(dir, ec);
  if (ec || !fs::is_directory(base, ec)) {
    fail("security directory '" + dir + "' does not exist or is not a directory");
  }
  auto uri = [&](const char* file, bool required) -> std::optional<std::string> {
    const fs::path path = base / file;
    if (!fs::is_regular_file(path, ec)) {
      if (!required && !fs::exists(path, ec)) return std::nullopt;
      fail("security file '" + path.string() + "' is missing or not a regular file");
    }
    std::ifstream in(path);
    if (!in || in.peek() == std::ifstream::traits_type::eof()) {
      fail("security file '" + path.string() + "' is unreadable or empty");
    }
    return "file://" + fs::weakly_canonical(path, ec).string();
  };
  std::map<std::string, std::string> files;
  for (const char* file : kSecurityFiles) files[file] = *uri(file, true);
  const std::optional<std::string> crl = uri(kSecurityCrlFile, false);

  auto& props = qos.properties().properties();
  auto set = [&](const std::string& name, const std::string& value) {
    props.emplace_back(name, value);
  };
  const std::string auth = "dds.sec.auth.builtin.PKI-DH.";
  const std::string access = "dds.sec.access.builtin.Access-Permissions.";
  set("dds.sec.auth.plugin", "builtin.PKI-DH");
  set(auth + "identity_ca", files["identity_ca.pem"]);
  set(auth + "identity_certificate", files["cert.pem"]);
  set(auth + "private_key", files["key.pem"]);
  if (crl) set(auth + "identity_crl", *crl);
  set("dds.sec.crypto.plugin", "builtin.AES-GCM-GMAC");
  set("dds.sec.access.plugin", "builtin.Access-Permissions");
  set(access + "permissions_ca", files["permissions_ca.pem"]);
  set(access + "governance", files["governance.p7s"]);
  set(access + "permissions", files["permissions.p7s"]);
}

}  // namespace

namespace detail {

fdds::Topic* NodeImpl::topic(std::string_view name, fdds::TypeSupport type) {
  if (auto it = topics.find(name); it != topics.end()) return it->second;
  if (type.register_type(participant) != ReturnCode_t::RETCODE_OK) {
    throw std::runtime_error("esfleet::dds: cannot register type " + type.get_type_name());
  }
  fdds::Topic* t =
      participant->create_topic(std::string(name), type.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
  if (t == nullptr) {
    throw std::runtime_error("esfleet::dds: cannot create topic " + std::string(name));
  }
  topics.emplace(std::string(name), t);
  return t;
}

fdds::Publisher* NodeImpl::publisher_in(const std::string& partition) {
  if (partition.empty()) return publisher;
  if (auto it = partition_publishers.find(partition); it != partition_publishers.end()) {
    return it->second;
  }
  fdds::PublisherQos qos = participant->get_default_publisher_qos();
  qos.partition().push_back(partition.c_str());
  fdds::Publisher* p = participant->create_publisher(qos);
  if (p == nullptr) {
    throw std::runtime_error("esfleet::dds: cannot create a Publisher in partition '" + partition +
                             "'");
  }
  return partition_publishers.emplace(partition, p).first->second;
}

fdds::Subscriber* NodeImpl::subscriber_in(const std::string& partition) {
  if (partition.empty()) return subscriber;
  if (auto it = partition_subscribers.find(partition); it != partition_subscribers.end()) {
    return it->second;
  }
  fdds::SubscriberQos qos = participant->get_default_subscriber_qos();
  qos.partition().push_back(partition.c_str());
  fdds::Subscriber* s = participant->create_subscriber(qos);
  if (s == nullptr) {
    throw std::runtime_error("esfleet::dds: cannot create a Subscriber in partition '" + partition +
                             "'");
  }
  return partition_subscribers.emplace(partition, s).first->second;
}

void NodeImpl::close() {
  {
    std::unique_lock lock(state_mutex);  // waits for writes in progress
    closed = true;
  }
  std::lock_guard lock(entity_mutex);
  if (participant == nullptr) return;
  // Deleting a DataReader waits for its running listener callback; that callback may write,
  // which is why state_mutex is not held here.
  participant->delete_contained_entities();
  fdds::DomainParticipantFactory::get_instance()->delete_participant(participant);
  participant = nullptr;
  publisher = nullptr;
  subscriber = nullptr;
  topics.clear();
  partition_publishers.clear();
  partition_subscribers.clear();
}

}  // namespace detail

Node::Node(NodeOptions options)
    : options_(std::move(options)), impl_(std::make_shared<detail::NodeImpl>()) {
  if (options_.domain < 0 || options_.domain > kMaxDomain) {
    fail("domain " + std::to_string(options_.domain) + " is out of range 0.." +
         std::to_string(kMaxDomain));
  }
  fdds::DomainParticipantQos qos = participant_qos(options_.profile_file);
  if (!options_.name.empty()) qos.name(options_.name);
  if (!options_.secure_dir.empty()) {
    add_security_properties(qos, options_.secure_dir);
    impl_->secure = true;
  }
  auto& announcements = qos.wire_protocol().builtin.discovery_config.initial_announcements;
  announcements.count =
      std::max(announcements.count, static_cast<std::uint32_t>(kMinInitialAnnouncements));

  // StatusMask::none(): no participant listener callbacks may swallow reader data (pitfall 1).
  impl_->participant = fdds::DomainParticipantFactory::get_instance()->create_participant(
      static_cast<fdds::DomainId_t>(options_.domain), qos, nullptr, fdds::StatusMask::none());
  const std::string where =
      " on domain " + std::to_string(options_.domain) +
      (options_.profile_file.empty() ? std::string(" with the default QoS")
                                     : " with profile file '" + options_.profile_file + "'") +
      (options_.secure_dir.empty()
           ? std::string()
           : " and security files in '" + options_.secure_dir +
                 "' (Fast DDS rejected a certificate, key or signed XML file: see its messages)");
  if (impl_->participant == nullptr) fail("cannot create the DomainParticipant" + where);
  impl_->publisher = impl_->participant->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
  if (impl_->publisher == nullptr) {
    impl_->close();
    fail("cannot create the Publisher" + where);
  }
  impl_->subscriber = impl_->participant->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
  if (impl_->subscriber == nullptr) {
    impl_->close();
    fail("cannot create the Subscriber" + where);
  }
}

Node::~Node() { impl_->close(); }

std::string Node::guid_prefix() const {
  std::lock_guard lock(impl_->entity_mutex);
  if (impl_->participant == nullptr) return {};
  std::ostringstream out;
  out << impl_->participant->guid().guidPrefix;
  return out.str();
}

}  // namespace esfleet::dds
