#include "foxglove.hpp"

#include <fastcdr/Cdr.h>
#include <fastcdr/FastBuffer.h>

#include <cmath>
#include <cstring>
#include <nlohmann/json.hpp>
#include <string>

#include "esfleet/dds/ros_msg.hpp"

namespace esfleet::view {

namespace {

// The schemas in the concatenated form ros2msg schemas use (what `ros2 interface show` prints,
// each dependency after a line of '=' and "MSG: "), built from the dependencies they share.
const std::string kSeparator = std::string(80, '=') + "\n";
/// std_msgs/Header and what it needs.
const std::string kHeaderDependencies = kSeparator +
                                        "MSG: std_msgs/Header\n"
                                        "builtin_interfaces/Time stamp\n"
                                        "string frame_id\n" +
                                        kSeparator +
                                        "MSG: builtin_interfaces/Time\n"
                                        "int32 sec\n"
                                        "uint32 nanosec\n";
/// geometry_msgs/Pose and what it needs.
const std::string kPoseDependencies = kSeparator +
                                      "MSG: geometry_msgs/Pose\n"
                                      "Point position\n"
                                      "Quaternion orientation\n" +
                                      kSeparator +
                                      "MSG: geometry_msgs/Point\n"
                                      "float64 x\n"
                                      "float64 y\n"
                                      "float64 z\n" +
                                      kSeparator +
                                      "MSG: geometry_msgs/Quaternion\n"
                                      "float64 x 0\n"
                                      "float64 y 0\n"
                                      "float64 z 0\n"
                                      "float64 w 1\n";

/// nav_msgs/msg/OccupancyGrid.
const std::string kOccupancyGridSchema =
    "std_msgs/Header header\n"
    "MapMetaData info\n"
    "int8[] data\n" +
    kHeaderDependencies + kSeparator +
    "MSG: nav_msgs/MapMetaData\n"
    "builtin_interfaces/Time map_load_time\n"
    "float32 resolution\n"
    "uint32 width\n"
    "uint32 height\n"
    "geometry_msgs/Pose origin\n" +
    kPoseDependencies;

/// geometry_msgs/msg/PoseArray.
const std::string kPoseArraySchema =
    "std_msgs/Header header\n"
    "geometry_msgs/Pose[] poses\n" +
    kHeaderDependencies + kPoseDependencies;

/// Little-endian CDR by hand for PoseArray (plain fields, alignment from the encapsulation's
/// end).
class CdrWriter {
 public:
  CdrWriter() { out_.assign("\x00\x01\x00\x00", 4); }
  template <class T>
  void put(T v) {
    while ((out_.size() - 4) % sizeof(T) != 0) out_.push_back('\0');
    out_.append(reinterpret_cast<const char*>(&v), sizeof v);
  }
  void put_string(const std::string& s) {
    put(static_cast<std::uint32_t>(s.size() + 1));
    out_ += s;
    out_.push_back('\0');
  }
  std::string take() { return std::move(out_); }

 private:
  std::string out_;
};

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

}  // namespace

std::optional<std::string> foxglove_subprotocol(std::string_view offered) {
  for (std::string_view want : kFoxgloveSubprotocols) {
    std::string_view rest = offered;
    while (!rest.empty()) {
      const std::size_t comma = rest.find(',');
      if (trim(rest.substr(0, comma)) == want) return std::string(want);
      if (comma == std::string_view::npos) break;
      rest.remove_prefix(comma + 1);
    }
  }
  return std::nullopt;
}

std::string foxglove_server_info() {
  return nlohmann::json{{"op", "serverInfo"},
                        {"name", "esfleet-view"},
                        {"capabilities", nlohmann::json::array()},
                        {"supportedEncodings", nlohmann::json::array()},
                        {"metadata", nlohmann::json::object()},
                        {"sessionId", "esfleet-view"}}
      .dump();
}

std::string foxglove_advertise() {
  return nlohmann::json{{"op", "advertise"},
                        {"channels",
                         {{{"id", kFoxgloveMapChannel},
                           {"topic", "/map"},
                           {"encoding", "cdr"},
                           {"schemaName", "nav_msgs/msg/OccupancyGrid"},
                           {"schema", kOccupancyGridSchema},
                           {"schemaEncoding", "ros2msg"}},
                          {{"id", kFoxgloveRobotsChannel},
                           {"topic", "/robots"},
                           {"encoding", "cdr"},
                           {"schemaName", "geometry_msgs/msg/PoseArray"},
                           {"schema", kPoseArraySchema},
                           {"schemaEncoding", "ros2msg"}}}}}
      .dump();
}

FoxgloveRequest parse_foxglove_request(std::string_view text) {
  FoxgloveRequest r;
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (!j.is_object() || !j.contains("op") || !j["op"].is_string()) return r;
  const auto id_of = [](const nlohmann::json& v) -> std::optional<std::uint32_t> {
    if (!v.is_number_unsigned() || v.get<std::uint64_t>() > 0xffffffffu) return std::nullopt;
    return v.get<std::uint32_t>();
  };
  const std::string op = j["op"];
  if (op == "subscribe" && j.contains("subscriptions") && j["subscriptions"].is_array()) {
    for (const auto& s : j["subscriptions"]) {
      if (!s.is_object() || !s.contains("id") || !s.contains("channelId")) continue;
      const auto id = id_of(s["id"]), channel = id_of(s["channelId"]);
      if (id && channel &&
          (*channel == kFoxgloveMapChannel || *channel == kFoxgloveRobotsChannel)) {
        r.subscribe.emplace_back(*id, *channel);
      }
    }
  } else if (op == "unsubscribe" && j.contains("subscriptionIds") &&
             j["subscriptionIds"].is_array()) {
    for (const auto& v : j["subscriptionIds"]) {
      if (const auto id = id_of(v)) r.unsubscribe.push_back(*id);
    }
  }
  return r;
}

std::string foxglove_message_data(std::uint32_t subscription, std::uint64_t stamp_ns,
                                  const std::string& payload) {
  std::string out(13, '\0');
  out[0] = 0x01;
  std::memcpy(out.data() + 1, &subscription, 4);  // little-endian (x86-64, arm64)
  std::memcpy(out.data() + 5, &stamp_ns, 8);
  out += payload;
  return out;
}

std::string occupancy_grid_cdr(const GridMap& map, double stamp_s) {
  const nav_msgs::msg::OccupancyGrid grid =
      dds::grid_to_ros(map, dds::map_window(map), OccupancyThresholds{}, stamp_s, "map");
  std::string out(nav_msgs::msg::OccupancyGrid::getCdrSerializedSize(grid) + 4, '\0');
  eprosima::fastcdr::FastBuffer buffer(out.data(), out.size());
  eprosima::fastcdr::Cdr cdr(buffer, eprosima::fastcdr::Cdr::DEFAULT_ENDIAN,
                             eprosima::fastcdr::Cdr::DDS_CDR);
  cdr.serialize_encapsulation();
  grid.serialize(cdr);
  out.resize(cdr.getSerializedDataLength());
  return out;
}

std::string pose_array_cdr(const std::vector<PlanarPose>& poses, double stamp_s) {
  CdrWriter w;
  const double sec = std::floor(stamp_s);
  w.put(static_cast<std::int32_t>(sec));
  w.put(static_cast<std::uint32_t>((stamp_s - sec) * 1e9));
  w.put_string("map");
  w.put(static_cast<std::uint32_t>(poses.size()));
  for (const PlanarPose& p : poses) {
    for (double v : {p.x, p.y, 0.0, 0.0, 0.0, std::sin(p.theta / 2), std::cos(p.theta / 2)}) {
      w.put(v);
    }
  }
  return w.take();
}

}  // namespace esfleet::view
