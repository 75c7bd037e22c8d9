// The Foxglove protocol's pieces (view/foxglove.hpp): subprotocol choice, the client's
// requests, the MessageData layout and the PoseArray CDR.

#include "foxglove.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <nlohmann/json.hpp>

namespace esfleet::view {
namespace {

TEST(Foxglove, SubprotocolIsChosenFromTheOffers) {
  EXPECT_EQ(foxglove_subprotocol("foxglove.websocket.v1"), "foxglove.websocket.v1");
  EXPECT_EQ(foxglove_subprotocol("chat, foxglove.sdk.v1"), "foxglove.sdk.v1");
  EXPECT_EQ(foxglove_subprotocol("foxglove.sdk.v1,foxglove.websocket.v1"), "foxglove.websocket.v1");
  EXPECT_EQ(foxglove_subprotocol(""), std::nullopt);
  EXPECT_EQ(foxglove_subprotocol("foxglove.websocket.v2"), std::nullopt);
  EXPECT_EQ(foxglove_subprotocol("xfoxglove.websocket.v1"), std::nullopt);
}

TEST(Foxglove, AdvertiseNamesBothChannels) {
  const auto j = nlohmann::json::parse(foxglove_advertise());
  ASSERT_EQ(j["channels"].size(), 2u);
  EXPECT_EQ(j["channels"][0]["topic"], "/map");
  EXPECT_EQ(j["channels"][0]["id"], kFoxgloveMapChannel);
  EXPECT_EQ(j["channels"][1]["schemaName"], "geometry_msgs/msg/PoseArray");
  EXPECT_EQ(nlohmann::json::parse(foxglove_server_info())["op"], "serverInfo");
}

TEST(Foxglove, RequestsAreReadOrIgnored) {
  const FoxgloveRequest r = parse_foxglove_request(
      R"({"op":"subscribe","subscriptions":[{"id":3,"channelId":1},{"id":4,"channelId":2},)"
      R"({"id":5,"channelId":99},{"id":-1,"channelId":1},{"channelId":1}]})");
  ASSERT_EQ(r.subscribe.size(), 2u);
  EXPECT_EQ(r.subscribe[0], (std::pair<std::uint32_t, std::uint32_t>{3, 1}));
  EXPECT_EQ(r.subscribe[1], (std::pair<std::uint32_t, std::uint32_t>{4, 2}));
  EXPECT_EQ(parse_foxglove_request(R"({"op":"unsubscribe","subscriptionIds":[3,"x"]})").unsubscribe,
            std::vector<std::uint32_t>{3});
  for (const char* bad :
       {"", "{", "[]", R"({"op":1})", R"({"op":"advertise"})",
        R"({"op":"subscribe","subscriptions":{}})",
        R"({"op":"subscribe","subscriptions":[{"id":99999999999,"channelId":1}]})"}) {
    const FoxgloveRequest b = parse_foxglove_request(bad);
    EXPECT_TRUE(b.subscribe.empty() && b.unsubscribe.empty()) << bad;
  }
}

TEST(Foxglove, MessageDataLayout) {
  const std::string m = foxglove_message_data(0x01020304, 0x1122334455667788ull, "abc");
  ASSERT_EQ(m.size(), 16u);
  EXPECT_EQ(m[0], 0x01);
  std::uint32_t id;
  std::uint64_t t;
  std::memcpy(&id, m.data() + 1, 4);
  std::memcpy(&t, m.data() + 5, 8);
  EXPECT_EQ(id, 0x01020304u);
  EXPECT_EQ(t, 0x1122334455667788ull);
  EXPECT_EQ(m.substr(13), "abc");
}

TEST(Foxglove, PoseArrayCdr) {
  const std::string c = pose_array_cdr({{1.0, 2.0, M_PI / 2}, {-3.0, 4.5, 0.0}}, 12.25);
  // encapsulation, stamp (8), frame_id "map" (4 + 4), count (4), padding to 8, 2 x 7 doubles.
  ASSERT_EQ(c.size(), 4u + 8 + 8 + 4 + 4 + 2 * 56);
  EXPECT_EQ(c.substr(0, 4), std::string("\x00\x01\x00\x00", 4));
  std::int32_t sec;
  std::uint32_t nsec, count;
  std::memcpy(&sec, c.data() + 4, 4);
  std::memcpy(&nsec, c.data() + 8, 4);
  std::memcpy(&count, c.data() + 20, 4);
  EXPECT_EQ(sec, 12);
  EXPECT_EQ(nsec, 250000000u);
  EXPECT_EQ(c.substr(16, 4), std::string("map\0", 4));
  EXPECT_EQ(count, 2u);
  double pose[7];
  std::memcpy(pose, c.data() + 28, sizeof pose);
  EXPECT_EQ(pose[0], 1.0);
  EXPECT_EQ(pose[1], 2.0);
  EXPECT_NEAR(pose[5], std::sin(M_PI / 4), 1e-12);  // z of the quaternion: yaw 90 deg
  EXPECT_NEAR(pose[6], std::cos(M_PI / 4), 1e-12);
}

}  // namespace
}  // namespace esfleet::view
