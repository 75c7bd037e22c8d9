#pragma once
// esfleet::dds::Node: one DDS DomainParticipant with its Publisher, Subscriber and topics, the
// object every writer and reader of the esfleet topics hangs off. Plain C++ API: Fast DDS headers
// stay in dds/src/, so programs that only hold a Node compile fast.
//
// Life cycle: the constructor creates participant -> publisher -> subscriber and throws
// std::runtime_error naming the step (and the profile file) that failed. The destructor deletes
// every contained entity and then the participant, which also releases the participant's
// shared-memory files in /dev/shm. Destroy writers and readers before their Node; if the Node
// goes first they become inert (write() returns false, no more callbacks) and are safe to destroy.

#include <memory>
#include <string>

#include "esfleet/dds/topics.hpp"

namespace esfleet::dds {

/// How a Node joins DDS.
struct NodeOptions {
  /// DDS domain id, 0..kMaxDomain. Nodes only see nodes of the same domain.
  int domain = kDefaultDomain;
  /// Fast DDS XML profile file; its default participant profile (is_default_profile="true") is
  /// used: transports, discovery, locators. Empty: the Fast DDS defaults (shared memory + UDPv4,
  /// multicast discovery), or the default profile of $FASTRTPS_DEFAULT_PROFILES_FILE if set.
  /// See deploy/fastdds/README.md for the shipped profiles.
  std::string profile_file;
  /// Participant name shown by discovery tools; empty keeps the profile's name.
  std::string name;
  /// DDS Security (docs/security.md): empty = off. Otherwise a directory holding this
  /// participant's security files under the fixed names kSecurityFiles (identity_ca.pem,
  /// cert.pem, key.pem, permissions_ca.pem, governance.p7s, permissions.p7s; optional crl.pem),
  /// as made by deploy/security/make-fleet-certs.sh. The node turns on PKI-DH authentication,
  /// AES-GCM-GMAC encryption and Access-Permissions access control with them.
  std::string secure_dir = {};  // "= {}": aggregate inits that stop before it need no warning
};

/// The files a NodeOptions::secure_dir must hold (all required).
inline constexpr const char* kSecurityFiles[] = {"identity_ca.pem", "cert.pem",
                                                 "key.pem",         "permissions_ca.pem",
                                                 "governance.p7s",  "permissions.p7s"};
/// Optional file in NodeOptions::secure_dir: a certificate revocation list of the identity CA.
inline constexpr const char* kSecurityCrlFile = "crl.pem";

namespace detail {
struct NodeImpl;
}

template <class Msg>
class Writer;
template <class Msg>
class Reader;

/// Owns one DomainParticipant plus the Publisher, Subscriber and Topics of the esfleet topics.
/// Thread-safe: writers and readers may be created and destroyed from any thread.
///
/// Whatever the profile says, the node raises the participant's initial discovery announcements
/// to at least kMinInitialAnnouncements (every 100 ms): with Fast DDS's default of 5, about one
/// start in three where the subscriber came first took 3 s to match (measured with Fast DDS 2.9.1
/// between two processes on one host).
class Node {
 public:
  /// Minimum number of initial participant announcements (see the class comment).
  static constexpr int kMinInitialAnnouncements = 20;

  /// Creates the participant. Throws std::runtime_error with a message naming the cause: domain
  /// out of range, missing or unreadable profile file, XML errors, no default participant
  /// profile in the file, a missing or unreadable security file (named, checked before Fast DDS
  /// sees it), or Fast DDS refusing to create an entity (with security: a certificate, key or
  /// signed XML that Fast DDS rejects; its own messages on stdout say which).
  explicit Node(NodeOptions options = {});
  ~Node();
  Node(const Node&) = delete;
  Node& operator=(const Node&) = delete;

  const NodeOptions& options() const { return options_; }
  int domain() const { return options_.domain; }
  /// The participant's GUID prefix ("01.0f.a2....") for logs; identifies this node's writers in
  /// SampleMeta::writer_guid.
  std::string guid_prefix() const;

 private:
  template <class Msg>
  friend class Writer;
  template <class Msg>
  friend class Reader;

  NodeOptions options_;
  std::shared_ptr<detail::NodeImpl> impl_;  ///< shared with the node's writers and readers
};

}  // namespace esfleet::dds
