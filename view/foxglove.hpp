#pragma once
// The Foxglove WebSocket protocol (foxglove.websocket.v1; foxglove.sdk.v1 is the same under the
// current name), as far as esfleet-view speaks it: one channel, /map, a nav_msgs/msg/OccupancyGrid
// in ROS 2 CDR with its ros2msg schema, so that a user's Foxglove or Lichtblick app connects to
// the view directly and sees the whole map (no such viewer handles tiled updates; the page does).
// The JSON operations and the binary MessageData layout are the protocol's (docs/view.md).

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "esfleet/core/grid_map.hpp"

namespace esfleet::view {

/// The subprotocols a Foxglove client may ask for, in the order the server prefers them.
inline constexpr std::string_view kFoxgloveSubprotocols[] = {"foxglove.websocket.v1",
                                                             "foxglove.sdk.v1"};
/// The map's channel id.
inline constexpr std::uint32_t kFoxgloveMapChannel = 1;

/// The subprotocol to answer with for a Sec-WebSocket-Protocol request header (comma-separated
/// offers), or std::nullopt when none is Foxglove's.
std::optional<std::string> foxglove_subprotocol(std::string_view offered);

/// {"op":"serverInfo",...} and {"op":"advertise",...} (the /map channel), sent on connect.
std::string foxglove_server_info();
std::string foxglove_advertise();

/// The subscription id a client's {"op":"subscribe"} text gives the map channel; std::nullopt
/// for anything else (other operations, other channels, malformed JSON). `unsubscribed` is set
/// when the text unsubscribes `current`.
struct FoxgloveRequest {
  std::optional<std::uint32_t> subscribe_map;  ///< subscription id for the map channel
  bool unsubscribe = false;                    ///< unsubscribes the given id
  std::uint32_t unsubscribe_id = 0;
};
FoxgloveRequest parse_foxglove_request(std::string_view text, std::uint32_t current);

/// A binary MessageData frame: opcode 0x01, subscription id, receive time (ns), payload.
std::string foxglove_message_data(std::uint32_t subscription, std::uint64_t stamp_ns,
                                  const std::string& payload);

/// The whole map as a nav_msgs/msg/OccupancyGrid (dds::grid_to_ros over all tiles, frame "map")
/// serialised as ROS 2 CDR (encapsulation header first), what the /map channel carries.
std::string occupancy_grid_cdr(const GridMap& map, double stamp_s);

}  // namespace esfleet::view
