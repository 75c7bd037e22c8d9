#pragma once
// The Foxglove WebSocket protocol (foxglove.websocket.v1; foxglove.sdk.v1 is the same under the
// current name), as far as esfleet-view speaks it: two channels in ROS 2 CDR with their ros2msg
// schemas, /map (nav_msgs/msg/OccupancyGrid, the whole map: no such viewer handles tiled
// updates; the page does) and /robots (geometry_msgs/msg/PoseArray, every robot's pose), so that
// a user's Foxglove or Lichtblick app connects to the view directly.
// The JSON operations and the binary MessageData layout are the protocol's (docs/view.md).

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "esfleet/core/grid_map.hpp"

namespace esfleet::view {

/// The subprotocols a Foxglove client may ask for, in the order the server prefers them.
inline constexpr std::string_view kFoxgloveSubprotocols[] = {"foxglove.websocket.v1",
                                                             "foxglove.sdk.v1"};
/// The channel ids: the map, the robots' poses.
inline constexpr std::uint32_t kFoxgloveMapChannel = 1;
inline constexpr std::uint32_t kFoxgloveRobotsChannel = 2;

/// The subprotocol to answer with for a Sec-WebSocket-Protocol request header (comma-separated
/// offers), or std::nullopt when none is Foxglove's.
std::optional<std::string> foxglove_subprotocol(std::string_view offered);

/// {"op":"serverInfo",...} and {"op":"advertise",...} (both channels), sent on connect.
std::string foxglove_server_info();
std::string foxglove_advertise();

/// What a client's text asks: {"op":"subscribe"} (subscription id -> one of our channels) or
/// {"op":"unsubscribe"} (subscription ids). Unknown channels, other operations and malformed
/// JSON give an empty request.
struct FoxgloveRequest {
  std::vector<std::pair<std::uint32_t, std::uint32_t>> subscribe;  ///< (subscription, channel)
  std::vector<std::uint32_t> unsubscribe;                          ///< subscription ids
};
FoxgloveRequest parse_foxglove_request(std::string_view text);

/// A binary MessageData frame: opcode 0x01, subscription id, receive time (ns), payload.
std::string foxglove_message_data(std::uint32_t subscription, std::uint64_t stamp_ns,
                                  const std::string& payload);

/// The whole map as a nav_msgs/msg/OccupancyGrid (dds::grid_to_ros over all tiles, frame "map")
/// serialised as ROS 2 CDR (encapsulation header first), what the /map channel carries.
std::string occupancy_grid_cdr(const GridMap& map, double stamp_s);

/// A robot's position and heading in the map frame.
struct PlanarPose {
  double x = 0.0, y = 0.0, theta = 0.0;
};
/// The robots as a geometry_msgs/msg/PoseArray in ROS 2 CDR (frame "map"), what /robots carries.
std::string pose_array_cdr(const std::vector<PlanarPose>& poses, double stamp_s);

}  // namespace esfleet::view
