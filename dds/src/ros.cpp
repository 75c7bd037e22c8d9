#include "esfleet/dds/ros.hpp"

#include <algorithm>

namespace esfleet::dds {
namespace {

bool is_token_char(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
}

/// Checks `path` (tokens separated by single '/', optionally starting with '/'); throws
/// RosNameError naming `what` and the name.
void check_tokens(std::string_view path, std::string_view what, std::string_view whole) {
  auto fail = [&](const std::string& why) {
    throw RosNameError("ROS " + std::string(what) + " '" + std::string(whole) + "' " + why);
  };
  if (!path.empty() && path.front() == '/') path.remove_prefix(1);
  if (path.empty()) fail("is empty");
  std::size_t start = 0;
  while (start <= path.size()) {
    const std::size_t end = std::min(path.find('/', start), path.size());
    const std::string_view token = path.substr(start, end - start);
    if (token.empty()) fail("has an empty token ('//' or a trailing '/')");
    if (token.front() >= '0' && token.front() <= '9') fail("has a token starting with a digit");
    for (char c : token) {
      if (!is_token_char(c)) fail("may hold only letters, digits, '_' and '/'");
    }
    start = end + 1;
  }
}

TopicQos endpoint(std::string_view full_name, bool reliable, bool transient_local,
                  std::int32_t depth) {
  return TopicQos{ros_dds_topic(full_name), reliable, transient_local, depth};
}

}  // namespace

std::string ros_name(std::string_view ns, std::string_view name) {
  check_tokens(name, "name", name);
  const bool root = ns.empty() || ns == "/";
  if (!root) check_tokens(ns, "namespace", ns);
  if (name.front() == '/') return std::string(name);
  if (root) return std::string("/").append(name);
  std::string full;
  if (ns.front() != '/') full += '/';
  full.append(ns);
  full += '/';
  full.append(name);
  return full;
}

std::string ros_dds_topic(std::string_view full_name) {
  std::string topic = "rt";
  topic.append(full_name);
  return topic;
}

std::string ros_frame(std::string_view ns, std::string_view frame) {
  check_tokens(frame, "frame", frame);
  if (frame.front() == '/') frame.remove_prefix(1);
  const bool root = ns.empty() || ns == "/";
  if (!root) check_tokens(ns, "namespace", ns);
  std::string prefix = root ? std::string() : std::string(ns);
  if (!prefix.empty() && prefix.front() == '/') prefix.erase(0, 1);
  return prefix.empty() ? std::string(frame) : prefix + "/" + std::string(frame);
}

TopicQos ros_map_endpoint(std::string_view full_name) { return endpoint(full_name, true, true, 1); }
TopicQos ros_map_updates_endpoint(std::string_view full_name) {
  return endpoint(full_name, true, false, 16);
}
TopicQos ros_pose_endpoint(std::string_view full_name) {
  return endpoint(full_name, true, true, 1);
}
TopicQos ros_initialpose_endpoint(std::string_view full_name) {
  return endpoint(full_name, true, false, 1);
}
TopicQos ros_tf_endpoint() { return endpoint("/tf", true, false, 100); }
TopicQos ros_tf_static_endpoint(bool reader) {
  return endpoint("/tf_static", true, true, reader ? 100 : 1);
}
TopicQos ros_scan_endpoint(std::string_view full_name, bool reader) {
  return reader ? endpoint(full_name, false, false, 5) : endpoint(full_name, true, false, 50);
}
TopicQos ros_odom_endpoint(std::string_view full_name, bool reader) {
  return endpoint(full_name, !reader, false, 50);
}

}  // namespace esfleet::dds
